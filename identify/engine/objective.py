"""The objective of the multi-model updating: the model evaluated at parameter values,
its modes paired with the measured ones, the weighted residuals and their Jacobian.

All configurations are evaluated together (paper eqs. 12-14): the paired model
frequencies of every configuration are stacked in measurement-row order, with their
exact derivatives, so the global sensitivity matrix is one array.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from fem.model import LaminateSolution, SpecimenModel, with_bending_modes
from fem.solver.mode_shapes import deflection_operator
from fem.solver.reduced_basis import OutsideBasis, Reanalysis
from fem.specimen import Parameter, Specimen

from ..measurements import Measurements
from . import ties
from .pairing import ModePairing, close_modes
from .parameters import ParameterSpace
from .statistics import FitStatistics, weighted_residuals

#: Singular values of the Jacobian below this fraction of the largest span its null
#: space: the pseudo-inverse of the paper's eq. 15 drops them.
NULL_SINGULAR_VALUE = 1e-12
#: The scatter of a measured shape's amplitude at a point, relative to the shape's
#: largest amplitude, the fit starts from: 1 %, what a roving-hammer test's LSFD shapes
#: show on a plate (``identify.recordings.shapes``: standard errors 0.1-1.4 % of the
#: largest for the well-excited modes).  The fit then takes it from the shapes' own
#: residuals (``ShapeObjective.rescaled``): a hammer landing 1 mm off its point moves a
#: 100 mm wave's amplitude by about 6 % of its largest, which no LSFD error shows.
SHAPE_SCATTER = 0.01


@dataclass(frozen=True)
class Evaluation:
    """The model at one set of parameter values, paired with the measurements."""

    values: np.ndarray
    model_hz: np.ndarray  # paired model frequencies, measurement row order
    derivatives: np.ndarray | None  # d f / d p of the paired modes (rows x parameters); None: not computed
    pairings: dict[str, ModePairing]
    model: SpecimenModel


def solving_model(model: SpecimenModel, measurements: Measurements, extra_modes: int = 3) -> SpecimenModel:
    """The model as the updating solves it: the mesh the measured modes need (the default
    rule for the highest measured rank) and ``extra_modes`` more modes, so a mode may be
    followed when it moves past the last measured one; and one more for every in-plane
    mode among them in any measured configuration (at the model's values): a test that
    measures the deflection sees only the bending modes, so every one of those it
    measured must be solved for a label or a shape to pair with, whatever in-plane modes
    lie between (a thick light sandwich's membrane modes: ``docs/diagnosis.md``, heldout5)."""
    highest = int(measurements.table["mode"].max())
    return with_bending_modes(
        model.with_options(modes=highest),
        measurements.configurations,
        bending_needed(measurements, extra_modes),
    )


def bending_needed(measurements: Measurements, extra_modes: int = 3) -> int:
    """The bending modes the updating solves in each configuration: the highest measured
    rank and ``extra_modes`` more (``solving_model``)."""
    return int(measurements.table["mode"].max()) + extra_modes


class Objective:
    """Evaluates the model for parameter values and pairs its modes with the measurements."""

    #: Whether the damped iteration screens its trial steps on Ritz models of this
    #: objective (``TrialScreen``; ``FitOptions.reanalysis``).
    trials_screened = True
    #: Whether each iteration first steps to the minimum of the Ritz models of its point
    #: (``updating.iterate``; ``FitOptions.reanalysis``).
    reduced_steps = True

    def __init__(self, model: SpecimenModel, measurements: Measurements, parameters, extra_modes: int = 3):
        self.model = model
        self.measurements = measurements
        self.space = ParameterSpace.of(parameters, model.specimen)
        table = measurements.table
        self.configurations = measurements.configurations
        self.solved = solving_model(model, measurements, extra_modes)
        self.highest_rank = int(table["mode"].max())
        self.bending = bending_needed(measurements, extra_modes)
        self.measured_hz = table["frequency_hz"].to_numpy()
        self.sigma = table["std_hz"].to_numpy() if measurements.has_std else self.measured_hz.copy()
        self.rows = {c: np.flatnonzero(table["configuration"].to_numpy() == c) for c in self.configurations}

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        return self.space.parameters

    def for_model(self, model: SpecimenModel, parameters) -> Objective:
        """This objective's data and solving options for ``model`` (solved as this one's,
        e.g. with an attachment added) with ``parameters`` free; nothing is solved."""
        out = copy.copy(self)
        out.model = model
        out.space = ParameterSpace.of(list(parameters), model.specimen)
        out.solved = self.solved.with_specimen(model.specimen)
        return out

    def evaluate(
        self,
        values: np.ndarray,
        pairings: dict[str, ModePairing] | None,
        track: bool = True,
        differentiate: bool = True,
    ) -> Evaluation:
        """The model at ``values``; modes paired afresh (``pairings`` None: by rank or
        label), followed from the previous pairings by their shapes, or (``track``
        False) paired with the same model modes as ``pairings`` say.  Without
        ``differentiate`` the sensitivities are left out (a trial step that may be
        rejected; ``differentiated`` adds them)."""
        specimen = ties.apply(self.model.specimen, self.space.parameters, values)
        model_hz = np.empty(len(self.measured_hz))
        derivatives = np.empty((len(self.measured_hz), len(values))) if differentiate else None
        new_pairings = {}
        for name in self.configurations:
            solution, rows = self.solution(specimen, name), self.rows[name]
            previous = None if pairings is None else pairings[name]
            if self._afresh(solution, previous, track):
                solution = self.with_measured_bending(specimen, name, solution)
            pairing = self._paired(name, solution, previous, track)
            new_pairings[name] = pairing
            model_hz[rows] = solution.frequencies_hz[pairing.indices]
            if differentiate:
                derivatives[rows] = ties.derivatives(solution, self.space.parameters)[pairing.indices]
        return Evaluation(values, model_hz, derivatives, new_pairings, self.model.with_specimen(specimen))

    @staticmethod
    def _afresh(solution, previous: ModePairing | None, track: bool) -> bool:
        """Whether ``_paired`` pairs afresh: there is no ``previous`` pairing to follow, or
        it is of another model (another plate theory)."""
        return (
            previous is None
            or previous.shapes is None
            or (track and previous.shapes.shape[0] != solution.modes.shapes.shape[0])
        )

    def with_measured_bending(self, specimen: Specimen, configuration: str, solution) -> LaminateSolution:
        """``solution`` (of ``configuration`` at ``specimen``), solved again with
        ``solving_model``'s ``bending`` modes when fewer of its modes bend than the highest
        measured rank: a fresh pairing needs every measured rank among the bending modes,
        and the in-plane modes move with the parameters (a foam sandwich's thin-plate fit
        that took its skins' G12 to its bound had nine membrane modes among the first
        fifteen: blind33).  The solving model then keeps the larger number of modes; it
        never shrinks.  Where the start's count suffices nothing changes."""
        if self.bends_enough(solution):
            return solution
        self.solved = with_bending_modes(
            self.solved.with_specimen(specimen), self.configurations, self.bending
        )
        return self.solution(specimen, configuration)

    def bends_enough(self, solution) -> bool:
        """Whether every measured rank is among ``solution``'s bending modes."""
        return int((~solution.moves_in_plane).sum()) >= self.highest_rank

    def _paired(self, name: str, solution, previous: ModePairing | None, track: bool) -> ModePairing:
        """The pairing of one configuration's modes in ``solution`` (``evaluate``): afresh
        (``_afresh``), its model modes kept (``track`` False), else followed by shape."""
        if self._afresh(solution, previous, track):
            group = self.measurements.table.iloc[self.rows[name]]
            return ModePairing.initial(
                name,
                solution,
                group["mode"].to_numpy(),
                group["label"].tolist(),
                self.measurements.shapes_of(group),
            )
        if not track:
            return ModePairing(name, previous.indices, solution.modes.shapes[:, previous.indices])
        return previous.track(solution.modes, solution.units.first_unit_mass)

    def solution(self, specimen: Specimen, configuration: str) -> LaminateSolution:
        """The modes of one configuration of ``specimen``: a full solve (cached by content)."""
        return self.solved.with_specimen(specimen).solve(configuration)

    def modes_at(self, e: Evaluation) -> dict[str, np.ndarray]:
        """The mode shapes (n_dofs, modes) of every configuration at ``e`` (full solves)."""
        return {name: self.solution(e.model.specimen, name).modes.shapes for name in self.configurations}

    def differentiated(self, e: Evaluation) -> Evaluation:
        """``e`` with its sensitivities (the solves are cached: no new eigen-solve)."""
        if e.derivatives is not None:
            return e
        derivatives = np.empty((len(self.measured_hz), len(e.values)))
        for name in self.configurations:
            solution = self.solution(e.model.specimen, name)
            derivatives[self.rows[name]] = ties.derivatives(solution, self.space.parameters)[
                e.pairings[name].indices
            ]
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

    def frequency_cost(self, e: Evaluation) -> float:
        r = Objective.residual(self, e)
        return 0.5 * float(r @ r)

    def rms(self, e: Evaluation) -> float:
        """RMS of the relative frequency errors."""
        return float(np.sqrt(np.mean((e.model_hz / self.measured_hz - 1) ** 2)))

    def statistics(self, e: Evaluation) -> FitStatistics:
        return FitStatistics.of(e.model_hz, self.measurements, len(e.values))

    def frequency_jacobian(self, e: Evaluation) -> np.ndarray:
        """The frequency rows of the Jacobian (all of it here)."""
        return self.jacobian(e)

    def std_z(self, e: Evaluation) -> np.ndarray:
        """Linearised std of each z at ``e`` (scatter from std_hz, or from the residual);
        infinite for a parameter the data do not determine (it has a share in the null
        space of the Jacobian)."""
        _, s, vt = np.linalg.svd(self.jacobian(e), full_matrices=False)
        null = s <= NULL_SINGULAR_VALUE * s[0]
        variance = self.statistics(e).chi2_unit * np.sum((vt[~null] / s[~null, None]) ** 2, axis=0)
        undetermined = np.sum(vt[null] ** 2, axis=0) > 1e-6
        return np.where(undetermined, np.inf, np.sqrt(variance))


def _real_unit(amplitude: np.ndarray) -> np.ndarray:
    """A measured (complex) shape turned to its most real phase, real part, unit length."""
    turned = (amplitude * np.exp(-0.5j * np.angle(np.sum(amplitude**2)))).real
    return turned / np.linalg.norm(turned)


class ShapeObjective(Objective):
    """The frequencies and the measured mode shapes together (``FitOptions.use_shapes``).

    Each measured shape whose paired mode has no other bending mode within
    ``CLOSE_MODES`` (a close pair's shapes mix in any proportion: they pin the pairing,
    not the stiffness) adds one residual per point: the model's paired mode at the
    points, scaled to unit length and turned to the measured sign, minus the measured
    shape at unit length, over its scatter (``SHAPE_SCATTER`` of the largest amplitude).
    Their derivatives come from the exact mode shape sensitivities
    (``LaminateSolution.shape_derivatives``).  The set of shapes used is fixed at the first
    evaluation, so the residual keeps its length through the iterations."""

    #: The Ritz models give no shapes at the points.
    reduced_steps = False

    def __init__(self, model: SpecimenModel, measurements: Measurements, parameters, extra_modes: int = 3):
        super().__init__(model, measurements, parameters, extra_modes)
        table = measurements.table
        self.shaped = [
            (row, shape) for row, shape in enumerate(measurements.shapes_of(table)) if shape is not None
        ]
        self.used: list[tuple[int, object]] | None = None
        # per shape used: of a point's amplitude, relative to its largest
        self.scatter: np.ndarray | None = None
        self._measured: list[np.ndarray] = []  # per shape used: the measured shape, real and at unit length
        # row -> (unit matrices, deflection at its points)
        self._operators: dict[int, tuple[object, object]] = {}
        self._jacobian: tuple[Evaluation, np.ndarray] | None = None  # the last one asked for

    def _local(self, row: int) -> tuple[str, int]:
        name = self.measurements.table["configuration"].iloc[row]
        return name, int(np.flatnonzero(self.rows[name] == row)[0])

    def shapes_used(self, e: Evaluation) -> list[tuple[int, object]]:
        """(row, shape) of the shapes in the objective, chosen at the first evaluation."""
        if self.used is None:
            self.used = []
            for row, shape in self.shaped:
                name, local = self._local(row)
                if (
                    len(close_modes(self.solution(e.model.specimen, name), e.pairings[name].indices[local]))
                    == 1
                ):
                    self.used.append((row, shape))
            self.scatter = np.full(len(self.used), SHAPE_SCATTER)
            self._measured = [_real_unit(shape.amplitude) for _, shape in self.used]
        return self.used

    def _model_shape(self, e: Evaluation, row: int, shape) -> tuple[np.ndarray, object, object, int]:
        """The paired mode at the shape's points, the deflection operator there (built once
        per mesh), the solution and the mode's index."""
        name, local = self._local(row)
        solution = self.solution(e.model.specimen, name)
        j = int(e.pairings[name].indices[local])
        units, at = self._operators.get(row, (None, None))
        if units is not solution.units:
            at = deflection_operator(solution.units, shape.xy[:, 0], shape.xy[:, 1])
            self._operators[row] = (solution.units, at)
        return at @ solution.modes.shapes[:, j], at, solution, j

    def shape_residual(self, e: Evaluation) -> np.ndarray:
        return np.concatenate(self._shape_blocks(e)) if self.shapes_used(e) else np.zeros(0)

    def _shape_blocks(self, e: Evaluation) -> list[np.ndarray]:
        out = []
        for k, (row, shape) in enumerate(self.shapes_used(e)):
            x, measured = self._model_shape(e, row, shape)[0], self._measured[k]
            unit = x / np.linalg.norm(x) * np.sign(x @ measured)
            out.append((unit - measured) / (self.scatter[k] * np.abs(measured).max()))
        return out

    def residual(self, e: Evaluation) -> np.ndarray:
        """Weighted residuals: the frequencies', then the shapes' (class docstring)."""
        return np.concatenate([super().residual(e), self.shape_residual(e)])

    def jacobian(self, e: Evaluation) -> np.ndarray:
        """d residual / d z, the shapes' rows from the exact shape sensitivities."""
        if self._jacobian is not None and self._jacobian[0] is e:
            return self._jacobian[1]
        used = self.shapes_used(e)
        modes: dict[str, list[int]] = {}  # per configuration, the modes whose derivatives are wanted
        for row, _ in used:
            name, local = self._local(row)
            modes.setdefault(name, []).append(int(e.pairings[name].indices[local]))
        derivatives = {
            name: (js, self.solution(e.model.specimen, name).shape_derivatives(list(self.parameters), js))
            for name, js in modes.items()
        }  # one K, M and dK, dM per configuration
        rows = []
        for k, (row, shape) in enumerate(used):
            x, at, _, j = self._model_shape(e, row, shape)
            measured = self._measured[k]
            norm, sign = np.linalg.norm(x), np.sign(x @ measured)
            unit = x / norm
            js, d_phi = derivatives[self._local(row)[0]]
            dx = at @ d_phi[:, js.index(j), :]  # (points, parameters)
            d_unit = sign * (dx - np.outer(unit, unit @ dx)) / norm
            rows.append(d_unit / (self.scatter[k] * np.abs(measured).max()))
        shapes = (
            np.vstack(rows) * self.space.dvalue_dz(e.values)[None, :]
            if rows
            else np.zeros((0, len(e.values)))
        )
        out = np.vstack([super().jacobian(e), shapes])
        self._jacobian = (e, out)
        return out

    def frequency_jacobian(self, e: Evaluation) -> np.ndarray:
        return super().jacobian(e)

    def rescaled(self, e: Evaluation) -> float:
        """Each shape's scatter as its residuals at ``e`` say (the RMS of its weighted
        residuals x the scatter it had), set as the objective's: a hammer's position
        error grows with a mode's slopes, so each mode has its own.  Returns the largest
        factor a scatter changed by (or its inverse, when below 1)."""
        blocks = self._shape_blocks(e)
        if not blocks:
            return 1.0
        factors = np.array([np.sqrt(np.mean(b**2)) for b in blocks])
        self.scatter = self.scatter * factors
        self._jacobian = None
        return float(np.max(np.maximum(factors, 1 / factors)))


class RitzObjective(Objective):
    """``objective`` evaluated on Ritz models of every configuration
    (``fem.solver.reduced_basis``) at the point ``at`` (full solves), their bases
    enlarged by the ``extra`` fields of each configuration (the modes at other points on
    the same mesh: ``Objective.modes_at``).  ``assembled``: each point's K and M are
    assembled and projected (a screen evaluates a few: projecting every unit matrix of the
    layerwise element costs one to three full solves a configuration, as much as the
    trials a screen saves); else the unit matrices are projected once and a point costs
    milliseconds, its sensitivities included (the pairing screen's refits,
    ``ambiguity.RITZ_SCREEN_CHI2``)."""

    #: Its own trials cost what a screen's do.
    trials_screened = False
    reduced_steps = False

    def __init__(self, objective: Objective, at: Evaluation, extra: dict, assembled: bool = True):
        self.__dict__.update(objective.__dict__)
        solved = objective.solved.with_specimen(at.model.specimen)
        self.reanalyses = {
            name: Reanalysis.of(solved, name, extra.get(name), assembled=assembled)
            for name in self.configurations
        }
        self._anchors: dict[str, tuple] = {}

    def solution(self, specimen: Specimen, configuration: str) -> LaminateSolution:
        return self.reanalyses[configuration].solve(specimen)

    def with_measured_bending(self, specimen: Specimen, configuration: str, solution) -> LaminateSolution:
        """``solution`` where enough of its modes bend; a Ritz model cannot solve more
        modes, so elsewhere the point is outside its basis (the full solve decides)."""
        if self.bends_enough(solution):
            return solution
        raise OutsideBasis(
            f"configuration {configuration!r}: fewer than {self.highest_rank} bending modes in the basis"
        )

    def _anchor(self, pairing: ModePairing) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For following modes from ``pairing``'s shapes a (n_dofs, m): a^T W V, a^T W a
        and V^T W V, W the first unit mass, V the basis (the MAC of ``mac_matrix`` then
        costs products of the basis's size, with no shape expanded)."""
        name = pairing.configuration
        if name not in self._anchors or self._anchors[name][0] is not pairing.shapes:
            basis = self.reanalyses[name].basis
            weight = self.reanalyses[name].base.units.first_unit_mass
            a, wv = pairing.shapes, weight @ basis
            self._anchors[name] = (a, a.T @ wv, np.einsum("ij,ij->j", a, weight @ a), basis.T @ wv)
        return self._anchors[name][1:]

    def _paired(self, name: str, solution, previous: ModePairing, track: bool) -> ModePairing:
        """The Ritz modes followed from ``previous`` by MAC in the basis's coordinates; the
        pairing passes ``previous``'s shapes on unchanged, so every point of a Ritz
        iteration follows its modes from its full start."""
        indices, lowest = previous.indices, previous.lowest_mac
        if track:
            cross, norms, gram = self._anchor(previous)
            y = solution.modes.coordinates
            mac = (cross @ y) ** 2 / np.outer(norms, np.einsum("ij,ij->j", y, gram @ y))
            assigned, columns = linear_sum_assignment(-mac)
            indices, lowest = columns[np.argsort(assigned)], float(mac[assigned, columns].min())
        return ModePairing(name, indices, previous.shapes, lowest)


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
        # The screen compares frequency misfits (a Ritz model's shapes at the points are
        # not worth the screen's while); the full solve decides with the whole objective.
        ritz = RitzObjective(objective, current, objective.modes_at(rejected))
        return cls(ritz, current, objective.frequency_cost(current))

    def descends(self, values: np.ndarray) -> bool:
        """The Ritz misfit at ``values`` is not above the current one (True also where the
        Ritz models do not apply: a layerwise stack whose groups changed)."""
        try:
            trial = self.ritz.evaluate(values, self.current.pairings, differentiate=False)
        except OutsideBasis:
            return True
        return self.ritz.cost(trial) <= self.cost


#: A parameter whose value is below this share of its fit variable's unit is at zero for
#: the relative sensitivity matrix (``relative_sensitivity``): nu12 held on its bound (a
#: real-like spruce plate's fit ended at 1e-10) is; a modulus, whose unit is its value,
#: never is.
NEGLIGIBLE_VALUE = 1e-6


def relative_sensitivity(e: Evaluation, space: ParameterSpace) -> np.ndarray:
    """The paper's normalised sensitivity matrix (p / f) df/dp of the paired modes.  A
    parameter at zero (below ``NEGLIGIBLE_VALUE`` of its fit variable's unit: nu12 held on
    its bound, a position on an edge) is scaled by that unit instead
    (``ParameterSpace.dvalue_dz``: 1 for nu12, a plate length for a position): there
    p / f makes its column vanish, the matrix singular and every parameter's std void,
    although the frequencies see it (real-like spruce plates' thin-plate fits, nu12 on its
    bound: E1, E2, G12 all "not identifiable", condition number inf or 2e11)."""
    unit = space.dvalue_dz(e.values)
    scale = np.where(np.abs(e.values) > NEGLIGIBLE_VALUE * np.abs(unit), e.values, unit)
    return e.derivatives * scale[None, :] / e.model_hz[:, None]


__all__ = [
    "Evaluation",
    "Objective",
    "RitzObjective",
    "ShapeObjective",
    "TrialScreen",
    "relative_sensitivity",
    "solving_model",
]
