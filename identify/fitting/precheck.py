"""Before refitting with an effect: can its parameters be identified at all?

One evaluation of the model with the effect switched on (one solve per configuration, at
the start values, modes paired by rank and label) gives the sensitivity matrix augmented
with the effect's parameters.  Its condition number (the paper's criterion, on the
relative sensitivities (p / f) df/dp) says whether the refit can determine them: a
singular augmented matrix means a combination of the effect's and the layers' parameters
changes no frequency (a layer's thickness against its moduli), and the candidate is
reported as not identifiable without iterating.  The same evaluation predicts each
parameter's std at the stated scatter (or an assumed 0.1 %), which decides how the
transverse shear moduli are freed (``shear_moduli``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.model import SpecimenModel
from fem.solver.reduced_basis import OutsideBasis
from fem.solver.sensitivity import SINGULAR_ABOVE, Verdict, condition_verdict
from fem.specimen import Parameter

from ..engine.objective import Objective, RitzObjective, relative_sensitivity
from ..engine.result import FitResult
from ..engine.statistics import ASSUMED_SCATTER_REL
from ..engine.ties import Tied
from ..engine.uncertainty import condition_number, describe_combination
from ..measurements import Measurements

#: The augmented matrix is singular when its condition number exceeds the paper's limit
#: (``SINGULAR_ABOVE``, 1e7) and this many times the layer parameters' own (a baseline that
#: is ill-conditioned already does not make every effect look singular).
SINGULAR_GROWTH = 1e3


@dataclass(frozen=True)
class Sensitivities:
    """The model with an effect on, evaluated once at its start: ``relative`` (p / f)
    df/dp and ``jacobian`` d r / d z (z = log p for positive kinds) of the paired modes,
    one column per (plain) parameter; ``scatter``: the relative scatter the weighted
    residuals are in units of (1 with std_hz, else the assumed 0.1 %)."""

    parameters: tuple[Parameter, ...]
    relative: np.ndarray
    jacobian: np.ndarray
    scatter: float
    residual: np.ndarray | None = None  # weighted residuals at the start

    @classmethod
    def at_start(
        cls, model: SpecimenModel, measurements: Measurements, parameters, pairings: dict | None = None
    ) -> Sensitivities:
        """At the model's values, the modes paired afresh or followed from ``pairings``."""
        objective = Objective(model, measurements, list(parameters))
        return cls._at(objective, model, pairings)

    @classmethod
    def on_state_modes(
        cls, state: FitResult, model: SpecimenModel, measurements: Measurements, parameters
    ) -> Sensitivities:
        """As ``at_start`` (the modes followed from ``state``'s pairing), on the
        Rayleigh-Ritz models of ``state``'s full solves (its modes and the rigid-body
        fields, ``RitzObjective``) instead of a solve of every configuration: for starts
        that the state's modes span (``Effect.other_starts_spanned``), a fraction of a
        second where a layerwise evaluation costs seconds.  In full where ``model`` is
        solved otherwise than the state (another theory or mesh) or leaves the basis."""
        if model.options != state.model.options or state.pairings is None:
            return cls.at_start(model, measurements, parameters, state.pairings)
        own = Objective(state.model, measurements, list(state.parameters))
        at = own.evaluate(state.values, state.pairings, track=False, differentiate=False)
        ritz = RitzObjective(own.for_model(model, parameters), at, {})
        try:
            return cls._at(ritz, model, state.pairings)
        except OutsideBasis:
            return cls.at_start(model, measurements, parameters, state.pairings)

    @classmethod
    def _at(cls, objective: Objective, model: SpecimenModel, pairings: dict | None) -> Sensitivities:
        """``objective`` evaluated at ``model``'s values of its parameters."""
        parameters = objective.space.parameters
        values = objective.space.clip(np.array([model.value(p) for p in parameters], dtype=float))
        evaluation = objective.evaluate(values, pairings)
        scatter = 1.0 if objective.measurements.has_std else ASSUMED_SCATTER_REL
        return cls(
            tuple(parameters),
            relative_sensitivity(evaluation, objective.space),
            objective.jacobian(evaluation),
            scatter,
            objective.residual(evaluation),
        )

    def predicted_sum_squares(self, parameters) -> float:
        """The weighted sum of squares one full Gauss-Newton step from the start would
        leave (the linearised refit)."""
        _, jac = self.columns(parameters)
        step, *_ = np.linalg.lstsq(jac, self.residual, rcond=None)
        left = self.residual - jac @ step
        return float(left @ left)

    def columns(self, parameters) -> tuple[np.ndarray, np.ndarray]:
        """(relative, jacobian) for ``parameters``: plain ones are columns of this
        evaluation, a ``Tied`` one (log kinds) the sum of its members' columns."""
        index = {p: i for i, p in enumerate(self.parameters)}
        rel, jac = [], []
        for p in parameters:
            members = (
                [p]
                if p in index or not isinstance(p, Tied)
                else [Parameter(p.kind, p.target)] + [f for f, _ in p.followers]
            )
            rel.append(sum(self.relative[:, index[m]] for m in members))
            jac.append(sum(self.jacobian[:, index[m]] for m in members))
        return np.column_stack(rel), np.column_stack(jac)

    def predicted_std(self, parameters) -> np.ndarray:
        """Linearised std of z (relative std for log parameters) of each parameter, all
        of ``parameters`` free; infinite for one the data do not determine."""
        _, jac = self.columns(parameters)
        _, s, vt = np.linalg.svd(jac, full_matrices=False)
        null = s <= 1e-12 * s[0]
        std = self.scatter * np.sqrt(np.sum((vt[~null] / s[~null, None]) ** 2, axis=0))
        return np.where(np.sum(vt[null] ** 2, axis=0) > 1e-6, np.inf, std)


@dataclass(frozen=True)
class Precheck:
    """The conditioning of an effect's refit before it is run: the condition number of the
    relative sensitivity matrix with the effect's parameters (``condition_number``) and
    without them (``base_condition_number``), the verdict, and the combination that the
    frequencies do not see when it is singular."""

    condition_number: float
    base_condition_number: float
    weakest: str

    @property
    def verdict(self) -> Verdict:
        return condition_verdict(self.condition_number)

    @property
    def singular(self) -> bool:
        return self.singular_at(self.condition_number)

    def singular_at(self, condition_number: float) -> bool:
        """Whether a refit that ends at ``condition_number`` is singular by the same rule as
        its start: above the paper's limit and ``SINGULAR_GROWTH`` times the start's
        without the effect."""
        return bool(
            not condition_number <= SINGULAR_ABOVE
            and not condition_number <= SINGULAR_GROWTH * self.base_condition_number
        )

    def describe(self) -> str:
        with_it, without = self.condition_number, self.base_condition_number
        text = f"condition number {with_it:.3g} with the effect ({without:.3g} without)"
        if self.singular:
            text += f": singular, not identifiable (the frequencies do not see {self.weakest})"
        return text


def precheck(sensitivities: Sensitivities, base, added) -> Precheck:
    """The conditioning of ``base`` + ``added`` parameters from one evaluation."""
    parameters = list(base) + list(added)
    rel, _ = sensitivities.columns(parameters)
    _, s, vt = np.linalg.svd(rel, full_matrices=False)
    weakest = describe_combination(vt[-1], [p.name for p in parameters])
    base_condition = condition_number(rel[:, : len(base)]) if base else 1.0
    return Precheck(condition_number(rel), base_condition, weakest)


__all__ = ["Sensitivities", "Precheck", "precheck", "SINGULAR_GROWTH"]
