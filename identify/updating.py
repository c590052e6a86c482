"""Multi-model updating (paper section 4.2, eqs. 12-15) with safeguards.

All configurations are updated at once: the relative frequency residuals of every
measured mode of every configuration are stacked, with the global sensitivity matrix,
and a Gauss-Newton step is taken with its pseudo-inverse (eq. 15).  Unlike the paper,
the step is damped (Levenberg-Marquardt) when it does not lower the misfit, limited in
size, and kept inside the physical bounds (positive moduli, nu12^2 < E1/E2).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from fem.errors import MeasurementError
from fem.model import ModelOptions, SpecimenModel
from fem.specimen import Parameter, Specimen

from .measurements import Measurements
from .pairing import ModePairing
from .parameters import ParameterSpace
from .uncertainty import Uncertainty

#: Adjacent measured modes closer than this (relative) may be paired either way round.
CLOSE_MODES = 0.01
#: The updating stops once the misfit has stalled (falls by less than this fraction) and
#: no parameter moves by more than STEP_PER_STD of its std.
STALLED = 1e-4
STEP_PER_STD = 0.01
#: Up to this many close pairs every assignment (2^k) is refitted; beyond, single swaps.
MAX_EXHAUSTIVE_PAIRS = 4


@dataclass(frozen=True)
class FitOptions:
    """Iteration control.  Steps and tolerances are in z: relative for log parameters."""

    max_iterations: int = 30
    parameter_tolerance: float = 1e-7   # stop when no parameter changes by more (relative)
    cost_tolerance: float = 1e-10       # ... or the misfit falls by less than this fraction
    max_log_step: float = 0.7           # largest relative change per step: a factor e^0.7 ~ 2
    max_linear_step: float = 0.1        # largest change of nu12 (or an angle in rad) per step
    extra_modes: int = 3                # model modes computed beyond the highest measured one
    max_damping_tries: int = 12


@dataclass(frozen=True)
class Iteration:
    """One accepted state of the updating (number 0 is the start)."""

    number: int
    values: np.ndarray
    model_hz: np.ndarray
    rms_rel_error: float
    cost: float
    step: float
    damping: float


@dataclass(frozen=True)
class Evaluation:
    """The model at one set of parameter values, paired with the measurements."""

    values: np.ndarray
    model_hz: np.ndarray            # paired model frequencies, measurement row order
    derivatives: np.ndarray         # d f / d p of the paired modes (rows x parameters)
    pairings: dict[str, ModePairing]
    specimen: Specimen


@dataclass(frozen=True)
class FitResult:
    """The outcome of an identification: parameters with uncertainties, history, residuals."""

    converged: bool
    status: str
    parameters: tuple[Parameter, ...]
    values: np.ndarray
    uncertainty: Uncertainty
    history: tuple[Iteration, ...]
    measurements: Measurements
    model_hz: np.ndarray
    specimen: Specimen
    warnings: tuple[str, ...] = field(default=())
    twins: tuple[np.ndarray, ...] = field(default=())  # other solutions that fit within the scatter
    pairings: dict = field(default_factory=dict)       # configuration -> final ModePairing
    jacobian: np.ndarray | None = None                 # weighted d residual / d z at the result
    effect_of: dict = field(default_factory=dict)      # parameter -> effect kind it belongs to

    @property
    def iterations(self) -> int:
        return len(self.history) - 1

    @property
    def rel_error(self) -> np.ndarray:
        """(model - measured) / measured per measured mode."""
        return self.model_hz / self.measurements.table["frequency_hz"].to_numpy() - 1

    @property
    def rms_rel_error(self) -> float:
        return float(np.sqrt(np.mean(self.rel_error**2)))

    def value(self, parameter: Parameter) -> float:
        return float(self.values[self.parameters.index(parameter)])

    def std(self, parameter: Parameter) -> float:
        return float(self.uncertainty.std[self.parameters.index(parameter)])


class Updater:
    """Evaluates the model for parameter values and pairs its modes with the measurements."""

    def __init__(self, specimen: Specimen, measurements: Measurements, parameters, model: ModelOptions,
                 options: FitOptions):
        self.specimen = specimen
        self.measurements = measurements
        self.space = ParameterSpace.of(parameters, specimen)
        table = measurements.table
        self.configurations = measurements.configurations
        highest = int(table["mode"].max())
        mesh = replace(model, modes=highest).mesh(specimen)
        self.model_options = replace(model, modes=highest + options.extra_modes, divisions=max(mesh.nx, mesh.ny))
        self.measured_hz = table["frequency_hz"].to_numpy()
        self.sigma = table["std_hz"].to_numpy() if measurements.has_std else self.measured_hz.copy()
        self.rows = {c: np.flatnonzero(table["configuration"].to_numpy() == c) for c in self.configurations}

    def evaluate(self, values: np.ndarray, pairings: dict[str, ModePairing] | None) -> Evaluation:
        specimen = self.space.apply(self.specimen, values)
        model = SpecimenModel(specimen, self.model_options)
        weight = None
        model_hz = np.empty(len(self.measured_hz))
        derivatives = np.empty((len(self.measured_hz), len(values)))
        new_pairings = {}
        for name in self.configurations:
            solution = model.solve(name)
            rows = self.rows[name]
            group = self.measurements.table.iloc[rows]
            if pairings is None:
                pairing = ModePairing.initial(name, solution.modes, group["mode"].to_numpy(), group["label"].tolist())
            else:
                if weight is None:
                    units = solution.units
                    weight = units.matrix(units.mass_data[0])
                pairing = pairings[name].track(solution.modes, weight)
            new_pairings[name] = pairing
            model_hz[rows] = solution.frequencies_hz[pairing.indices]
            derivatives[rows] = solution.derivatives(list(self.space.parameters))[pairing.indices]
        return Evaluation(values, model_hz, derivatives, new_pairings, specimen)

    def std_z(self, e: Evaluation) -> np.ndarray:
        """Linearised std of each z at ``e`` (scatter from std_hz, or from the residual)."""
        _, s, vt = np.linalg.svd(self.jacobian(e), full_matrices=False)
        if s[-1] <= 1e-12 * s[0]:
            return np.zeros(len(s))
        if self.measurements.has_std:
            scale = 1.0  # the stated scatter, never inflated by a misfit
        else:
            dof = len(self.measured_hz) - len(e.values)
            scale = 2 * self.cost(e) / dof if dof > 0 else 0.0
        return np.sqrt(scale * np.sum((vt / s[:, None]) ** 2, axis=0))

    def cost(self, e: Evaluation) -> float:
        r = self.residual(e)
        return 0.5 * float(r @ r)

    def rms(self, e: Evaluation) -> float:
        """RMS of the relative frequency errors."""
        return float(np.sqrt(np.mean((e.model_hz / self.measured_hz - 1) ** 2)))

    def noise_variance(self, e: Evaluation) -> float:
        """The scale of chi^2 differences: 1 with measured std, else the residual variance."""
        if self.measurements.has_std:
            return 1.0
        dof = len(self.measured_hz) - len(e.values)
        return max(2 * self.cost(e) / dof, 1e-30) if dof > 0 else 1e-30

    def close_pairs(self) -> list[tuple[int, int]]:
        """Rows of adjacent measured modes closer than ``CLOSE_MODES`` with no labels."""
        table = self.measurements.table
        pairs = []
        for rows in self.rows.values():
            for a, b in zip(rows[:-1], rows[1:]):
                ta, tb = table.iloc[a], table.iloc[b]
                if tb["mode"] == ta["mode"] + 1 and not ta["label"] and not tb["label"] \
                        and tb["frequency_hz"] / ta["frequency_hz"] - 1 < CLOSE_MODES:
                    pairs.append((int(a), int(b)))
        return pairs

    @property
    def mirror_symmetric(self) -> bool:
        """True when a 90-degree turn maps every configuration onto itself with only the
        identified materials' axes exchanged: a square plate, layer angles 0 or 90 deg,
        known materials in-plane isotropic.  Then E1 <-> E2 (nu12 -> nu21) of all
        identified materials together changes no frequency."""
        sp = self.specimen
        if abs(sp.length - sp.width) > 1e-9 * sp.length:
            return False
        kinds = {p.kind for p in self.space.parameters}
        if not kinds <= {"E1", "E2", "G12", "nu12", "density"}:
            return False
        identified = {p.target for p in self.space.parameters}
        for layer in sp.all_layers():
            if abs(np.sin(2 * layer.angle)) > 1e-12:
                return False
            m = layer.material
            if m.name not in identified and abs(m.E1 - m.E2) > 1e-12 * m.E1:
                return False
        return all({Parameter(k, t) for k in ("E1", "E2", "nu12")} <= set(self.space.parameters) for t in identified)

    def mirrored(self, values: np.ndarray) -> np.ndarray:
        """Values with E1 and E2 exchanged and nu12 -> nu21 for every identified material."""
        index = {p: i for i, p in enumerate(self.space.parameters)}
        out = values.copy()
        for p, i in index.items():
            if p.kind == "E1":
                j = index[Parameter("E2", p.target)]
                out[i], out[j] = values[j], values[i]
                n = index[Parameter("nu12", p.target)]
                out[n] = values[n] * values[j] / values[i]
        return out

    def anisotropy_sign(self, values: np.ndarray) -> float:
        """sign(D11 - D22) of the original plate with these values."""
        d = self.space.apply(self.specimen, values).laminate(self.specimen.configurations[0].name).stiffness
        return float(np.sign(d[12] - d[14]))

    def oriented_like_start(self, e: Evaluation) -> Evaluation:
        """The state or its exact mirror, whichever has D11 - D22 of the start's sign."""
        start = np.array([self.specimen.value(p) for p in self.space.parameters])
        if self.anisotropy_sign(e.values) * self.anisotropy_sign(start) >= 0:
            return e
        return self.evaluate(self.mirrored(e.values), None)

    def same_or_mirror(self, a: Evaluation, b: Evaluation, tolerance: float = 1e-4) -> bool:
        def close(x, y):
            return bool(np.all(np.abs(x / y - 1) < tolerance))

        return close(a.values, b.values) or (self.mirror_symmetric and close(self.mirrored(a.values), b.values))

    def describe_pairs(self, pairs) -> str:
        table = self.measurements.table
        return ", ".join(f"{table['configuration'].iloc[a]} {table['mode'].iloc[a]}/{table['mode'].iloc[b]}"
                         for a, b in pairs)

    def swapped(self, e: Evaluation, rows: tuple[int, int]) -> Evaluation:
        """The same state with the model partners of two measured rows exchanged."""
        configuration = self.measurements.table["configuration"].iloc[rows[0]]
        local = [int(np.flatnonzero(self.rows[configuration] == r)[0]) for r in rows]
        pairing = e.pairings[configuration]
        indices = pairing.indices.copy()
        indices[local] = indices[local[::-1]]
        shapes = pairing.shapes.copy()
        shapes[:, local] = shapes[:, local[::-1]]
        pairings = dict(e.pairings)
        pairings[configuration] = ModePairing(configuration, indices, shapes)
        model_hz, derivatives = e.model_hz.copy(), e.derivatives.copy()
        model_hz[list(rows)] = model_hz[list(rows[::-1])]
        derivatives[list(rows)] = derivatives[list(rows[::-1])]
        return Evaluation(e.values, model_hz, derivatives, pairings, e.specimen)

    def residual(self, e: Evaluation) -> np.ndarray:
        """Weighted residuals (model - measured) / sigma."""
        return (e.model_hz - self.measured_hz) / self.sigma

    def jacobian(self, e: Evaluation) -> np.ndarray:
        """d residual / d z."""
        return e.derivatives * self.space.dvalue_dz(e.values)[None, :] / self.sigma[:, None]


