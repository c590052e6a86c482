"""Which transverse shear moduli the data can identify, decided from the conditioning.

The transverse-shear effects free G13 and G23 of every identified material.  How well
the frequencies determine them depends on the plate (its slenderness, the stack, the
configurations) and on the scatter, so the choice is made from the sensitivity matrix
augmented with them, evaluated once at the start (``precheck.Sensitivities``), through
the std it predicts for each at the stated scatter (or an assumed 0.1 %):

1. every G13 and G23 free on its own;
2. while one is predicted worse than ``SEPARATE_STD`` (relative), the material with the
   worst is given one scale for both (G23 / G13 kept at the start's ratio);
3. a scale still worse than ``FREE_STD`` is not freed: the data do not see it, and the
   material keeps its given or default values.

The outcome is said in words (which are free, which are scaled together, which keep
their value, and the predicted std that decided).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fem.laminates.material import SHEAR_MODULI
from fem.specimen import Parameter, Specimen

from ..engine.ties import Tied
from .precheck import Sensitivities

#: G13 and G23 of a material are freed separately when each is predicted within 30 % (1
#: std): determined to better than a factor 1.35 either way; otherwise one scale.
SEPARATE_STD = 0.3
#: A scale predicted worse than a factor e (1 std in log) is not worth freeing.
FREE_STD = 1.0


@dataclass(frozen=True)
class ShearChoice:
    """The parameters to free (plain G13/G23, or ``Tied`` scales) and what was decided."""

    parameters: tuple[Parameter, ...]
    separate: tuple[str, ...]  # materials with G13 and G23 free on their own
    scaled: tuple[str, ...]  # materials with one scale for both
    kept: tuple[str, ...]  # materials whose shear moduli stay at their values
    predicted: dict  # parameter name -> predicted relative std that decided

    def describe(self, specimen: Specimen) -> str:
        parts = []
        if self.separate:
            parts.append(f"G13 and G23 free for {', '.join(self.separate)}")
        if self.scaled:
            parts.append(
                f"one scale for G13 and G23 of {', '.join(self.scaled)} (the data cannot separate them: "
                f"predicted std of one above {100 * SEPARATE_STD:.0f} %; G23 / G13 kept at "
                + ", ".join(f"{_ratio(specimen, m):.3g}" for m in self.scaled)
                + ")"
            )
        if self.kept:
            parts.append(
                f"G13, G23 of {', '.join(self.kept)} not freed (the data do not see them: predicted std "
                f"above {100 * FREE_STD:.0f} %), kept at "
                + ", ".join(_values(specimen, m) for m in self.kept)
            )
        stds = ", ".join(f"{name} {100 * std:.2g} %" for name, std in self.predicted.items())
        return "transverse shear moduli: " + "; ".join(parts) + (f" (predicted std: {stds})" if stds else "")


def _ratio(specimen: Specimen, material: str) -> float:
    m = specimen.materials[material]
    g13, g23 = m.transverse_shear_moduli
    return g23 / g13


def _values(specimen: Specimen, material: str) -> str:
    m = specimen.materials[material]
    g13, g23 = m.transverse_shear_moduli
    default = " = G12 (default)" if m.defaulted_shear_moduli else ""
    return f"{material} G13 = {g13 / 1e9:.3g} GPa, G23 = {g23 / 1e9:.3g} GPa{default}"


def choose_shear_moduli(sensitivities: Sensitivities, base, shear, specimen: Specimen) -> ShearChoice:
    """The shear parameters to free among ``shear`` (plain G13/G23, or scales already
    ``Tied``), given the ``base`` parameters free too, from one evaluation's
    ``sensitivities``."""
    materials = list(dict.fromkeys(p.target for p in shear))
    own = {m: [p for p in shear if p.target == m] for m in materials}
    # "separate" -> "scaled" -> "kept"
    mode = {m: "scaled" if any(isinstance(p, Tied) for p in own[m]) else "separate" for m in materials}

    def chosen() -> list[Parameter]:
        out = []
        for m in materials:
            if mode[m] != "kept" and (mode[m] == "separate" or len(own[m]) == 1):
                out += own[m]
            elif mode[m] == "scaled":
                lead, *rest = sorted(own[m], key=lambda p: SHEAR_MODULI.index(p.kind))
                out.append(Tied.scale(lead, rest, specimen))
        return out

    predicted = {}
    while True:
        free = chosen()
        if not free:
            break
        std = sensitivities.predicted_std(list(base) + free)[len(base) :]
        predicted = {p.name: float(s) for p, s in zip(free, std)}
        # The worst parameter that can be acted on: a separate pair to scale, or a scale to keep.
        actionable = [
            i
            for i, p in enumerate(free)
            if std[i] > FREE_STD
            or (std[i] > SEPARATE_STD and mode[p.target] == "separate" and len(own[p.target]) > 1)
        ]
        if not actionable:
            break
        material = free[max(actionable, key=lambda i: std[i])].target
        mode[material] = "scaled" if mode[material] == "separate" and len(own[material]) > 1 else "kept"
    free = chosen()
    return ShearChoice(
        tuple(free),
        tuple(m for m in materials if mode[m] == "separate"),
        tuple(m for m in materials if mode[m] == "scaled"),
        tuple(m for m in materials if mode[m] == "kept"),
        {k: v for k, v in predicted.items() if any(p.name == k for p in free)},
    )


def freed_shear_moduli(result, nominal: Specimen) -> list[Parameter]:
    """The transverse shear parameters of a fit that an effect freed (not ones the spec
    identifies): plain G13/G23 or ``Tied`` scales."""
    return [
        p
        for p in result.parameters
        if p.kind in SHEAR_MODULI and p.kind not in nominal.materials[p.target].identify
    ]


def reconsidered(result, nominal: Specimen, scatter: float):
    """At a solution: the freed shear parameters chosen again (``choose_shear_moduli``) from
    the sensitivities there, not inflated by the misfit (a modulus may have moved to where
    the frequencies hardly see it, or another effect may have taken its part).  Returns
    (parameters, model, note) for a refit, or None when the choice stands: a pair the data
    no longer separate gets one scale (at the solution's ratio), a scale they no longer
    determine goes back to its given or default value."""
    shear = freed_shear_moduli(result, nominal)
    if not shear:
        return None
    sensitivities = Sensitivities(tuple(result.parameters), result.jacobian, result.jacobian, scatter)
    others = [p for p in result.parameters if p not in shear]
    specimen = result.model.specimen
    choice = choose_shear_moduli(sensitivities, others, shear, specimen)
    if set(choice.parameters) == set(shear):
        return None
    for material in choice.kept:
        specimen = with_shear_moduli(specimen, nominal.materials[material])
    changed = [m for m in choice.scaled if not any(isinstance(p, Tied) for p in shear if p.target == m)]
    parameters = list(choice.parameters)
    renamed, reached = {}, []
    for material in changed:
        # One scale at the spec's ratio G23 / G13 (given, or 1 by default), through the
        # geometric mean of the two values reached: the ratio reached is not determined.
        k = next(i for i, p in enumerate(parameters) if p.target == material)
        tied = parameters[k]
        g13, g23 = specimen.materials[material].transverse_shear_moduli
        n13, n23 = nominal.materials[material].transverse_shear_moduli
        ratio = n23 / n13
        lead = float(np.sqrt(g13 * g23 / ratio))
        reached.append(
            f"{material}: G23 / G13 = {ratio:.3g}, the spec's (reached: {g23 / g13:.3g}, not determined)"
        )
        parameters[k] = Tied(tied.kind, tied.target, tuple((f, ratio) for f, _ in tied.followers))
        renamed[tied.name] = parameters[k].name
        specimen = specimen.with_values(
            {Parameter("G13", material): lead, Parameter("G23", material): ratio * lead}
        )
    parts = [f"one scale for G13 and G23 of {', '.join(changed)} ({'; '.join(reached)})"] if changed else []
    if choice.kept:
        parts.append(
            "G13, G23 of "
            + ", ".join(choice.kept)
            + " no longer free: "
            + ", ".join(_values(specimen, m) for m in choice.kept)
        )
    stds = ", ".join(f"{renamed.get(name, name)} {100 * std:.2g} %" for name, std in choice.predicted.items())
    note = (
        f"transverse shear moduli chosen again at the solution (the data no longer determine them as freed): "
        f"{'; '.join(parts)}" + (f" (std there: {stds})" if stds else "")
    )
    return others + parameters, result.model.with_specimen(specimen), note


def with_shear_moduli(specimen: Specimen, nominal) -> Specimen:
    """The specimen with one material's G13, G23 as ``nominal`` has them (given or default)."""
    return specimen.with_materials(
        [replace(specimen.materials[nominal.name], G13=nominal.G13, G23=nominal.G23)]
    )


__all__ = [
    "ShearChoice",
    "choose_shear_moduli",
    "reconsidered",
    "with_shear_moduli",
    "SEPARATE_STD",
    "FREE_STD",
]
