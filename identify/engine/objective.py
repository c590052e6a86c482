"""The objective of the multi-model updating: the model evaluated at parameter values,
its modes paired with the measured ones, the weighted residuals and their Jacobian.

All configurations are evaluated together (paper eqs. 12-14): the paired model
frequencies of every configuration are stacked in measurement-row order, with their
exact derivatives, so the global sensitivity matrix is one array.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fem.model import LaminateSolution, SpecimenModel
from fem.solver.reduced_basis import OutsideBasis, Reanalysis
from fem.specimen import Parameter, Specimen

from ..measurements import Measurements
from . import ties
from .pairing import ModePairing
from .parameters import ParameterSpace
from .statistics import FitStatistics, weighted_residuals

#: Singular values of the Jacobian below this fraction of the largest span its null
#: space: the pseudo-inverse of the paper's eq. 15 drops them.
NULL_SINGULAR_VALUE = 1e-12


@dataclass(frozen=True)
class Evaluation:
    """The model at one set of parameter values, paired with the measurements."""

    values: np.ndarray
    model_hz: np.ndarray            # paired model frequencies, measurement row order
    derivatives: np.ndarray | None  # d f / d p of the paired modes (rows x parameters); None: not computed
    pairings: dict[str, ModePairing]
    model: SpecimenModel


def solving_model(model: SpecimenModel, measurements: Measurements, extra_modes: int = 3) -> SpecimenModel:
    """The model as the updating solves it: the mesh the measured modes need (the default
    rule for the highest measured rank) and ``extra_modes`` more modes, so a mode may be
    followed when it moves past the last measured one."""
    highest = int(measurements.table["mode"].max())
    divisions = replace(model.options, modes=highest).divisions_for(model.specimen)
    return model.with_options(modes=highest + extra_modes, divisions=divisions)


class Objective:
    """Evaluates the model for parameter values and pairs its modes with the measurements."""

    def __init__(self, model: SpecimenModel, measurements: Measurements, parameters, extra_modes: int = 3):
        self.model = model
        self.measurements = measurements
        self.space = ParameterSpace.of(parameters, model.specimen)
        table = measurements.table
        self.configurations = measurements.configurations
        self.solved = solving_model(model, measurements, extra_modes)
        self.measured_hz = table["frequency_hz"].to_numpy()
        self.sigma = table["std_hz"].to_numpy() if measurements.has_std else self.measured_hz.copy()
        self.rows = {c: np.flatnonzero(table["configuration"].to_numpy() == c) for c in self.configurations}

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        return self.space.parameters

    def evaluate(self, values: np.ndarray, pairings: dict[str, ModePairing] | None, track: bool = True,
                 differentiate: bool = True) -> Evaluation:
        """The model at ``values``; modes paired afresh (``pairings`` None: by rank or
        label), followed from the previous pairings by their shapes, or (``track``
        False) paired with the same model modes as ``pairings`` say.  Without
        ``differentiate`` the sensitivities are left out (a trial step that may be
        rejected; ``differentiated`` adds them)."""
        specimen = ties.apply(self.model.specimen, self.space.parameters, values)
        weight = None
        model_hz = np.empty(len(self.measured_hz))
        derivatives = np.empty((len(self.measured_hz), len(values))) if differentiate else None
        new_pairings = {}
        for name in self.configurations:
            solution = self.solution(specimen, name)
            rows = self.rows[name]
            group = self.measurements.table.iloc[rows]
            previous = None if pairings is None else pairings[name].shapes
            if previous is None or (track and previous.shape[0] != solution.modes.shapes.shape[0]):
                # Afresh; also when the pairing to follow is of another model (another plate theory).
                pairing = ModePairing.initial(name, solution, group["mode"].to_numpy(), group["label"].tolist(),
                                              self.measurements.shapes_of(group))
            elif not track:
                indices = pairings[name].indices
                pairing = ModePairing(name, indices, solution.modes.shapes[:, indices])
            else:
                units = solution.units
                if weight is None or weight.shape[0] != units.n_dofs:  # the layerwise DOFs differ per stack
                    weight = units.first_unit_mass
                pairing = pairings[name].track(solution.modes, weight)
            new_pairings[name] = pairing
            model_hz[rows] = solution.frequencies_hz[pairing.indices]
            if differentiate:
                derivatives[rows] = ties.derivatives(solution, self.space.parameters)[pairing.indices]
        return Evaluation(values, model_hz, derivatives, new_pairings, self.model.with_specimen(specimen))

    def solution(self, specimen: Specimen, configuration: str) -> LaminateSolution:
        """The modes of one configuration of ``specimen``: a full solve (cached by content)."""
        return self.solved.with_specimen(specimen).solve(configuration)

    def differentiated(self, e: Evaluation) -> Evaluation:
        """``e`` with its sensitivities (the solves are cached: no new eigen-solve)."""
        if e.derivatives is not None:
            return e
        derivatives = np.empty((len(self.measured_hz), len(e.values)))
        for name in self.configurations:
            solution = self.solution(e.model.specimen, name)
            derivatives[self.rows[name]] = ties.derivatives(solution, self.space.parameters)[e.pairings[name].indices]
        return replace(e, derivatives=derivatives)

    def residual(self, e: Evaluation) -> np.ndarray:
        """Weighted residuals (model - measured) / sigma."""
        return weighted_residuals(e.model_hz, self.measurements)

    def jacobian(self, e: Evaluation) -> np.ndarray:
        """d residual / d z."""
        return e.derivatives * self.space.dvalue_dz(e.values)[None, :] / self.sigma[:, None]

    def cost(self, e: Evaluation) -> float:
        r = self.residual(e)
        return 0.5 * float(r @ r)

    def rms(self, e: Evaluation) -> float:
        """RMS of the relative frequency errors."""
        return float(np.sqrt(np.mean((e.model_hz / self.measured_hz - 1) ** 2)))

    def statistics(self, e: Evaluation) -> FitStatistics:
        return FitStatistics.of(e.model_hz, self.measurements, len(e.values))

    def std_z(self, e: Evaluation) -> np.ndarray:
        """Linearised std of each z at ``e`` (scatter from std_hz, or from the residual);
        infinite for a parameter the data do not determine (it has a share in the null
        space of the Jacobian)."""
        _, s, vt = np.linalg.svd(self.jacobian(e), full_matrices=False)
        null = s <= NULL_SINGULAR_VALUE * s[0]
        variance = self.statistics(e).chi2_unit * np.sum((vt[~null] / s[~null, None]) ** 2, axis=0)
        undetermined = np.sum(vt[null] ** 2, axis=0) > 1e-6
        return np.where(undetermined, np.inf, np.sqrt(variance))


class RitzObjective(Objective):
    """``objective`` evaluated on Ritz models of every configuration
    (``fem.solver.reduced_basis``) at the point ``at`` (full solves), their bases
    enlarged by the modes at the point ``also``."""

    def __init__(self, objective: Objective, at: Evaluation, also: Evaluation):
        self.__dict__.update(objective.__dict__)
        solved = objective.solved.with_specimen(at.model.specimen)
        self.reanalyses = {name: Reanalysis.of(solved, name, objective.solution(also.model.specimen, name).modes.shapes)
                           for name in self.configurations}

    def solution(self, specimen: Specimen, configuration: str) -> LaminateSolution:
        return self.reanalyses[configuration].solve(specimen)


@dataclass(frozen=True)
class TrialScreen:
    """Whether a trial step from ``current`` lowers the misfit, judged on the Ritz models:
    a rejected step of the damped Gauss-Newton iteration then costs a dense eigenproblem
    of a few dozen unknowns, not a factorization.

    When an iteration's first trial step raises the misfit, the iteration damps the step
    and tries again, up to ``FitOptions.max_damping_tries`` times; at the end of a fit on
    real data, where the misfit is flat, it often tries them all (a thick-plate refit of a
    long spruce plate's peak list: 45 of 152 trials rejected, 44 of them in four such
    streaks).  After the first rejection the Ritz models are built on the modes of the
    current point and of the rejected trial: the shorter trials lie between the two, where
    they are accurate to a few 1e-5 (``tests/fem/test_reduced_basis.py``).  A trial is
    then solved in full only where the Ritz misfit is not above the current one, and
    accepted only where the full solve agrees: every accepted point is a full solve.
    """

    ritz: RitzObjective
    current: Evaluation
    cost: float

    @classmethod
    def of(cls, objective: Objective, current: Evaluation, rejected: Evaluation) -> TrialScreen:
        """The screen of the iteration at ``current`` whose trial ``rejected`` raised the misfit."""
        return cls(RitzObjective(objective, current, rejected), current, objective.cost(current))

    def descends(self, values: np.ndarray) -> bool:
        """The Ritz misfit at ``values`` is not above the current one (True also where the
        Ritz models do not apply: a layerwise stack whose groups changed)."""
        try:
            trial = self.ritz.evaluate(values, self.current.pairings, differentiate=False)
        except OutsideBasis:
            return True
        return self.ritz.cost(trial) <= self.cost


def relative_sensitivity(e: Evaluation) -> np.ndarray:
    """The paper's normalised sensitivity matrix (p / f) df/dp of the paired modes."""
    return e.derivatives * e.values[None, :] / e.model_hz[:, None]


__all__ = ["Evaluation", "Objective", "RitzObjective", "TrialScreen", "relative_sensitivity", "solving_model"]