def fit(
    specimen: Specimen,
    measurements: Measurements,
    parameters: list[Parameter] | None = None,
    model: ModelOptions = ModelOptions(),
    options: FitOptions = FitOptions(),
    progress: Callable[[Iteration], None] | None = None,
    effects: dict[Parameter, str] | None = None,
) -> FitResult:
    """Identify ``parameters`` (default: E1, E2, G12, nu12 of every identified material)
    from measured frequencies of all configurations at once.  ``effects`` names the
    effect kind a parameter belongs to, for reporting."""
    parameters = list(parameters) if parameters is not None else specimen.material_parameters()
    if not parameters:
        raise MeasurementError("nothing to identify: mark at least one material with identify = true")
    if len(measurements) < len(parameters):
        raise MeasurementError(
            f"{len(measurements)} measured frequencies for {len(parameters)} unknown parameters: "
            "measure at least as many modes as unknowns (the paper uses 5 per configuration)"
        )
    updater = Updater(specimen, measurements, parameters, model, options)
    values = np.array([specimen.value(p) for p in parameters], dtype=float)
    current = updater.evaluate(values, None)
    start_notes = [p.note for p in current.pairings.values() if p.note]
    history = [Iteration(0, values, current.model_hz, updater.rms(current), updater.cost(current), 0.0, 0.0)]
    if progress:
        progress(history[-1])
    current, converged, status, warnings = _iterate(updater, current, history, options, progress)
    warnings = start_notes + warnings
    twins = []
    if converged:
        current, status, notes, twins = _explore_pairings(updater, current, history, options, status)
        warnings += notes
        if progress and notes:
            progress(history[-1])
    uncertainty = Uncertainty.at(updater, current, updater.residual(current))
    if converged and uncertainty.verdict == "singular":
        converged = False
        status = (f"not identifiable: the frequencies fit but the sensitivity matrix is singular (condition number "
                  f"{uncertainty.condition_number:.3g} > 1e7); the parameters are not determined by these data")
    return FitResult(converged, status, tuple(parameters), current.values, uncertainty, tuple(history),
                     measurements, current.model_hz, current.specimen, tuple(warnings) + uncertainty.warnings,
                     tuple(twins), current.pairings, updater.jacobian(current), dict(effects or {}))


