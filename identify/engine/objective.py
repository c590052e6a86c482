"""The objective of the multi-model updating: the model evaluated at parameter values,
its modes paired with the measured ones, the weighted residuals and their Jacobian.

All configurations are evaluated together (paper eqs. 12-14): the paired model
frequencies of every configuration are stacked in measurement-row order, with their
exact derivatives, so the global sensitivity matrix is one array.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace

import numpy as np

from fem.model import MAX_SOLVED_MODES, LaminateSolution, SpecimenModel
from fem.solver.reduced_basis import ReducedModel
from fem.specimen import Parameter

from ..measurements import Measurements
from .pairing import ModePairing
from .parameters import ParameterSpace
from . import ties
from .statistics import FitStatistics, weighted_residuals

#: Singular values of the Jacobian below this fraction of the largest span its null
#: space: the pseudo-inverse of the paper's eq. 15 drops them.
NULL_SINGULAR_VALUE = 1e-12
#: Reanalysis: basis modes per solved mode, and how far (in z: a relative change of a
#: modulus, a plate length of a position) the parameters may move from the basis point
#: before the basis is solved again there.  Ritz frequencies err at second order in the
#: move, the modes and so the sensitivities at first order: on the paper's plate, moving
#: the coatings and steel 2 % against the brass gives the frequencies within 4e-5 and the
#: sensitivities within 2 % (a Gauss-Newton step needs the direction; full solves finish).
BASIS_PER_MODE = 1.5
REBASE_STEP = 0.02


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


@dataclass(frozen=True)
class _Basis:
    """A configuration's reanalysis basis: the full solve at ``z`` (with
    ``BASIS_PER_MODE`` x the modes) and its projection without attachments."""

    z: np.ndarray
    solution: LaminateSolution
    reduced: ReducedModel


class Objective:
    """Evaluates the model for parameter values and pairs its modes with the measurements.

    With ``reanalysis`` the modes come from Rayleigh-Ritz on a basis of modes solved in
    full near the point (``fem.solver.reduced_basis``), rebuilt once the parameters have
    moved ``REBASE_STEP`` in z from it: iterations cost a dense eigenproblem of a few
    tens of DOFs instead of a sparse solve.  Such an objective is for the way to a
    solution only; :meth:`exact` gives the one every accepted point is verified with.
    """

    def __init__(self, model: SpecimenModel, measurements: Measurements, parameters, extra_modes: int = 3,
                 reanalysis: bool = False):
        self.model = model
        self.measurements = measurements
        self.space = ParameterSpace.of(parameters, model.specimen)
        table = measurements.table
        self.configurations = measurements.configurations
        self.solved = solving_model(model, measurements, extra_modes)
        self.measured_hz = table["frequency_hz"].to_numpy()
        self.sigma = table["std_hz"].to_numpy() if measurements.has_std else self.measured_hz.copy()
        self.rows = {c: np.flatnonzero(table["configuration"].to_numpy() == c) for c in self.configurations}
        self.reanalysis = reanalysis and self.solved.options.theory != "layerwise"
        self._bases: dict[str, _Basis] = {}
        self._recent: dict[tuple, LaminateSolution] = {}

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        return self.space.parameters

    def exact(self) -> "Objective":
        """The same objective solving every point in full."""
        if not self.reanalysis:
            return self
        out = copy.copy(self)
        out.reanalysis, out._bases, out._recent = False, {}, {}
        return out

    def _solve(self, model: SpecimenModel, name: str, values: np.ndarray):
        """The configuration's solution at ``values``: full, or by reanalysis."""
        if not self.reanalysis:
            return model.solve(name)
        key = (name, values.tobytes())
        if key in self._recent:
            return self._recent[key]
        z = self.space.to_z(values)
        basis = self._bases.get(name)
        if basis is None or basis.solution.units.mesh != model.mesh or np.max(np.abs(z - basis.z)) > REBASE_STEP:
            modes = min(MAX_SOLVED_MODES, math.ceil(BASIS_PER_MODE * model.options.modes))
            full = model.with_options(modes=modes).solve(name)
            basis = self._bases[name] = _Basis(z, full, full.reduced(with_attachments=False))
        solution = basis.solution.reanalysed(basis.reduced, model.specimen.laminate(name),
                                             model.specimen.attachments, model.options.modes)
        if len(self._recent) >= 4 * len(self.configurations):  # a trial step and its successor: a few suffice
            self._recent.pop(next(iter(self._recent)))
        self._recent[key] = solution
        return solution

    def evaluate(self, values: np.ndarray, pairings: dict[str, ModePairing] | None, track: bool = True,
                 differentiate: bool = True) -> Evaluation:
        """The model at ``values``; modes paired afresh (``pairings`` None: by rank or
        label), followed from the previous pairings by their shapes, or (``track``
        False) paired with the same model modes as ``pairings`` say.  Without
        ``differentiate`` the sensitivities are left out (a trial step that may be
        rejected; ``differentiated`` adds them)."""
        model = self.solved.with_specimen(ties.apply(self.model.specimen, self.space.parameters, values))
        weight = None
        model_hz = np.empty(len(self.measured_hz))
        derivatives = np.empty((len(self.measured_hz), len(values))) if differentiate else None
        new_pairings = {}
        for name in self.configurations:
            solution = self._solve(model, name, values)
            rows = self.rows[name]
            group = self.measurements.table.iloc[rows]
            previous = None if pairings is None else pairings[name].shapes
            if previous is None or (track and previous.shape[0] != solution.modes.shapes.shape[0]):
                # Afresh; also when the pairing to follow is of another model (another plate theory).
                pairing = ModePairing.initial(name, solution, group["mode"].to_numpy(), group["label"].tolist())
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
        return Evaluation(values, model_hz, derivatives, new_pairings, self.model.with_specimen(model.specimen))

    def differentiated(self, e: Evaluation) -> Evaluation:
        """``e`` with its sensitivities (the solves are cached: no new eigen-solve)."""
        if e.derivatives is not None:
            return e
        model = self.solved.with_specimen(e.model.specimen)
        derivatives = np.empty((len(self.measured_hz), len(e.values)))
        for name in self.configurations:
            solution = self._solve(model, name, e.values)
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


def relative_sensitivity(e: Evaluation) -> np.ndarray:
    """The paper's normalised sensitivity matrix (p / f) df/dp of the paired modes."""
    return e.derivatives * e.values[None, :] / e.model_hz[:, None]


__all__ = ["Evaluation", "Objective", "relative_sensitivity", "solving_model"]
