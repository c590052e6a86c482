"""Tied parameters: one unknown that moves several model parameters together.

When the frequencies cannot tell two parameters apart (a material's G13 and G23 on a
plate whose shear is seen only as a whole), the identification frees one scale for both:
the tied parameter is the leader (e.g. ``G13``), and each follower keeps its ratio to it
(``G23 = r G13`` with r from the start values).  Its frequency derivative is the chain
rule, df/dG13 + r df/dG23, from the same exact sensitivities.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.specimen import Parameter, Specimen


@dataclass(frozen=True)
class Tied(Parameter):
    """A parameter (``kind``, ``target``: the leader) with ``followers``: (parameter,
    ratio) pairs set to ratio x the leader's value."""

    followers: tuple[tuple[Parameter, float], ...] = ()

    @property
    def name(self) -> str:
        others = ", ".join(f"{f.kind} = {ratio:.3g} {self.kind}" for f, ratio in self.followers)
        return f"{self.target}.{self.kind} ({others})" if others else f"{self.target}.{self.kind}"

    @classmethod
    def scale(cls, leader: Parameter, followers: list[Parameter], specimen: Specimen) -> Tied:
        """The leader with ``followers`` kept at their present ratios to it."""
        value = specimen.value(leader)
        return cls(leader.kind, leader.target, tuple((f, specimen.value(f) / value) for f in followers))


def expanded(parameters, values: np.ndarray) -> dict[Parameter, float]:
    """Parameter -> value with every tied parameter's followers set (plain parameters as
    keys: a ``Tied`` leader becomes its plain ``Parameter``)."""
    out: dict[Parameter, float] = {}
    for p, v in zip(parameters, values):
        if isinstance(p, Tied):
            out[Parameter(p.kind, p.target)] = float(v)
            out.update({f: float(ratio * v) for f, ratio in p.followers})
        else:
            out[p] = float(v)
    return out


def apply(specimen: Specimen, parameters, values: np.ndarray) -> Specimen:
    """The specimen with these values, followers of tied parameters included."""
    return specimen.with_values(expanded(parameters, values))


def derivatives(solution, parameters) -> np.ndarray:
    """df/dp [Hz per SI unit] of every mode of ``solution`` for ``parameters``, a tied
    parameter's column being the chain rule over its followers."""
    parameters = list(parameters)
    if not any(isinstance(p, Tied) for p in parameters):
        return solution.derivatives(parameters)
    plain, columns = [], []
    for p in parameters:
        members = (
            [(Parameter(p.kind, p.target), 1.0)] + list(p.followers) if isinstance(p, Tied) else [(p, 1.0)]
        )
        column = []
        for member, ratio in members:
            if member not in plain:
                plain.append(member)
            column.append((plain.index(member), ratio))
        columns.append(column)
    d = solution.derivatives(plain)
    return np.column_stack([sum(ratio * d[:, j] for j, ratio in column) for column in columns])


def plain(parameter: Parameter) -> Parameter:
    """The leader as a plain parameter (a tied one's followers dropped)."""
    return Parameter(parameter.kind, parameter.target) if isinstance(parameter, Tied) else parameter


__all__ = ["Tied", "expanded", "apply", "derivatives", "plain"]