def _iterate(updater: Updater, current: Evaluation, history: list, options: FitOptions, progress):
    """Damped Gauss-Newton iterations from ``current``; appends to ``history``."""
    space = updater.space
    r = updater.residual(current)
    damping, warnings = 0.0, []
    limit = np.where(space.is_log, options.max_log_step, options.max_linear_step)
    first = history[-1].number + 1
    for number in range(first, first + options.max_iterations):
        u, s, vt = np.linalg.svd(updater.jacobian(current), full_matrices=False)
        keep = s > 1e-12 * s[0]  # the pseudo-inverse of eq. 15 drops null directions
        ur = u.T @ r
        z = space.to_z(current.values)
        # Converged already?  Judge by the Gauss-Newton prediction before paying for solves.
        reducible = 0.5 * float(np.sum(ur[keep] ** 2))  # misfit a Gauss-Newton step could remove
        gauss_newton = vt.T @ np.where(keep, ur / np.where(keep, s, 1.0), 0.0)
        if reducible <= options.cost_tolerance * updater.cost(current) or \
                float(np.max(np.abs(gauss_newton))) < options.parameter_tolerance:
            return current, True, "converged: the Gauss-Newton step is below the tolerances", warnings
        accepted = None
        for _ in range(options.max_damping_tries):
            gain = np.where(keep, s / (s**2 + damping), 0.0)
            dz = -vt.T @ (gain * ur)
            dz *= min(1.0, float(np.min(limit / np.maximum(np.abs(dz), 1e-300))))
            trial_values = space.to_values(z + dz)
            for _ in range(30):  # keep inside the physical bounds (nu12^2 < E1/E2, on the plate)
                if space.admissible(updater.specimen, trial_values):
                    break
                dz *= 0.5
                trial_values = space.to_values(z + dz)
            else:
                damping = max(10 * damping, 1e-6 * s[0] ** 2)  # the step leaves the bounds: damp it
                continue
            trial = updater.evaluate(trial_values, current.pairings)
            if updater.cost(trial) <= updater.cost(current):
                accepted = (trial, dz)
                damping = damping / 10 if damping > 1e-9 * s[0] ** 2 else 0.0  # back to Gauss-Newton
                break
            damping = max(10 * damping, 1e-6 * s[0] ** 2)
        if accepted is None:
            return current, False, (f"stopped: no step lowered the misfit after {options.max_damping_tries} "
                                    "damping increases"), warnings
        previous_cost = updater.cost(current)
        current, dz = accepted
        r = updater.residual(current)
        step = float(np.max(np.abs(dz)))
        history.append(Iteration(number, current.values, current.model_hz, updater.rms(current),
                                 updater.cost(current), step, damping))
        if progress:
            progress(history[-1])
        lost = [p.configuration for p in current.pairings.values() if p.lost]
        if lost:
            warnings.append(f"iteration {number}: mode tracking uncertain in {', '.join(lost)} "
                            "(a mode shape changed strongly; check the pairing in the residual table)")
        if step < options.parameter_tolerance:
            return current, True, f"converged: parameter change {step:.1e} below {options.parameter_tolerance:g}", warnings
        stalled = previous_cost - updater.cost(current) <= STALLED * previous_cost
        if stalled and np.all(np.abs(dz) < STEP_PER_STD * updater.std_z(current)):
            return current, True, f"converged: every change below {STEP_PER_STD:g} of its parameter's std", warnings
        if updater.rms(current) < 1e-11:
            return current, True, "converged: the model reproduces the measurements exactly", warnings
        if previous_cost - updater.cost(current) <= options.cost_tolerance * previous_cost and step < 1e-4:
            return current, True, "converged: the misfit no longer falls", warnings
    return current, False, f"not converged in {options.max_iterations} iterations", warnings


def _explore_pairings(updater: Updater, current: Evaluation, history: list, options: FitOptions, status: str):
    """Refit with every other assignment of the close measured mode pairs that carry no label.

    Frequencies alone hardly tell two close modes apart: on a near-square plate the
    pair (1,2)/(2,1) may be 0.05 % apart, and with one such pair per configuration each
    of the 2^k assignments can be fitted, giving twin solutions that differ by percents
    in E1, E2 and nu12.  The lowest misfit wins; every assignment that fits within the
    scatter (chi^2 higher by less than 4) is returned as a twin, so the user learns that
    only mode shapes (a ``label`` column) can decide.
    """
    pairs = updater.close_pairs()
    if not pairs:
        return current, status, [], []
    if len(pairs) <= MAX_EXHAUSTIVE_PAIRS:
        combos = [c for k in range(1, len(pairs) + 1) for c in itertools.combinations(pairs, k)]
        if updater.mirror_symmetric:
            # Swapping a set of pairs or all the others gives mirror images (same misfit):
            # refit one of each.
            combos = [c for c in combos if pairs[0] not in c]
    else:
        combos = [(p,) for p in pairs]
    outcomes = [(current, history[:], ())]
    for combo in combos:
        state = current
        for rows in combo:
            state = updater.swapped(state, rows)
        branch = history[:]
        alternative, ok, _, _ = _iterate(updater, state, branch, options, None)
        if ok:
            outcomes.append((alternative, branch, combo))
    best, branch, combo = min(outcomes, key=lambda o: updater.cost(o[0]))
    notes = []
    if updater.mirror_symmetric:
        best = updater.oriented_like_start(best)
    if combo:
        history[:] = branch
        status += f"; close modes re-paired ({updater.describe_pairs(combo)})"
        notes.append(f"re-paired close modes {updater.describe_pairs(combo)}: lower misfit than the start's pairing")
    if updater.mirror_symmetric:
        notes.append("square plate, known layers in-plane isotropic: exchanging E1 and E2 (nu12 -> nu21) of all "
                     "identified materials changes no frequency; the orientation of the start values "
                     "(sign of D11 - D22) is given. Mode-shape labels or a non-square plate remove this ambiguity")
    scale = updater.noise_variance(best)
    twins = [o[0] for o in outcomes
             if 2 * (updater.cost(o[0]) - updater.cost(best)) < 4 * scale and not updater.same_or_mirror(o[0], best)]
    if twins:
        spread = np.max(np.abs([t.values / best.values - 1 for t in twins]), axis=0)
        worst = np.argsort(-spread)[:3]
        names = ", ".join(f"{updater.space.parameters[i].name} {100 * spread[i]:.2g} %" for i in worst)
        notes.append(f"{len(twins)} other pairing(s) of the close modes {updater.describe_pairs(pairs)} fit within "
                     f"the scatter (twin solutions; largest differences: {names}); give mode-shape labels "
                     "(a 'label' column) for these modes to decide")
    return best, status, notes, [t.values for t in twins]


def relative_sensitivity(e: Evaluation) -> np.ndarray:
    """The paper's normalised sensitivity matrix (p / f) df/dp of the paired modes."""
    return e.derivatives * e.values[None, :] / e.model_hz[:, None]


__all__ = ["FitOptions", "FitResult", "Iteration", "fit", "relative_sensitivity"]
