"""``fit``: identify the layers of a specimen, optionally with physical effects whose
parameters are estimated together with the layer properties."""

from __future__ import annotations

import concurrent.futures as cf
import math
import multiprocessing as mp
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from contextlib import contextmanager
from dataclasses import dataclass, replace

import numpy as np

from fem.effects import SwitchedOn, effect
from fem.errors import LayerIdError, NotApplicableError
from fem.inputs import InputStd
from fem.laminates.material import MATERIAL_PARAMETERS, SHEAR_MODULI
from fem.model import SpecimenModel
from fem.solver.attachments import ATTACHMENT_PARAMETERS
from fem.solver.threads import one_blas_thread, one_blas_thread_process
from fem.specimen import Parameter, Specimen

from ..engine.objective import Objective, solving_model
from ..engine.parameters import UNITS, display
from ..engine.peak_lists import fit_peak_list, matching_cost, model_error, start_matching_cost
from ..engine.result import FitResult, FitStatus, Iteration
from ..engine.statistics import ASSUMED_SCATTER_REL
from ..engine.ties import Tied, plain
from ..engine.updating import Abandoned, FitOptions, Follow, Settle, update
from ..measurements import Measurements
from .budget import with_budget, with_theory_accuracy
from .causes import with_causes
from .damping import identify_damping
from .patterns import residual_patterns
from .plausibility import implausible, plate_mass
from .point_mass_screen import PointMassScreen
from .precheck import Precheck, Sensitivities, precheck
from .shear_moduli import choose_shear_moduli, reconsidered, with_shear_moduli


@dataclass(frozen=True)
class RefitPolicy:
    """The numbers that govern how effects are refitted; a study or a test passes another
    to vary them (``Refit.policy``, ``Refitting.policy``).

    ``effect_iterations``: iterations of a refit with an effect (from the fit without it).
    ``prune_factor``: a candidate whose refit could explain, by its linearised estimate (or
    a point mass by the residual scan), less than 1 / ``prune_factor`` of what another one
    explained is not refitted.  ``parallel_from_s`` [s]: independent refits run in worker
    processes only after a baseline fit of at least this long (starting a worker costs
    about 1 s)."""

    effect_iterations: int = 40
    prune_factor: float = 2.0
    parallel_from_s: float = 0.5

    @property
    def options(self) -> FitOptions:
        """The iteration control of a refit with an effect."""
        return FitOptions(max_iterations=self.effect_iterations)


#: The documented defaults (docs/diagnosis.md).
REFIT_POLICY = RefitPolicy()
_EFFECT_OPTIONS = REFIT_POLICY.options
#: Point-mass starts: the residual scan's best position and a 3 x 3 grid over its quarter
#: of the plate, ranked by the share of the misfit the scan gives a mass there; the best
#: ``POINT_MASS_STARTS`` are ranked again by one linearised step each, and the best
#: ``POINT_MASS_CONTINUED`` at distinct positions are fitted to convergence (rivals need
#: finished fits).  Screening each start with 3 iterations instead cost 12 evaluations
#: where this costs 4: on a layerwise model a point-mass candidate took 120-250 s.
POINT_MASS_STARTS = 4
POINT_MASS_CONTINUED = 2
#: A point mass's vanishing start, as a share of the plate's mass: it moves a mode by at
#: most about twice that (1e-6), far below any scatter.
VANISHING_MASS = 1e-6
#: A refit ends worse than the fit it adds its effect to when its misfit is higher by
#: more than this (units of chi^2): a vanishing start is that fit to within far less,
#: and a tenth of a unit is no difference any test or criterion can see (an effect must
#: gain ``SelectionPolicy.min_gain`` = 10 to be selected).
NOT_WORSE_CHI2 = 0.1
#: The start of a ply's shear moduli from the 3-D relations of its class: a
#: unidirectional ply (E1 >= ``UD_ANISOTROPY`` E2) is transversely isotropic about its
#: fibres, G13 = G12 and G23 = E2 / 2(1 + nu23), nu23 = ``UD_NU23`` (mid-range of the
#: 0.3-0.6 of epoxy-matrix plies); any other material starts at G13 = G23 = G12.  On a
#: blind 5 mm carbon/glass hybrid the layerwise refit from G13 = G23 = G12 stopped at
#: 3.5 x the floor with the carbon's G13 and G23 swapped (2.2 and 12 GPa; truth 5.4 and
#: 3.4), from this start it reached the floor (0.0212 %, floor 0.0209 %).
TRANSVERSELY_ISOTROPIC = "transversely isotropic"
UD_ANISOTROPY = 2.0
UD_NU23 = 0.45
#: Starts of transverse shear moduli that only default to G12, screened (one evaluation
#: each): the ply class's relation, then (G13, G23) / G12: fibre plies have G23 ~ 0.6-0.9
#: G12, wood's rolling shear G23 ~ G12 / 10-20, and from G23 = G12 a refit stops in a
#: local minimum there (the 3-D spruce reference: 1.1 % RMS left, against the noise level
#: from G12 / 16).  The starts with G23 != G13 are for unidirectional plies (and wood) only
#: (``_shear_starts``).
SHEAR_STARTS = (TRANSVERSELY_ISOTROPIC, (1.0, 1.0), (1.0, 0.25), (1.0, 1 / 16), (0.25, 0.25))
#: A failed shear refit is restarted from the thin-plate limit first: shear moduli so stiff
#: that the shear theory's frequencies lie within this share of the measurements' scatter
#: of the fit it is added to (``vanishing_shear_start``), from where every accepted step
#: lowers the misfit.  A fixed multiple of G12 is no such limit: at 8 G12 a balsa core
#: (G12 60 MPa) still moves the modes by several per cent.
VANISHING_SHEAR = 0.1
#: ... found by the 1 / G law of the shear correction from two evaluations at these
#: multiples of G12, and kept this far below the moduli's upper bound.
SHEAR_PROBES = (8.0, 64.0)
SHEAR_BOUND_MARGIN = 0.5
#: From the limit the shear moduli are lowered by this factor a step, the layers refitted
#: (at most ``CONTINUATION_ITERATIONS`` iterations) at each, while the misfit falls.
CONTINUATION_STEP = 4.0
CONTINUATION_ITERATIONS = 6
#: Two effect estimates whose chi^2 differ by less than this (about 2 std) are rivals.
RIVAL_CHI2 = 4.0
#: The thin-plate fit a diagnosis starts from holds the layer properties that run to their
#: bounds at the spec's values and is repeated, at most this many times: with physics
#: missing, the weakly determined ones (a ply's nu12, the E2 of a cross-ply's middle
#: layer) take up the misfit and end at a bound, and every effect's refit starts from
#: there (blind cross-ply, a/h 16: 17 % misfit left and the shear refit at 1.3 % with
#: G13 at its bound; holding nu12 and E2: 5.2 %, and shear 0.39 %, every estimate
#: plausible).  The final refit frees them again where the data then determine them.
HOLD_ROUNDS = 3
#: ... or that end this many times above or below it: an order of magnitude beyond a
#: handbook value is the thin plate's doing, not the material's (a cross-ply's middle
#: layer's E2 fell 10.4 -> 0.0075 GPa; the issue's worst handbook start, a woven-fabric
#: guess for a unidirectional ply, is 2.9x under its E1 and 5x over its E2).
RUN_OFF = 10.0
#: A layer property held at the spec's (handbook) value is uncertain by this much (1 std,
#: relative): handbook values of a ply's E2, G12 and nu12 spread by 15-30 % between
#: sources and fibre contents; the blind study draws its starts uniformly within +-30 %
#: of the truth, 17 %.  Its effect on the other properties enters their std.
HANDBOOK_STD_REL = 0.2
#: A thin-plate fit that moved a layer property this many times off the spec's value has
#: distorted it to absorb missing physics (a handbook value is good to tens of per cent):
#: the shear candidates are then refitted from the spec's values too (``spec_start``).
#: On a blind glass/carbon/glass hybrid with a soft bond line the carbon core's E1 fell
#: 113 -> 16 GPa (spec 95) and every candidate started there stalled at 1.7-1.9 % RMS.
DISTORTED = 3.0


@one_blas_thread
def fit(
    model: SpecimenModel,
    measurements: Measurements,
    effects: Sequence[str] = (),
    *,
    parameters=None,
    options: FitOptions | None = None,
    progress: Callable[[Iteration | str], None] | None = None,
    workers: int | None = 1,
) -> FitResult:
    """Identify the layers: E1, E2, G12, nu12 of every identified material at once.

    The parameters of every identified material of ``model`` (or the given
    ``parameters``) are fitted to the measured frequencies of all configurations at once.
    Values are SI inside (Pa); ``report()`` and ``to_dict()`` print in the spec's units
    (GPa, mm, g).  When the spec states the known inputs' std, the result carries the
    uncertainty budget and its std includes them.  When materials have
    ``identify_damping``, the result's ``damping`` holds their loss factors, found after
    the stiffness from the measured damping ratios.

    Parameters
    ----------
    model : SpecimenModel
        The model (``fem.load_spec``).
    measurements : Measurements
        The measured frequencies (``load_measurements``).
    effects : sequence of str, default ()
        Effect kinds switched on with their parameters free (e.g. ``["point_mass"]``): the
        layers (``parameters``) are fitted first, then again with the effects' parameters
        added; the result's ``baseline`` is the fit without them.
    parameters : sequence of Parameter, optional
        What to fit; default (None): E1, E2, G12, nu12 of every identified material.
    options : FitOptions, optional
        The iteration control of every fit; default (None): ``FitOptions()``, and for the
        refits with effects ``RefitPolicy.effect_iterations`` (40) iterations.
    progress : callable, optional
        Called with every accepted ``Iteration`` (or, with effects, a line of text per
        refit).
    workers : int or None, default 1
        Processes for the independent refits of the effects (``independent_refits``): 1,
        all here; None, two where it pays, as the command line does.  Workers are spawned
        and import the main module: a script that asks for them needs the
        ``if __name__ == "__main__":`` guard.

    Returns
    -------
    FitResult
        The fitted values (SI) with their std, the status and the misfit statistics.

    Raises
    ------
    LayerIdError
        ``effects`` is a string instead of a list, ``options`` is not a ``FitOptions``,
        or an effect's refit cannot use the measured shapes ``options.use_shapes`` asks
        for (an attachment's parameters, the layerwise theory); all before any fit.
    SpecError
        An effect kind is unknown (before any work).

    Examples
    --------
    >>> import identify
    >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
    >>> model = identify.load_spec(COATED_PLATE)
    >>> result = identify.fit(model, identify.load_measurements(COATED_PLATE_MEASURED, model))
    >>> result.status.value, f"RMS error {100 * result.statistics.rms_rel_error:.3f} %"
    ('converged', 'RMS error 0.024 %')
    """
    if isinstance(effects, str):
        raise LayerIdError(f"effects = {effects!r}: give a list of effect kinds, e.g. [{effects!r}]")
    if options is not None and not isinstance(options, FitOptions):
        raise LayerIdError(
            f"options = {options!r}: need a FitOptions (identify.FitOptions(max_iterations=...))"
        )
    if effects:
        for kind in effects:
            effect(kind)  # unknown kinds fail before any work
            if options is not None and options.use_shapes:
                _shapes_fit(model, kind)
        started = time.perf_counter()
        baseline = fit_holding_bounds(model, measurements, parameters, options)
        independent = any(effect(k).independent_starts for k in effects) or not measurements.ranked
        worth_it = independent and time.perf_counter() - started >= REFIT_POLICY.parallel_from_s
        with independent_refits(workers, worth_it) as pool:
            refitting = Refitting.from_baseline(model, measurements, baseline)
            result = fit_with_effects(refitting, list(effects), options or _EFFECT_OPTIONS, pool, progress)
            return with_damping(with_theory_accuracy(with_budget(result)))
    fitted = fit_layers(model, measurements, parameters, options or FitOptions(), progress=progress)
    return with_damping(with_theory_accuracy(with_budget(with_causes(fitted))))


def _shapes_fit(model: SpecimenModel, kind: str) -> None:
    """Refuse, before any work, an effect whose refit the measured shapes cannot enter:
    the shape sensitivities cover the laminate parameters of a single-layer theory
    (``LaminateSolution.shape_derivatives``), not an attachment's or the layerwise theory."""
    for on in effect(kind).free(model):
        if on.model.options.theory == "layerwise" or any(p.kind in ATTACHMENT_PARAMETERS for p in on.free):
            raise LayerIdError(
                f"effect {kind!r} with use_shapes: the measured shapes cannot enter its refit yet "
                "(shape sensitivities cover a single-layer plate's laminate parameters, not an "
                "attachment's or the layerwise theory); fit it without --use-shapes (the shapes still "
                "pin the pairing)"
            )


def with_damping(result: FitResult) -> FitResult:
    """The fit with the layers' loss factors identified from the measured damping ratios
    at its stiffness (``identify.fitting.damping``), when the spec asks for them."""
    damping = identify_damping(result.model, result.measurements, result.pairings)
    return result if damping is None else replace(result, damping=damping)


def fit_layers(
    model: SpecimenModel,
    measurements: Measurements,
    parameters=None,
    options: FitOptions | None = None,
    follow: Follow = Follow(),
    progress: Callable[[Iteration], None] | None = None,
) -> FitResult:
    """The multi-model updating of ranked measurements, or of a peak list (matched to the
    model's modes as it goes).  ``follow``: what the fit takes over from an earlier one
    (``Follow.on``: its pairings, its peak matching, which effect each parameter belongs
    to) and the pairing check at the solution of ranked data (a peak list's final fit
    settles in full); ``options`` default ``FitOptions()``.  The causes of a poor fit are
    the caller's to add (``with_causes``)."""
    options = options or FitOptions()
    if measurements.ranked:
        return update(model, measurements, parameters, options, progress, follow)
    return fit_peak_list(model, measurements, parameters, options, progress, follow)


def continued(
    fit: FitResult,
    measurements: Measurements,
    options: FitOptions,
    settle: Settle = Settle.QUICK,
    like: FitResult | None = None,
) -> FitResult:
    """``fit`` iterated on from where it stopped: its model, parameters, effects and
    pairing; causes of a poor fit are left to the caller.  ``like``: the fit whose peak
    matching a peak list starts from (default ``fit``; a fit made on ``matched_peaks`` has
    none: the fit whose matching it was made on)."""
    follow = replace(Follow.on(like or fit, settle, fit.effect_of), pairings=fit.pairings)
    return fit_layers(fit.model, measurements, list(fit.parameters), options, follow)


def matched_peaks(fit: FitResult, measurements: Measurements) -> Measurements:
    """The data an effect's refit on top of ``fit`` is made on: a peak list's peaks as
    ``fit`` matched them (ranked), ranked measurements as they are.  A refit of the peak
    list itself would match its peaks again on the way, so its misfit would be over other
    peaks than ``fit``'s: neither comparable (a real-like spruce plate's candidates all
    ended "worse" than the baseline) nor bound to descend from it, and each round of
    re-matching is a refit.  The peaks are matched again once an effect is chosen
    (``rematched``)."""
    return measurements if measurements.ranked else fit.measurements


def rematched(
    fit: FitResult,
    measurements: Measurements,
    like: FitResult,
    options: FitOptions,
    pool: Executor | None = None,
) -> FitResult:
    """A fit made on ``matched_peaks(like, measurements)`` refitted on the peak list
    ``measurements`` itself, the peaks matched again; ranked measurements: ``fit`` as it
    is.  Two ways, the one that matches every peak at less cost kept (``matching_cost``
    at the smaller of their model errors: the same data, the same tolerance): from
    ``like``'s matching, matched again at the solution; and afresh from ``fit``'s values
    (the spectrum laid over the peaks and the moduli screened, as a first fit does), for
    the physics an effect adds can move modes past their neighbours.  On a real-like
    spruce plate the thin plate's matching kept 26 of 33 peaks, the lowest two left out
    and some paired wrongly; with transverse shear matched again from it, 26 peaks at
    0.40 % RMS; afresh, all 33 at 0.50 % with the rolling shear modulus G23 within 1 %
    of the truth, from where the point-mass screen found the sensor.  ``pool``: the two
    refits run side by side (they are independent: the same answer, in about half the
    time on two cores)."""
    if measurements.ranked:
        return fit
    jobs = [
        dict(fit=fit, measurements=measurements, options=options, like=like),
        dict(fit=fit, measurements=measurements, options=options, like=None),
    ]
    again, fresh = pool.map(_matched_again, jobs) if pool is not None else map(_matched_again, jobs)
    tolerance = min(model_error(again), model_error(fresh))
    costs = [matching_cost(f, measurements, tolerance) for f in (again, fresh)]
    if not costs[1] < costs[0]:
        return again
    note = (
        f"the peaks matched afresh with {', '.join(sorted(set(fit.effect_of.values())))} on (the spectrum "
        "laid "
        f"over them again): matching cost {costs[1]:.4g} against {costs[0]:.4g} from the matching of the fit "
        f"without it, at {100 * tolerance:.2g} %"
    )
    return replace(fresh, warnings=fresh.warnings + (note,))


def _matched_again(job: dict) -> FitResult:
    """One way of ``rematched`` (module level: runs in a worker process): from ``like``'s
    matching with the pairing checked in full, or (``like`` None) matched afresh."""
    fit, measurements, options, like = job["fit"], job["measurements"], job["options"], job["like"]
    if like is not None:
        return continued(fit, measurements, options, Settle.FULL, like=like)
    return fit_layers(fit.model, measurements, list(fit.parameters), options, Follow(fit.effect_of))


@contextmanager
def independent_refits(workers: int | None, worth_it: bool):
    """A pool of ``workers`` processes for refits that do not depend on each other (None:
    two, where the cores allow and the work is ``worth_it``: a baseline fit of at least
    ``RefitPolicy.parallel_from_s``; 1: none, all here).  Workers are spawned and import the main
    module: a script that asks for them needs the ``if __name__ == "__main__":`` guard."""
    n = (min(2, os.cpu_count() or 1) if worth_it else 1) if workers is None else max(1, workers)
    if n == 1:
        yield None
        return
    pool = worker_pool(n)
    try:
        yield pool
    finally:
        pool.shutdown()


def worker_pool(n: int) -> cf.ProcessPoolExecutor:
    """``n`` spawned worker processes for refits and candidates (the diagnosis's and
    ``independent_refits``'); they import the main module, so a script that asks for them
    needs the ``if __name__ == "__main__":`` guard.  Each runs BLAS on one thread, as
    ``fit`` and ``diagnose`` do (``fem.solver.threads``)."""
    return cf.ProcessPoolExecutor(
        max_workers=n, mp_context=mp.get_context("spawn"), initializer=one_blas_thread_process
    )


def fit_with_effects(
    refitting: Refitting,
    kinds: list[str],
    options: FitOptions,
    pool: Executor | None = None,
    progress: Callable[[str], None] | None = None,
) -> FitResult:
    """The fit with ``kinds`` switched on, their parameters free, starting from the
    baseline fit (``refitting.baseline``), one effect after the other (``add_effect``);
    the answer's pairing is checked in full, once, at the end.

    A point mass starts at each of the positions the residual scan suggests and on a grid
    over that quarter of the plate; the lowest misfit is kept and rivals that fit about as
    well are reported.  The transverse-shear effects free the G13 and G23 that the data
    can identify (``shear_moduli``).  An effect whose parameters the frequencies cannot
    determine with the others (a singular sensitivity matrix, ``precheck``) is an error,
    not an iteration.  ``options``: of every refit; ``pool``: where the refits that are
    independent of each other run (a point mass's starts, a peak list's two matchings;
    ``independent_refits``).
    """
    measurements = refitting.measurements
    state, notes = refitting.baseline, []
    for kind in kinds:
        # Each start's refit checks only the re-pairings that lower the misfit; the answer
        # is checked in full once, at the end (``released``).
        step = refitting.refit(state, options, pool=pool)
        hints = refitting.hints(state)
        added = add_effect(step, kind, hints, progress=progress)
        if refitting.restarted([kind], state):
            from_spec = prepare_effect(state, kind, hints, refitting.respec)
            added = added.or_from_spec(add_effect(step, kind, hints, prepared=from_spec, progress=progress))
        if added.result is None:
            advice = (
                "; fix one of the parameters in that combination (e.g. give the layer's thickness or density "
                "as measured) or leave the effect out"
                if added.precheck is not None and added.precheck.singular
                else ""
            )
            raise LayerIdError(f"effect '{kind}': {added.error}{advice}")
        notes += [(kind, text) for text in added.notes]
        state = rematched(added.result, measurements, state, options, pool)
    # The pairing is checked in full once, at the answer (``released``).
    result, reconsidered_notes = refitting.with_determined_shear(state, options, Settle.QUICK)
    notes += [(kinds[-1], text) for text in reconsidered_notes]
    result = with_causes(refitting.released(result, options))
    return replace(
        result,
        warnings=tuple(dict.fromkeys(result.warnings + tuple(text for _, text in notes))),
        effect_notes=tuple(notes),
        baseline=refitting.baseline,
    )


def at_bounds(result: FitResult) -> list[Parameter]:
    """The parameters of ``result`` at a bound of theirs (``Uncertainty.bounded``)."""
    return [p for p, at in zip(result.parameters, result.uncertainty.bounded, strict=True) if at]


def _ran_off(value: float, start: float) -> bool:
    """A modulus ``RUN_OFF`` times above or below the spec's value."""
    return _off_by(value, start, RUN_OFF)


def _off_by(value: float, start: float, factor: float) -> bool:
    """``value`` more than ``factor`` times above or below ``start`` (both positive)."""
    return start > 0 and value > 0 and not 1 / factor <= value / start <= factor


def fit_holding_bounds(
    model: SpecimenModel, measurements: Measurements, parameters=None, options: FitOptions | None = None
) -> FitResult:
    """``fit_layers`` repeated while layer properties end at a bound or ``RUN_OFF`` times
    off the spec's values, those held at the spec's values (``HOLD_ROUNDS``); the result's
    warnings name each one held.  Only material properties are held, never all of them."""
    parameters = list(parameters) if parameters is not None else model.specimen.material_parameters()
    result = fit_layers(model, measurements, parameters, options)
    held: list[Parameter] = []
    for _ in range(HOLD_ROUNDS):
        bounded = set(at_bounds(result)) | {
            p for p in result.parameters if _ran_off(result.value(p), model.value(p))
        }
        hold = [
            p
            for p in result.parameters
            if p in bounded and isinstance(p, Parameter) and p.kind in MATERIAL_PARAMETERS
        ]
        if not hold or len(hold) >= len(result.parameters):
            break
        held += hold
        result = fit_layers(model, measurements, [p for p in result.parameters if p not in hold], options)
    if not held:
        return result
    notes = tuple(
        f"{p.name} held at the spec's {display(p, model.value(p)):.4g} {UNITS[p.kind][0]}".rstrip()
        + ": it ran to its bound or by an order of magnitude in the thin-plate fit (with physics "
        "missing, a weakly determined property takes up the misfit)"
        for p in held
    )
    return replace(result, warnings=notes + result.warnings)


def spec_start(model: SpecimenModel, measurements: Measurements, baseline: FitResult) -> FitResult | None:
    """The spec's values as a fit of ``measurements`` (no iteration), when ``baseline`` (the
    thin-plate fit of them) is degenerate: not converged, a layer property at a bound, or
    one ``DISTORTED`` times off the spec's value.  An effect that explains the misfit then
    starts better from the user's values than from what the thin plate did to them
    (``Effect.restarts_from_spec``); None otherwise."""
    distorted = [
        p
        for p in baseline.parameters
        if p.kind in MATERIAL_PARAMETERS and _off_by(baseline.value(p), model.value(p), DISTORTED)
    ]
    if baseline.status is not FitStatus.NOT_CONVERGED and not at_bounds(baseline) and not distorted:
        return None
    unsettled = Follow(settle=Settle.NONE)
    return fit_layers(model, measurements, list(baseline.parameters), FitOptions(max_iterations=0), unsettled)


def restarted_from_spec(kinds, state: FitResult, baseline: FitResult, respec: FitResult | None) -> list[str]:
    """Of ``kinds`` added to ``state``, those refitted from the spec's values too
    (``respec``, from ``spec_start``): those that ``restarts_from_spec``, added to the
    thin-plate fit ``baseline`` itself when it was degenerate."""
    return (
        [k for k in kinds if effect(k).restarts_from_spec] if state is baseline and respec is not None else []
    )


def afresh_from_spec(job: dict) -> AddedEffect:
    """Effect ``job["kind"]`` switched on in the spec's model, not in the thin-plate fit's,
    and fitted to the whole peak list ``job["refitting"].measurements`` with its peaks
    matched afresh (module level: runs in a worker process); ``job["options"]`` of the fit.
    A transverse-shear effect's moduli start at the one of ``SHEAR_STARTS`` whose spectrum
    matches the peaks at the least cost (``start_matching_cost``).

    Why: every other candidate is refitted on the peaks as the thin-plate fit matched them,
    and where that matching is wrong, no refit on it can leave it.  On a real-like spruce
    plate (rolling shear G23 ~ G12 / 12, a 4 g sensor; ``studies.long_plates``, seed 3)
    the thin plate matched 26 of 34 peaks with nu12 on its bound of 0, and every candidate
    refitted on them stayed above 0.35 % RMS; thick_plate from the spec at G23 = G12 / 16
    matched 30 of them, at matching cost 59 against the thin plate's 117 (at one tolerance:
    ``matching_cost``)."""
    refitting, kind, options = job["refitting"], job["kind"], job["options"]
    started = time.perf_counter()
    peaks = refitting.measurements
    try:
        on = effect(kind).free_all(refitting.model)
    except NotApplicableError as exc:
        return AddedEffect(kind, None, error=str(exc), applicable=False)
    except LayerIdError as exc:
        return AddedEffect(kind, None, error=str(exc))
    base = list(refitting.baseline.parameters)
    new = [p for p in on.free if p not in _covered(base)]
    specimen, shear = on.model.specimen, shear_moduli_in(new)
    starts = [(None, on.model)]
    if shear:
        starts = [
            (s, on.model.with_values(_shear_values(specimen, shear, s)))
            for s in _shear_starts(specimen, shear)
        ]
    costs = []
    for start, model in starts:
        try:
            costs.append((start_matching_cost(model, peaks), start, model))
        except LayerIdError:
            continue  # a start outside the materials' valid range: the others
    if not costs:
        return AddedEffect(kind, None, tuple(new), error="no start from the spec's values is a valid model")
    _, start, model = min(costs, key=lambda c: c[0])
    effect_of = {
        **refitting.baseline.effect_of,
        **{p: kind for p in new if p.kind not in MATERIAL_PARAMETERS},
    }
    try:
        result = fit_layers(model, peaks, base + new, options, Follow(effect_of, settle=Settle.QUICK))
    except LayerIdError as exc:
        return AddedEffect(kind, None, tuple(new), error=f"failed: {exc}")
    reasons = refitting.judged_implausible(new, result.specimen)
    notes = [
        f"{kind} refitted from the spec's values"
        + (f" ({_describe_start(start)})" if start is not None else "")
        + ", the peaks matched afresh"
    ]
    notes += [f"{kind}: implausible estimate: {r}" for r in reasons]
    return AddedEffect(
        kind,
        replace(result, warnings=result.warnings + tuple(notes)),
        tuple(new),
        notes=tuple(notes),
        implausible=reasons,
        seconds=time.perf_counter() - started,
    )


@dataclass(frozen=True)
class AddedEffect:
    """An effect added to a fit: ``result`` the refit with it (None when not run: not
    identifiable, or an error); ``added`` the parameters it freed (after the choice of
    shear moduli); ``precheck`` the conditioning before the refit; ``notes`` what was
    decided or found (shear moduli freed, rival estimates, implausible values);
    ``implausible`` why its estimate is physically unlikely (empty: plausible)."""

    kind: str
    result: FitResult | None
    added: tuple[Parameter, ...] = ()
    precheck: Precheck | None = None
    notes: tuple[str, ...] = ()
    implausible: tuple[str, ...] = ()
    error: str = ""
    seconds: float = 0.0
    pruned: bool = False  # not refitted: its bound is short of ``prune_below`` (``PruneBelow``)
    held: tuple[Parameter, ...] = ()  # shear moduli held because they ran out (``_held_shear``)
    applicable: bool = True  # False: the effect has nothing to act on in this spec
    # the fit the refit contains where that is not the state: the state with rotary
    # inertia, when it lies above the state (``_restarted``)
    contained: FitResult | None = None
    # other solutions of its own parameters that the final refit tries as well (an effect
    # refitted from several starts, ``_from_starts``): {parameter: value [SI]} each
    rivals: tuple[dict, ...] = ()

    def ended_above(self, state: FitResult) -> bool:
        """The refit ended above the fit it contains (``ended_worse``): ``state``, and the
        higher ``contained`` where there is one; never for an effect that freed no
        parameter (rotary inertia switched on: no limit where it is the state, its misfit
        is its answer)."""
        result = self.result
        if result is None or not self.added or not ended_worse(result, state):
            return False
        return self.contained is None or ended_worse(result, self.contained)

    @property
    def shear_moduli(self) -> list[Parameter]:
        """The transverse shear moduli among the parameters it freed."""
        return shear_moduli_in(self.added)

    def or_from_spec(self, from_spec: AddedEffect) -> AddedEffect:
        """Of this refit and the same effect's refit ``from_spec`` (from the spec's values),
        the one with the lower misfit, the other's start named in its notes."""

        def misfit(a: AddedEffect) -> float:
            finished = a.result is not None and a.result.finished
            return a.result.statistics.sum_squares if finished else float("inf")

        seconds = self.seconds + from_spec.seconds
        if misfit(from_spec) < misfit(self):
            restarted = (
                "the thin-plate fit ran to its bounds (or did not converge): refitted from the spec's values"
            )
            note = (
                f"{restarted} too, which left the lower misfit ({100 * from_spec.result.rms_rel_error:.3g} % "
                f"against {100 * self.result.rms_rel_error:.3g} %)"
                if self.result is not None
                else restarted
            )
            return replace(
                from_spec,
                notes=from_spec.notes + (note,),
                seconds=seconds,
                result=replace(from_spec.result, warnings=from_spec.result.warnings + (note,)),
            )
        return replace(self, seconds=seconds)


@dataclass(frozen=True)
class Prepared:
    """An effect ready to be refitted on top of ``state``: the model with it switched on,
    the parameters it adds (after the choice of shear moduli), the pre-check and its notes,
    and ``bound``: the reduction of the weighted sum of squares the refit could bring, by
    the linearised refit from its start (for a point mass the residual scan's best share
    if larger)."""

    kind: str
    model: SpecimenModel
    base: tuple
    added: tuple
    precheck: Precheck
    notes: tuple[str, ...]
    bound: float
    seconds: float = 0.0
    pairings: dict | None = None  # followed from the start of the refit
    others: tuple = ()  # other start models, most promising first (``Effect.other_starts``)
    # the misfit (sum of squares) of the fit it starts from where that is not the state
    start_misfit: float | None = None

    def starts_above(self, state: FitResult) -> bool:
        """It starts from another fit (the spec's values) with more misfit than ``state``:
        ending above ``state`` is then no failed start (its rival from ``state`` is refitted
        too, and the lower kept)."""
        return self.start_misfit is not None and ended_worse_by(self.start_misfit, state)

    def frees_any(self, parameters) -> bool:
        """Whether the refit moves any of the plain ``parameters``."""
        return bool(_covered(self.added) & set(parameters))


def prepare_effect(
    state: FitResult,
    kind: str,
    hints=(),
    start: FitResult | None = None,
    free_again: Sequence[Parameter] = (),
) -> Prepared | AddedEffect:
    """One evaluation of ``state``'s model with effect ``kind`` switched on, at the start
    of its refit (``precheck``): the shear moduli to free, the conditioning, the bound.
    ``start``: a fit of the same data whose layer and shear values (and pairing) the
    refit starts from (a refinement starts where what it refines ended), default
    ``state``'s.  ``free_again``: shear moduli ``state`` holds (``held_shear_moduli``),
    freed with an effect that frees none itself, where the data see them
    (``choose_shear_moduli``).  An ``AddedEffect`` without a fit when the effect has
    nothing to act on or fails."""
    started = time.perf_counter()
    origin = start or state
    try:
        on = effect(kind).free_all(state.model.with_specimen(origin.specimen))
    except NotApplicableError as exc:
        return AddedEffect(kind, None, error=str(exc), applicable=False)
    except LayerIdError as exc:
        return AddedEffect(kind, None, error=str(exc))
    base = list(state.parameters)
    covered = _covered(base)
    new = [p for p in on.free if p not in covered]
    notes = []
    held = [] if shear_moduli_in(new) else [p for p in free_again if p not in covered]
    if held:
        new += held
        notes.append(
            f"G13, G23 of {', '.join(sorted({p.target for p in held}))} held in the fit it adds to: free "
            f"again with {kind} (they ran out while it was missing)"
        )
    try:
        model, sensitivities, started_at, others = _best_start(on, origin, base + new)
        notes += [started_at] if started_at else []
        shear = shear_moduli_in(new)
        if shear:
            choice = choose_shear_moduli(
                sensitivities, base + [p for p in new if p not in shear], shear, model.specimen
            )
            new = [p for p in new if p not in shear] + list(choice.parameters)
            notes.append(choice.describe(model.specimen))
            for material in choice.kept:  # not freed: back to the given or default values
                model = model.with_specimen(
                    with_shear_moduli(model.specimen, on.model.specimen.materials[material])
                )
        check = precheck(sensitivities, base, new)
        now = state.statistics.sum_squares
        # linearised: may undershoot 0
        bound = max(0.0, now - sensitivities.predicted_sum_squares(base + new))
    except LayerIdError as exc:
        return AddedEffect(kind, None, tuple(new), error=str(exc))
    if effect(kind).hinted:
        bound = max([bound] + [h.get("share", 0.0) * now for h in hints])
    if start is not None:
        notes.append(
            f"started from the {' + '.join(sorted(set(start.effect_of.values()))) or 'spec'}'s values"
        )
    return Prepared(
        kind,
        model,
        tuple(base),
        tuple(new),
        check,
        tuple(notes),
        float(bound),
        time.perf_counter() - started,
        origin.pairings,
        others,
        None if start is None else start.statistics.sum_squares,
    )


def _best_start(on, state: FitResult, parameters) -> tuple[SpecimenModel, Sensitivities, str, tuple]:
    """``_shear_start`` from the effect's start and from each of its ``other_starts``; the
    one whose linearised refit leaves the least misfit kept, with a note when it is not
    the first, and the other start models, most promising first (tried when the refit
    fails, ``_other_starts``)."""
    kind = effect(on.kind)
    others = kind.other_starts(on, shapes=state.measurements.shapes is not None)
    tried = [_shear_start(on.model, state, parameters)] + [
        _shear_start(m, state, parameters, kind.other_starts_spanned) for m in others
    ]
    order = np.argsort([s.predicted_sum_squares(parameters) for _, s, _ in tried], kind="stable")
    model, sensitivities, note = tried[order[0]]
    if order[0]:
        note = "; ".join(
            filter(
                None,
                [
                    note,
                    f"the refit started at {_described(on.free, model)} (of {len(tried)} "
                    "starts, the lowest misfit after one linearised step)",
                ],
            )
        )
    return model, sensitivities, note, tuple(tried[i][0] for i in order[1:])


def _described(parameters, model: SpecimenModel) -> str:
    return ", ".join(
        f"{p.name} = {display(p, model.value(p)):.3g} {UNITS[p.kind][0]}".rstrip() for p in parameters
    )


def _shear_start(
    model: SpecimenModel, state: FitResult, parameters, spanned: bool = False
) -> tuple[SpecimenModel, Sensitivities, str]:
    """Where the refit of freed transverse shear moduli that only default to G12 starts:
    each of ``SHEAR_STARTS`` evaluated once (all such materials at once), the one whose
    linearised refit (one Gauss-Newton step, every parameter free) leaves the least misfit
    kept.  ``spanned``: evaluated on ``state``'s Ritz models (``Effect.other_starts_spanned``).
    Returns (the model there, its sensitivities, a note when it is not G12)."""
    specimen = model.specimen
    defaulted = [
        p
        for p in parameters
        if p.kind in SHEAR_MODULI and p.kind in specimen.materials[p.target].defaulted_shear_moduli
    ]
    starts = _shear_starts(specimen, defaulted) if defaulted else [(1.0, 1.0)]
    best = None
    for start in starts:
        try:
            trial = (
                model.with_values(_shear_values(specimen, defaulted, start)) if start != (1.0, 1.0) else model
            )
            sensitivities = (
                Sensitivities.on_state_modes(state, trial, state.measurements, parameters)
                if spanned
                else Sensitivities.at_start(trial, state.measurements, parameters, state.pairings)
            )
        except LayerIdError:
            continue  # a start outside the materials' valid range (e.g. below 0.1 MPa): the others
        left = sensitivities.predicted_sum_squares(parameters)
        if best is None or left < best[0]:
            best = (left, trial, sensitivities, start)
    if best is None:
        raise LayerIdError(
            "no transverse-shear start is a valid material: "
            + ", ".join(
                f"{p.target} G12 = {specimen.materials[p.target].G12 / 1e9:.3g} GPa" for p in defaulted
            )
        )
    _, trial, sensitivities, start = best
    alike = sorted({p.target for p in defaulted if not _unidirectional(specimen.materials[p.target])})
    if start == (1.0, 1.0):
        return trial, sensitivities, ""
    materials = ", ".join(sorted({p.target for p in defaulted}))
    alike_note = (
        f"(G23 = G13 for {', '.join(alike)}, no unidirectional ply) "
        if alike and start != TRANSVERSELY_ISOTROPIC and start[0] != start[1]
        else ""
    )
    note = (
        f"the refit started at {_describe_start(start)} for {materials} {alike_note}"
        f"(of {len(starts)} starts, the lowest misfit after one linearised step; "
        "G13 = G23 = G12 is only the default)"
    )
    return trial, sensitivities, note


def held_shear_moduli(state: FitResult, selected: Sequence[AddedEffect]) -> tuple[Parameter, ...]:
    """The transverse shear moduli that ``state`` holds because they ran out of range in
    the refit of one of the ``selected`` effects (``_held_shear``) while other physics was
    missing; not those the data do not see (``choose_shear_moduli``, ``reconsidered``).
    The next round's leading candidate frees them again (``diagnose._leader_freed_again``),
    so that it combines with the shear instead of competing with it: blind13 (hybrid, a
    4.7 g sensor), from the layerwise fit with both plies' G13/G23 held, a point mass
    alone ended at 12.6 g and 0.72 % RMS (10x the floor); with them free, 4.2 g at the
    sensor and 0.074 %, consistent with the scatter."""
    free = _covered(state.parameters)
    return tuple(dict.fromkeys(p for added in selected for p in added.held if p not in free))


def _covered(parameters) -> set[Parameter]:
    """The plain parameters ``parameters`` move (a tied scale's lead and followers)."""
    return {plain(p) for p in parameters} | {
        f for p in parameters if isinstance(p, Tied) for f, _ in p.followers
    }


def _unidirectional(material) -> bool:
    """Whether ``material`` is a unidirectional ply (E1 >= ``UD_ANISOTROPY`` E2)."""
    return material.E1 >= UD_ANISOTROPY * material.E2


def _shear_starts(specimen: Specimen, shear) -> list:
    """``SHEAR_STARTS`` for the shear moduli ``shear``: the ply-class start and the starts
    with G23 != G13 only where a material of them is a unidirectional ply (``_shear_values``
    gives the others G23 = G13)."""
    ud = any(_unidirectional(specimen.materials[p.target]) for p in shear)
    return [s for s in SHEAR_STARTS if ud or (s != TRANSVERSELY_ISOTROPIC and s[0] == s[1])]


def _describe_start(start) -> str:
    if start == TRANSVERSELY_ISOTROPIC:
        return (
            f"the ply class's relations (a unidirectional ply's G13 = G12, G23 = E2 / 2(1 + {UD_NU23:g}); "
            "G13 = G23 = G12 for others)"
        )
    f13, f23 = start
    return f"G13 = {f13:.3g} G12, G23 = {f23:.3g} G12"


@dataclass(frozen=True)
class Refit:
    """The context of the refits that add an effect to the fit ``state``: the data they
    fit (``measurements``), the spec's specimen their estimates are judged against
    (``nominal``), the iteration ``options`` (default the ``policy``'s: its
    ``effect_iterations``), the pairing check at the solution (``settle``), where independent refits
    may run side by side (``pool``), which effect each parameter belongs to (``effect_of``,
    default the state's) and the numbers of the refit rules (``policy``).  Each refit
    starts from the state's peak matching."""

    state: FitResult
    measurements: Measurements
    nominal: Specimen
    options: FitOptions | None = None
    settle: Settle = Settle.QUICK
    pool: Executor | None = None
    effect_of: dict | None = None
    policy: RefitPolicy = REFIT_POLICY

    def __post_init__(self):
        if self.options is None:
            object.__setattr__(self, "options", self.policy.options)

    def follow(self, pairings: dict, settle: Settle | None = None) -> Follow:
        """A refit from the state's peak matching, its modes followed from ``pairings``,
        the pairing check ``settle`` at its solution (default ``self.settle``)."""
        effect_of = self.state.effect_of if self.effect_of is None else self.effect_of
        follow = Follow.on(self.state, self.settle if settle is None else settle, effect_of)
        return replace(follow, pairings=pairings)

    def job(self, model: SpecimenModel, parameters, pairings: dict) -> dict:
        """The arguments of one refit of ``model`` with ``parameters`` free, its modes
        followed from ``pairings`` (``_fitted``: it may run in a worker process)."""
        return dict(
            model=model,
            measurements=self.measurements,
            parameters=list(parameters),
            options=self.options,
            follow=self.follow(pairings),
        )

    def fit(self, model: SpecimenModel, parameters, pairings: dict) -> FitResult:
        """One refit (``job``), here."""
        return _fitted(self.job(model, parameters, pairings))

    def prepare(
        self, kind: str, hints=(), start: FitResult | None = None, free_again=()
    ) -> Prepared | AddedEffect:
        """Effect ``kind`` ready to be refitted on top of the state (``prepare_effect``)."""
        return prepare_effect(self.state, kind, hints, start, free_again)

    def add(self, kind: str, hints=(), **how) -> AddedEffect:
        """The state refitted with effect ``kind`` on (``add_effect``; ``how``: its
        ``prepared``, ``prune_below`` and ``progress``)."""
        return add_effect(self, kind, hints, **how)

    def continued(self, fit: FitResult, options: FitOptions) -> FitResult:
        """``fit`` (made on this context's data) iterated on from where it stopped."""
        return continued(fit, self.measurements, options, self.settle)


@dataclass(frozen=True)
class Refitting:
    """What the effect refits of one data set share, from one thin-plate fit: the spec's
    ``model``, the ``measurements`` as given (a peak list's candidate refits are made on
    its peaks as each state matched them, ``data``), the ``baseline`` fit of them and,
    where that fit is degenerate, the spec's values as a fit (``respec``, ``spec_start``),
    and the numbers of the refit rules (``policy``)."""

    model: SpecimenModel
    measurements: Measurements
    baseline: FitResult
    respec: FitResult | None = None
    policy: RefitPolicy = REFIT_POLICY

    @classmethod
    def from_baseline(
        cls,
        model: SpecimenModel,
        measurements: Measurements,
        baseline: FitResult,
        policy: RefitPolicy = REFIT_POLICY,
    ) -> Refitting:
        """The context of ``baseline``, with its ``respec`` found (one evaluation at most)."""
        respec = spec_start(model, matched_peaks(baseline, measurements), baseline)
        return cls(model, measurements, baseline, respec, policy)

    @property
    def nominal(self) -> Specimen:
        """The spec's specimen, against which estimates are judged."""
        return self.model.specimen

    def judged_implausible(self, parameters, specimen: Specimen) -> tuple[str, ...]:
        """Why the estimates of ``parameters`` in ``specimen`` are physically unlikely
        (``plausibility.implausible``): against the spec, with the lowest frequency of the
        data as given."""
        first_hz = float(self.measurements.table["frequency_hz"].min())
        return implausible(parameters, specimen, self.nominal, first_hz, self.model.input_std)

    def data(self, state: FitResult) -> Measurements:
        """What an effect's refit on top of ``state`` fits (``matched_peaks``)."""
        return matched_peaks(state, self.measurements)

    def refit(
        self,
        state: FitResult,
        options: FitOptions | None = None,
        settle: Settle = Settle.QUICK,
        pool: Executor | None = None,
    ) -> Refit:
        """The context of the refits that add an effect to ``state``, on its data
        (``options`` default the policy's)."""
        return Refit(state, self.data(state), self.nominal, options, settle, pool, policy=self.policy)

    def hints(self, state: FitResult, comparison=None) -> tuple:
        """Point-mass start positions for a refit on top of ``state``: from the residual
        scan of ``comparison`` (a ``compare`` of the baseline) when ``state`` is the
        baseline, else from ``state``'s own (``point_mass_hints``)."""
        if comparison is None or state is not self.baseline:
            return point_mass_hints(state)
        scan = comparison
        return point_mass_starts(self.model, scan.point_mass_hints, scan.point_map, scan.node_xy)

    def restarted(self, kinds, state: FitResult) -> list[str]:
        """Of ``kinds`` added to ``state``, those refitted from the spec's values too
        (``restarted_from_spec``)."""
        return restarted_from_spec(kinds, state, self.baseline, self.respec)

    def held_shear(self, state: FitResult, selected: Sequence[AddedEffect]) -> tuple[Parameter, ...]:
        """The shear moduli ``state`` holds because they ran out (``held_shear_moduli``)."""
        return held_shear_moduli(state, selected)

    def polished(self, fit: FitResult, state: FitResult, options: FitOptions, pool=None) -> FitResult:
        """A chosen refit (made on ``data(state)``) taken on on the data as given: a peak
        list's peaks matched again (``rematched``), ranked data iterated on (``continued``)."""
        if self.measurements.ranked:
            return continued(fit, self.measurements, options)
        return rematched(fit, self.measurements, state, options, pool)

    def polished_afresh(self, fit: FitResult, options: FitOptions) -> FitResult:
        """A chosen refit of the whole peak list from the spec's values (``afresh_from_spec``)
        taken on: its peaks matched afresh from its values, the one way of ``rematched`` that
        does not go back to the matching it was chosen against.  ``rematched`` keeps the way
        whose matching costs less, and matched again from the thin-plate fit's matching it
        lost on every real-like spruce plate that took this path (seeds 0, 1, 3, 8, 10, 11,
        13, 14: matching cost 116 against 100, 78 / 28, 118 / 62, 127 / 99, 113 / 48, 68 /
        49, 58 / 55, 78 / 41), so the answer is the same; that way took 0.6-11 x as long
        (up to 295 s on a loaded machine), and the two ran side by side waiting for it."""
        return _matched_again(dict(fit=fit, measurements=self.measurements, options=options, like=None))

    def continued(
        self,
        fit: FitResult,
        options: FitOptions,
        settle: Settle = Settle.QUICK,
        like: FitResult | None = None,
    ) -> FitResult:
        """``fit`` iterated on, on the data as given (``continued``)."""
        return continued(fit, self.measurements, options, settle, like=like)

    def with_determined_shear(
        self, result: FitResult, options: FitOptions, settle: Settle = Settle.QUICK
    ) -> tuple[FitResult, list]:
        """``result`` refitted until its freed shear moduli are determined (``with_determined_shear``)."""
        return with_determined_shear(result, self.measurements, self.nominal, options, settle)

    def released(self, result: FitResult, options: FitOptions, settle: Settle = Settle.FULL) -> FitResult:
        """``result`` with the properties the baseline held freed where determined (``released``)."""
        return released(result, self.measurements, self.baseline, self.nominal, options, settle=settle)

    @staticmethod
    def explained(result: FitResult) -> FitResult:
        """A final fit as ``fit`` returns one: with its uncertainty budget, the likely causes
        of a poor fit and the layers' loss factors when the spec asks for them."""
        return with_damping(with_causes(with_budget(result)))


@dataclass(frozen=True)
class PruneBelow:
    """A candidate is not refitted when ``RefitPolicy.prune_factor`` x its linearised bound
    (``Prepared.bound``) is below ``chi2``, a reduction of the weighted sum of squares:
    ``of`` says whose (what another candidate of the round explained, or what this one
    must explain to pay for itself)."""

    chi2: float
    of: str = "another effect explained in this round"

    def prunes(self, bound: float, factor: float) -> bool:
        """Whether a candidate of linearised ``bound`` is not refitted (``factor``:
        ``RefitPolicy.prune_factor``)."""
        return factor * bound < self.chi2

    def short_of(self, bound: float, how: str, factor: float) -> str:
        """Why a candidate of ``bound`` (estimated ``how``) is pruned, for its report."""
        return (
            f"it could explain a chi^2 of about {bound:.4g} at most ({how}), less than 1/{factor:g} of the "
            f"{self.chi2:.4g} {self.of}"
        )


def add_effect(
    refit: Refit,
    kind: str,
    hints=(),
    *,
    prepared: Prepared | None = None,
    prune_below: PruneBelow | None = None,
    abandon_below: PruneBelow | None = None,
    progress: Callable[[str], None] | None = None,
) -> AddedEffect:
    """``refit.state`` (a finished fit, its effects on) refitted with effect ``kind``
    switched on and its parameters free too.  First one evaluation with the effect
    (``prepare_effect``, unless ``prepared`` is given): it decides which transverse shear
    moduli to free and, when the augmented sensitivity matrix is singular, the refit is not
    run.  ``hints``: point-mass start positions from the residual scan; ``prune_below``: a
    refit whose bound does not come within ``refit.policy.prune_factor`` of it is not run
    (``PruneBelow``); ``abandon_below``: the same rule at every iterate of the refit, which
    is abandoned once it fails it (``FitOptions.abandon_above``; not for a point mass or an
    effect that frees shear moduli, ``_abandonable``), its other starts refitted
    (``_after_abandoned``), and reported as not refitted to the end when they are too.  The estimates'
    plausibility is judged against ``refit.nominal``; a point mass's refits from its
    several starts run side by side in ``refit.pool``."""
    started = time.perf_counter()
    ready = prepared or prepare_effect(refit.state, kind, hints)
    if isinstance(ready, AddedEffect):
        return replace(ready, seconds=time.perf_counter() - started)
    added = _refit(refit, ready, hints, progress, prune_below, abandon_below)
    return replace(added, seconds=time.perf_counter() - started + (ready.seconds if prepared else 0.0))


def _refit(refit: Refit, ready: Prepared, hints, progress, prune_below, abandon_below) -> AddedEffect:
    """``add_effect``'s refit of the prepared effect, unless it is singular or pruned, or
    abandoned on the way (``abandon_below``)."""
    state, kind, new, check, notes = (
        refit.state,
        ready.kind,
        list(ready.added),
        ready.precheck,
        list(ready.notes),
    )
    if check.singular:
        return AddedEffect(
            kind, None, tuple(new), check, tuple(notes), error=f"not identifiable: {check.describe()}"
        )
    factor = refit.policy.prune_factor

    def pruned(why: str) -> AddedEffect:
        return AddedEffect(kind, None, tuple(new), check, tuple(notes), pruned=True, error=why)

    if prune_below is not None and prune_below.prunes(ready.bound, factor):
        how = "linearised, residual scan" if effect(kind).hinted else "linearised"
        return pruned("not refitted: " + prune_below.short_of(ready.bound, how, factor))
    base = list(ready.base)
    refit = replace(
        refit, effect_of={**state.effect_of, **{p: kind for p in new if p.kind not in MATERIAL_PARAMETERS}}
    )
    if abandon_below is not None and _abandonable(kind):
        # The start's rule at every iterate: abandoned where what it has explained and one
        # Gauss-Newton step more would explain stay short of abandon_below / factor.
        ceiling = state.statistics.sum_squares - abandon_below.chi2 / factor
        refit = replace(refit, options=replace(refit.options, abandon_above=ceiling))
    if progress:
        progress(f"fitting with {kind}")
    contained, rivals = None, ()
    try:
        if effect(kind).independent_starts:
            result, rival_notes, rivals = _from_starts(
                refit, kind, hints, base + shear_moduli_in(new), progress
            )
            notes += rival_notes
        else:
            try:
                result = refit.fit(ready.model, base + new, ready.pairings or state.pairings)
            except Abandoned as first:
                result, restarted = _after_abandoned(refit, ready, first, base + new)
            else:
                if effect(kind).frees_shear and not ready.starts_above(state):
                    result, new, restarted, contained = _restarted(refit, ready, result, new, base)
                    notes += restarted
                result, restarted = _other_starts(refit, ready, result, base + new)
            notes += restarted
        result, new, held, ran_out = _held_shear(refit, ready, result, new, base, contained)
        notes += held
    except Abandoned as exc:
        bound = state.statistics.sum_squares - exc.linearised
        return pruned(
            f"not refitted to the end: from its iterate {exc.iteration} "
            + abandon_below.short_of(bound, "linearised", factor)
        )
    except LayerIdError as exc:
        return AddedEffect(kind, None, tuple(new), check, tuple(notes), error=f"failed: {exc}")
    first_hz = float(state.measurements.table["frequency_hz"].min())
    reasons = implausible(new, result.specimen, refit.nominal, first_hz, state.model.input_std)
    notes += [f"{kind}: implausible estimate: {r}" for r in reasons]
    return AddedEffect(
        kind,
        replace(result, warnings=result.warnings + tuple(notes)),
        tuple(new),
        check,
        tuple(notes),
        reasons,
        held=ran_out,
        contained=contained,
        rivals=rivals,
    )


def _abandonable(kind: str) -> bool:
    """Whether a refit of effect ``kind`` may be abandoned once it can no longer pay
    (``FitOptions.abandon_above``): not a point mass, whose starts' refits must finish to
    be told apart (rivals), nor an effect that frees shear moduli, whose refit that ends
    above the fit it contains is restarted from the thin-plate limit (``_restarted``)."""
    return not effect(kind).independent_starts and not effect(kind).frees_shear


def _shear_values(specimen: Specimen, shear, start) -> dict[Parameter, float]:
    """The shear moduli ``shear`` (a tied one with its followers) [Pa] at ``start``, each of
    its own material: (f13, f23) for G13 = f13 G12 and G23 = f23 G12, or
    ``TRANSVERSELY_ISOTROPIC``.  A material that is no unidirectional ply (a fabric, a foam,
    a metal: E1 < ``UD_ANISOTROPY`` E2) takes G23 = G13: its two transverse planes are
    alike (blind18's balanced carbon fabric skins started at G23 = G12 / 16, wood's rolling
    shear, and the final refit kept that ratio, G23 = 0.84 GPa against G13 = 13 GPa)."""
    values = {}
    for p in shear:
        for q in [p] + [f for f, _ in p.followers] if isinstance(p, Tied) else [p]:
            m = specimen.materials[q.target]
            if start == TRANSVERSELY_ISOTROPIC:
                value = (_class_g23(m) or m.G12) if q.kind == "G23" else m.G12
            else:  # a material that is no unidirectional ply is about isotropic in its plane: G23 = G13
                value = (start[0] if q.kind == "G13" or not _unidirectional(m) else start[1]) * m.G12
            values[Parameter(q.kind, q.target)] = value
    return values


def shear_moduli_in(parameters) -> list[Parameter]:
    """The transverse shear moduli (G13, G23) among ``parameters``."""
    return [p for p in parameters if p.kind in SHEAR_MODULI]


def ended_worse(result: FitResult, state: FitResult) -> bool:
    """A refit that ends with more misfit than the fit it started from (which is the same
    model with the effect off), by more than ``NOT_WORSE_CHI2`` units of chi^2, has
    failed: it stopped in a local minimum or diverged."""
    return ended_worse_by(result.statistics.sum_squares, state)


def ended_worse_by(sum_squares: float, state: FitResult) -> bool:
    """A misfit (weighted sum of squares) above ``state``'s by more than ``NOT_WORSE_CHI2``
    units of chi^2."""
    slack = NOT_WORSE_CHI2 * state.statistics.chi2_unit
    return not sum_squares <= state.statistics.sum_squares + slack


def with_rotary_inertia(refit: Refit, model: SpecimenModel, base) -> FitResult | None:
    """Where the effect switched on in ``model`` brings rotary inertia to ``state`` on the
    same plate theory (``thick_plate`` on a thin plate), the fit its refit contains where
    its shear moduli vanish (or return to the state's): the state's model with rotary
    inertia, ``base`` refitted from the state (at most ``CONTINUATION_ITERATIONS``, on the
    state's mesh); None for the other effects, whose limit is the state itself."""
    state = refit.state
    before, after = state.model.options, model.options
    if not after.rotary_inertia or before.rotary_inertia or after.theory != before.theory:
        return None
    thin = state.model.with_options(rotary_inertia=True)
    unsettled = refit.follow(state.pairings, Settle.NONE)
    return fit_layers(thin, refit.measurements, list(base), _continuation_options(refit), unsettled)


def _continuation_options(refit: Refit) -> FitOptions:
    """A continuation step's refit of the layers at fixed effect parameters: at most
    ``CONTINUATION_ITERATIONS``, stalled as ``refit``'s."""
    return FitOptions(max_iterations=CONTINUATION_ITERATIONS, stall_chi2=refit.options.stall_chi2)


def _restarted(
    refit: Refit, ready: Prepared, result: FitResult, new, base
) -> tuple[FitResult, list, list, FitResult | None]:
    """A transverse-shear refit that ended worse than the fit it contains is a failed
    start, not a result: it is refitted from the thin-plate limit (``vanishing_shear_start``
    and ``shear_continuation``, from where every step can only lower the misfit), and only
    where that too ends worse (a fault, reported) from the other ``SHEAR_STARTS`` until one
    is not, the lowest misfit kept.  The fit it contains is ``state``, or where higher the
    state with rotary inertia (``with_rotary_inertia``, for an effect that brings it) or the
    effect's own model at the thin-plate limit its bounds allow, the other parameters
    refitted (``_at_fixed_shear``): the shear moduli's upper bound leaves some shear (a steel
    plate's limit is 14 G12), and the shear theory's element and mesh differ from the thin
    plate's.  A refit that ends between the state and the higher of these has not failed.
    On a real-like spruce plate's peak list (scatter 1e-4 of each frequency) the Mindlin
    element stays 0.21 of a peak's scatter off the thin plate even at G13 = G23 = 1e4 G12,
    7 units of chi^2 above it where the misfit is 12,100: a refit that ended 6.8 above the
    thin plate was called failed, and its restarts from every shear start took 3 minutes.
    Returns (result, parameters, notes, the fit it contains where that is not the state,
    else None)."""
    state = refit.state
    shear = shear_moduli_in(new)
    if not shear or not ended_worse(result, state):
        return result, new, [], None
    inertia = with_rotary_inertia(refit, ready.model, base)
    if inertia is not None and inertia.statistics.sum_squares <= state.statistics.sum_squares:
        inertia = None  # the state is the higher: it is what the refit contains
    if inertia is not None and not ended_worse(result, inertia):
        note = (
            f"the refit ended above the fit without {ready.kind}, but not above that fit with rotary "
            f"inertia, which it contains (RMS {100 * inertia.rms_rel_error:.3g} %): rotary inertia "
            "raises the misfit here, the refit did not fail"
        )
        return result, new, [note], inertia
    parameters = base + list(new)
    # At the state's values: the refit's own start may be another fit's end (a refinement's),
    # whose thin-plate limit is not the fit the refit contains.
    at_state = ready.model.with_values(dict(zip(state.parameters, state.values, strict=True)))
    limit_model, factor = vanishing_shear_start(refit, at_state, shear, parameters)
    limit = _at_fixed_shear(refit, limit_model, shear, parameters)
    contained = max(
        (
            f
            for f in (inertia, limit)
            if f is not None and not f.statistics.sum_squares <= state.statistics.sum_squares
        ),
        key=lambda f: f.statistics.sum_squares,
        default=None,
    )
    if contained is limit and not ended_worse(result, limit):
        note = (
            f"the refit ended above the fit without {ready.kind}, but not above its own model at the "
            f"thin-plate limit its bounds allow (G13 = G23 = {factor:.3g} G12, the other parameters "
            f"refitted: RMS {100 * limit.rms_rel_error:.4g} %), from where it can only descend: the shear "
            "that bound leaves, and the element and mesh of the shear theory, keep that limit above the "
            "thin plate; the refit did not fail"
        )
        return result, new, [note], limit
    specimen = ready.model.specimen

    def starts():
        model, reached = shear_continuation(refit, limit, shear, factor, parameters)
        yield (
            model,
            (
                f"the thin-plate limit (G13 = G23 = {factor:.3g} G12), the shear moduli lowered step by step "
                f"while the misfit fell (to {reached:.3g} G12)"
            ),
        )
        for start in _shear_starts(specimen, shear):
            yield ready.model.with_values(_shear_values(specimen, shear, start)), _describe_start(start)

    best, where, count = _first_not_worse(refit, ready, result, starts(), parameters, contained)
    notes = [
        f"the refit from the screened start ended worse than without the effect (a failed start); "
        f"restarted {count} time(s), kept {where or 'the screened start'}"
    ]
    if count > 1:
        notes.append(
            "the refit from the thin-plate limit ended above the fit it contains, which a continuation "
            "that only descends cannot do: please report it (a fault of the refit, not of the data); "
            "the other shear starts were tried"
        )
    return best, new, notes, contained


def vanishing_shear_start(
    refit: Refit, model: SpecimenModel, shear, parameters
) -> tuple[SpecimenModel, float]:
    """``model`` (``refit.state``'s with a shear theory on) with the ``shear`` moduli at F x G12,
    F so large that its paired frequencies lie within ``VANISHING_SHEAR`` of each
    measurement's scatter of ``state``'s (thin-plate) ones: the shear correction falls as
    1 / G, so two evaluations (``SHEAR_PROBES``) give each mode's f = f_inf + c / F and F
    follows; at most ``SHEAR_BOUND_MARGIN`` of the moduli's upper bound.  What does not
    vanish with the shear (rotary inertia, for the Mindlin and layerwise models) stays.
    Returns (the model, F)."""
    specimen, measurements = model.specimen, refit.measurements
    unsettled = refit.follow(refit.state.pairings, Settle.NONE)

    def paired_hz(factor: float) -> np.ndarray:
        trial = model.with_values(_shear_values(specimen, shear, (factor, factor)))
        return fit_layers(trial, measurements, parameters, FitOptions(max_iterations=0), unsettled).model_hz

    low, high = SHEAR_PROBES
    c = (paired_hz(low) - paired_hz(high)) / (1 / low - 1 / high)
    table = measurements.table
    scatter = (
        table["std_hz"].to_numpy()
        if measurements.has_std
        else ASSUMED_SCATTER_REL * table["frequency_hz"].to_numpy()
    )
    factor = max(high, float(np.max(np.abs(c) / (VANISHING_SHEAR * scatter))))
    ceiling = min(
        SHEAR_BOUND_MARGIN * specimen.materials[p.target].bound(p.kind)[1] / specimen.materials[p.target].G12
        for p in shear
    )
    factor = min(factor, ceiling)
    return model.with_values(_shear_values(specimen, shear, (factor, factor))), factor


def _at_fixed_shear(refit: Refit, model: SpecimenModel, shear, parameters) -> FitResult:
    """``model`` with its ``shear`` moduli as they are and the other ``parameters``
    refitted (at most ``CONTINUATION_ITERATIONS``): each point of ``shear_continuation``,
    the first at the thin-plate limit ``vanishing_shear_start`` chose."""
    others = [p for p in parameters if p not in shear]
    unsettled = refit.follow(refit.state.pairings, Settle.NONE)
    return fit_layers(model, refit.measurements, others, _continuation_options(refit), unsettled)


def shear_continuation(
    refit: Refit, limit: FitResult, shear, factor: float, parameters
) -> tuple[SpecimenModel, float]:
    """From the thin-plate limit (``limit``: ``_at_fixed_shear`` there, its ``shear`` moduli
    at ``factor`` x G12), the shear moduli lowered by ``CONTINUATION_STEP`` at a time, the
    other parameters refitted at each, as long as the misfit falls: the model where a
    refit with the shear moduli free starts (at the limit their derivatives vanish, so the
    refit itself would stop there with them undetermined).  Every step kept lowers the
    misfit.  Returns (the model, its factor)."""
    current = limit
    while factor > 1.0:
        lower = max(1.0, factor / CONTINUATION_STEP)
        lowered = current.model.with_values(_shear_values(current.model.specimen, shear, (lower, lower)))
        trial = _at_fixed_shear(refit, lowered, shear, parameters)
        if not trial.statistics.sum_squares < current.statistics.sum_squares:
            break
        current, factor = trial, lower
    return current.model, factor


def _first_not_worse(
    refit: Refit, ready: Prepared, result: FitResult | None, starts, parameters, contained=None
):
    """``result`` (a failed refit; None: an abandoned one) refitted from each of ``starts``
    ((model, description) pairs) in turn until one ends no worse than the fit it contains
    (``contained``, default ``state``), a start whose refit is abandoned (``Abandoned``)
    passed over; returns (the lowest misfit, its start's description or "" for ``result``,
    the number of starts tried); (None, "", count) when nothing ended."""
    state = refit.state
    contained = contained or state
    tried, count = ([] if result is None else [(result, "")]), 0
    for model, where in starts:
        count += 1
        try:
            tried.append((refit.fit(model, parameters, ready.pairings or state.pairings), where))
        except Abandoned:
            continue  # that start cannot pay either: ``result`` stands
        if not ended_worse(tried[-1][0], contained):
            break
    if not tried:
        return None, "", count
    best, where = min(tried, key=lambda t: t[0].statistics.sum_squares)
    return best, where, count


def _after_abandoned(refit: Refit, ready: Prepared, first: Abandoned, parameters) -> tuple[FitResult, list]:
    """The refit from ``ready``'s start abandoned (``first``: it could not pay): the effect's
    other starts (``Prepared.others``) refitted in turn, as after a refit that ends worse
    than the state (``_first_not_worse``), each once; raises ``first`` when every one is
    abandoned too.  Returns (result, notes)."""
    starts = ((m, _described(ready.added, m)) for m in ready.others)
    best, where, _ = _first_not_worse(refit, ready, None, starts, parameters)
    if best is None:
        raise first
    return best, [
        f"the refit from the screened start was abandoned at its iterate {first.iteration} (it "
        f"could not pay for {ready.kind}): refitted from {where}, RMS "
        f"{100 * best.statistics.rms_rel_error:.3g} %"
    ]


def _other_starts(refit: Refit, ready: Prepared, result: FitResult, parameters) -> tuple[FitResult, list]:
    """A refit that ended worse than ``state`` (``ended_worse``) is refitted from the effect's
    other starts (``Prepared.others``) until one is not; the lowest misfit kept.  blind19
    (a hybrid whose sensor was not yet placed): the orientation from -3 deg diverged to
    4.6 % RMS, where from +3 deg it had reached 0.29 % (study run 5).  Returns (result,
    notes)."""
    if not ready.others or not ended_worse(result, refit.state):
        return result, []
    starts = ((m, _described(ready.added, m)) for m in ready.others)
    best, where, count = _first_not_worse(refit, ready, result, starts, parameters)
    if not where:
        return result, [f"the refit ended worse than without {ready.kind}; from {count} other start(s) too"]
    return best, [
        f"the refit from the screened start ended worse than without {ready.kind} (RMS "
        f"{100 * result.statistics.rms_rel_error:.3g} %): refitted from {where}, "
        f"RMS {100 * best.statistics.rms_rel_error:.3g} %"
    ]


def _held_shear(
    refit: Refit, ready: Prepared, result: FitResult, new, base, contained: FitResult | None = None
) -> tuple[FitResult, list, list, tuple]:
    """Freed shear moduli that ended implausible (at a bound, or beyond
    ``plausibility.MAX_SHEAR_RATIO`` x G12) are ones the data do not see (a thin skin's
    G13/G23 in a sandwich): they are held at the spec's values or, where it gives none, at
    the ply class's relation (``_class_shear``: a value the data need not see, not the
    screened start, which one linearised step chose with every modulus free) and the
    candidate refitted without them, so that they cannot sink the candidate that holds the
    right physics.  blind14 (a cross-ply with a 7 g sensor): the glass core's G23 ran to the
    bound from 0.25 G12; held there (with the carbon's, which then ran out too) the
    transverse-shear refit ended at 4.0 % against a 1.81 % baseline; held at the relation,
    at 0.51 %.
    Repeated while the refit sends another material's moduli out (blind13, a hybrid:
    with the carbon's held, the glass's ran to the 2000 GPa bound and every shear candidate
    was implausible), at most once per material.  A hold that makes the refit end above
    the fit the refit contains (``contained``, default ``state``: ``_restarted``) while the
    free refit does not is undone: the data do see those moduli, and the free, implausible
    estimate is kept as a sign (cases in docs/diagnosis.md).  Returns (result, parameters,
    notes, the plain shear moduli held)."""
    state, nominal = refit.state, refit.nominal
    first_hz = float(state.measurements.table["frequency_hz"].min())
    held: list[str] = []
    removed: list[Parameter] = []
    free, free_new = result, list(new)
    for _ in nominal.materials:
        shear = shear_moduli_in(new)
        wandered = sorted({p.target for p in shear if implausible([p], result.specimen, nominal, first_hz)})
        if not wandered:
            break
        held += wandered
        out = [p for p in shear if p.target in wandered]
        removed += out
        new = [p for p in new if p not in out]
        specimen = result.model.specimen
        for material in wandered:
            specimen = specimen.with_materials(
                [_class_shear(specimen.materials[material], nominal.materials[material])]
            )
        result = refit.fit(result.model.with_specimen(specimen), base + new, result.pairings)
    if not held:
        return result, new, [], ()
    limit = contained or state
    if ended_worse(result, limit) and not ended_worse(free, limit):
        # Held, the refit ends above the fit it adds to: the data do see them. The free
        # estimate stays, implausible: a sign of what is missing, never a worse answer.
        return (
            free,
            free_new,
            [
                f"G13, G23 of {', '.join(held)} ran out of the plausible range; held at the spec's "
                "values or the ply class's relation, the refit ended above the fit it contains "
                f"(RMS {100 * result.rms_rel_error:.3g} %), so they stay free "
                f"(RMS {100 * free.rms_rel_error:.3g} %)"
            ],
            (),
        )
    note = (
        f"G13, G23 of {', '.join(held)} ran out of the plausible range (the data do not see them): held at "
        f"the spec's values or the ply class's relation ({_describe_start(TRANSVERSELY_ISOTROPIC)}) and "
        "refitted "
        "without them"
    )
    return result, new, [note], tuple(sorted(_covered(removed), key=lambda q: q.name))


def _class_g23(material) -> float | None:
    """The ply class's G23 [Pa]: a unidirectional ply's E2 / 2(1 + ``UD_NU23``); None for
    other materials (G23 follows G12)."""
    return material.E2 / (2 * (1 + UD_NU23)) if _unidirectional(material) else None


def _class_shear(material, given):
    """``material`` with its transverse shear moduli where a hold puts them: as the spec
    gives them (``given``), or where it gives none the ply class's relation (G13 follows G12,
    G23 ``_class_g23`` at ``material``'s E2)."""
    return replace(material, G13=given.G13, G23=given.G23 if given.G23 is not None else _class_g23(material))


def with_determined_shear(
    result: FitResult,
    measurements: Measurements,
    nominal: Specimen,
    options: FitOptions | None = None,
    settle: Settle = Settle.QUICK,
) -> tuple[FitResult, list]:
    """The fit refitted until every transverse shear modulus an effect freed is still
    determined at the solution (``shear_moduli.reconsidered``); with the notes saying what
    changed."""
    notes = []
    scatter = 1.0 if result.measurements.has_std else ASSUMED_SCATTER_REL
    for _ in range(2 * len(nominal.materials)):
        change = reconsidered(result, nominal, scatter) if result.jacobian is not None else None
        if change is None:
            break
        parameters, model, note = change
        notes.append(note)
        result = fit_layers(
            model, measurements, parameters, options or _EFFECT_OPTIONS, Follow.on(result, settle)
        )
    return result, notes


def released(
    result: FitResult,
    measurements: Measurements,
    baseline: FitResult,
    nominal: Specimen,
    options: FitOptions,
    settle: Settle = Settle.FULL,
) -> FitResult:
    """``result`` refitted with the layer properties the thin-plate fit held
    (``fit_holding_bounds``) free again where the data then determine them: all at once,
    else one at a time (blind hybrid: freeing a ply's nu12 and the other's E1 together sent
    one to a bound, while one of them alone is determined). A freed property must not end at
    a bound, run off or be implausible, nor, one at a time, may one freed before it
    (blind99: a coating's E2 ran off to 0.5 MPa while the next was freed). Not judged by the
    criterion: holding was for choosing the effects; a property held at a handbook value
    30 % off moves the others by several of their std (blind cross-ply: 7.5; blind hybrid:
    13.9), while freed it costs only its own std. Those still held carry their handbook
    scatter into the others' std (``with_held_scatter``). ``settle``: the pairing check of
    the answer, made once, at it (the tries to free check only the re-pairings that lower
    the misfit)."""
    every = baseline.model.specimen.material_parameters()
    held = [
        p
        for p in every
        if p not in baseline.parameters
        and p not in result.parameters
        and p.target in nominal.materials
        and p.kind in MATERIAL_PARAMETERS
    ]
    quick = Settle.QUICK if settle is Settle.FULL else settle

    def checked(fitted: FitResult) -> FitResult:
        """``fitted`` (its pairing checked ``quick``) with it checked as ``settle`` asks."""
        return fitted if settle is quick else continued(fitted, measurements, options, settle)

    if not held:
        return checked(result)
    first_hz = float(result.measurements.table["frequency_hz"].min())

    def freeing(fitted: FitResult, free: list[Parameter]) -> FitResult | None:
        free_too = list(fitted.parameters) + free
        freed = fit_layers(fitted.model, measurements, free_too, options, Follow.on(fitted, quick))
        # Every property this release frees, those freed before ``free`` one at a time too:
        # freeing the next one must not send an earlier one off.
        judged = [p for p in free_too if p in held]
        if (
            not freed.finished
            or any(p in judged for p in at_bounds(freed))
            or any(_ran_off(freed.value(p), baseline.model.value(p)) for p in judged)
            or implausible(judged, freed.specimen, nominal, first_hz, freed.model.input_std)
        ):
            return None
        return freed

    freed, now_free = freeing(result, held), list(held)
    if freed is None:
        freed, now_free = result, []
        for p in held if len(held) > 1 else ():
            one = freeing(freed, [p])
            if one is not None:
                freed, now_free = one, now_free + [p]
    if not now_free:
        return with_held_scatter(checked(result), held)
    still = [p for p in held if p not in now_free]
    note = f"{', '.join(p.name for p in now_free)} freed again (held in the thin-plate fit): now determined"
    freed = checked(freed)
    return with_held_scatter(replace(freed, warnings=freed.warnings + (note,)), still)


def with_held_scatter(result: FitResult, held: list[Parameter]) -> FitResult:
    """``result`` whose std carry the scatter of the ``held`` properties' values
    (``HANDBOOK_STD_REL`` of each, the covariance of "consider" parameters, through the
    uncertainty budget), with a note naming them; as it is when none is held."""
    if not held:
        return result
    inputs = tuple(InputStd(p.kind, p.target, HANDBOOK_STD_REL * abs(result.model.value(p))) for p in held)
    widened = with_budget(result, inputs)
    if widened is result:
        return result
    note = (
        f"{', '.join(p.name for p in held)} held at the spec's values: their handbook scatter "
        f"({100 * HANDBOOK_STD_REL:.0f} %, 1 std) is in the other properties' std (the uncertainty budget)"
    )
    return replace(widened, warnings=widened.warnings + (note,))


def point_mass_hints(state: FitResult) -> tuple:
    """Point-mass start positions from the residual scan of a fit (``compare``), ranked
    (``point_mass_starts``)."""
    _, shares, xy, hints, _ = residual_patterns(
        solving_model(state.model, state.measurements),
        state.measurements,
        state.model_hz,
        state.pairings,
        state.jacobian,
    )
    return point_mass_starts(state.model, hints, shares, xy)


def point_mass_starts(model: SpecimenModel, hints, shares=None, xy=None) -> tuple:
    """Where a point mass's refit starts: the residual scan's best position and a 3 x 3
    grid over its quarter of the plate (``_quadrant_grid``), ranked by the share of the
    misfit the scan says a mass there explains (``shares`` per node at ``xy``); the best
    ``POINT_MASS_STARTS`` (all of them without a scan)."""
    by_shapes = tuple(h for h in hints[:1] if h.get("from_shapes"))  # measured shapes place it: tried first
    hints = hints[len(by_shapes) :]
    starts = tuple(hints[:1]) + _quadrant_grid(model, hints[0] if hints else None)
    if shares is None or xy is None or not len(shares):
        return by_shapes + starts

    def share(start):
        return float(shares[int(np.argmin(np.hypot(*(xy - np.array(start["xy"])).T)))])

    return (by_shapes + tuple(sorted(starts, key=lambda start: -share(start))))[:POINT_MASS_STARTS]


def _from_starts(refit: Refit, kind: str, hints, base, progress) -> tuple[FitResult, list, tuple]:
    """An effect with ``independent_starts`` (a point mass: its mass, x and y free) from
    several starts (the measured shapes' first, when there are
    shapes): each ranked by the misfit one linearised
    Gauss-Newton step from it would leave (one evaluation, ``Sensitivities``; a bare peak
    list, which has no mode numbers to linearise with, keeps the scan's order), the best
    ``POINT_MASS_CONTINUED`` at distinct positions fitted to convergence (rivals need
    finished fits), and the best start of the screen over the whole plate
    (``point_mass_screen``) where it is at another position; the lowest misfit kept.  With
    the refit's pool the starts' refits run side by side (they are independent).  Returns
    (the best fit, notes on rivals that fit about as well, their values of the effect's
    parameters)."""
    state, measurements, pool = refit.state, refit.measurements, refit.pool
    starts = tuple(hints) if hints else point_mass_starts(state.model, ())
    switched = [on for hint in starts for on in effect(kind).free(state.model, hint)]
    # One evaluation a start, independent of each other: side by side in the pool.
    rankings = [
        dict(
            model=on.model,
            measurements=measurements,
            parameters=base + list(on.free),
            pairings=state.pairings,
        )
        for on in switched
    ]
    lefts = pool.map(_linearised_left, rankings) if pool is not None else map(_linearised_left, rankings)
    ranked = sorted(zip(lefts, switched, strict=True), key=lambda t: t[0])
    # Where measured shapes place the mass (``shape_point_map``), that start is fitted
    # whatever the frequencies' linearised step says: the shapes see the position, the
    # step only a frequency misfit that a wrong position can share.
    chosen = [
        on for hint in starts[:1] if hint.get("from_shapes") for on in effect(kind).free(state.model, hint)
    ][:1]
    for _, on in ranked:
        if all(_differs(on.model, other.model, _position(on)) for other in chosen):
            chosen.append(on)
        if len(chosen) == POINT_MASS_CONTINUED:
            break
    # The Ritz screen's best start over the whole plate too, where it is at another position
    # and scores better than each of those on the screen.
    screen = PointMassScreen.of(state)
    screened = []
    if screen is not None:
        best = screen.best(1)[0]
        screened = [
            on
            for on in effect(kind).free(state.model, best)
            if all(
                _differs(on.model, other.model, _position(on))
                and best["left"] < screen.score(*(other.model.value(p) for p in _position(on) + [_mass(on)]))
                for other in chosen
            )
        ]
    chosen += screened
    # A mass at its start can reorder the modes, and the measured numbers are the real
    # plate's ranks: a start whose modes, followed by shape from the state, pair otherwise
    # than afresh by those numbers is refitted both ways.
    reordering = (
        [on for on in chosen if _reorders(on, base, state.pairings, measurements)]
        if measurements.ranked
        else []
    )
    if progress:
        progress(
            f"{kind}: {len(ranked)} starts ranked and {len(screened)} screened on a reduced model, "
            f"{len(chosen)} fitted" + (f", {len(reordering)} also paired afresh" if reordering else "")
        )
    jobs = [refit.job(on.model, base + list(on.free), state.pairings) for on in chosen]
    jobs += [refit.job(on.model, base + list(on.free), None) for on in reordering]
    starts = chosen + reordering
    trials = list(
        zip(pool.map(_fitted, jobs) if pool is not None else map(_fitted, jobs), starts, strict=True)
    )
    result, on = min(trials, key=lambda t: t[0].statistics.sum_squares)
    if ended_worse(result, state):
        # Every start ended above the fit the mass is added to: once more from the mass
        # all but gone at the best one's start, from where the refit can only descend.
        gone = replace(
            on, model=on.model.with_values({_mass(on): VANISHING_MASS * plate_mass(state.model.specimen)})
        )
        trials.append((_fitted(refit.job(gone.model, base + list(gone.free), state.pairings)), gone))
        result, on = min(trials, key=lambda t: t[0].statistics.sum_squares)
    # Distinct finished solutions within the rival margin in units of the misfit's own
    # over-dispersion go to the final refit (``diagnose._final``): while physics is
    # missing, a misfit that much higher cannot rank two solutions (blind145's x-mirror of
    # its sensor 38 chi^2 below its true mirror image, at a reduced chi^2 of 26).  Those
    # within the margin itself are the rivals the report names.
    unit = result.statistics.chi2_unit
    others = [
        t
        for t, o in trials
        if t is not result
        and t.finished
        and t.statistics.sum_squares - result.statistics.sum_squares
        < RIVAL_CHI2 * unit * max(1.0, result.statistics.reduced_chi2)
        and _differs(t, result, o.free)
    ]
    rivals = [
        t for t in others if t.statistics.sum_squares - result.statistics.sum_squares < RIVAL_CHI2 * unit
    ]
    notes = []
    if rivals:
        described = "; ".join(
            ", ".join(f"{p.kind} {display(p, r.value(p)):.4g}" for p in on.free) for r in rivals
        )
        notes.append(
            f"{kind}: {len(rivals)} other solution(s) fit about as well ({described}): the effect's "
            "parameters are not unique with these modes; measure more modes to separate them"
        )
    return result, notes, tuple({p: t.value(p) for p in on.free} for t in others)


def _reorders(on: SwitchedOn, parameters, pairings: dict, measurements: Measurements) -> bool:
    """Do the modes of ``on``'s start model, followed by shape from ``pairings``, pair
    otherwise than afresh by the measured mode numbers in any configuration?  blind152 (a
    6.6 g sensor on a thick balsa sandwich): a 10.9 g start followed from the plate without
    it swapped two modes and skipped one, and its refit ended at a 25 g mass, 2.08 %;
    paired afresh it reached 6.0 g, 0.119 % (the floor 0.127 %)."""
    objective = Objective(on.model, measurements, list(parameters) + list(on.free))
    values = np.array([on.model.value(p) for p in objective.parameters])
    followed = objective.evaluate(values, pairings, differentiate=False)
    fresh = objective.evaluate(values, None, differentiate=False)
    return any(
        not np.array_equal(followed.pairings[name].indices, fresh.pairings[name].indices)
        for name in objective.configurations
    )


def _linearised_left(job: dict) -> float:
    """The weighted sum of squares one linearised refit from ``job``'s start model would
    leave (``Sensitivities.predicted_sum_squares``; module level: runs in a worker process);
    infinite for a bare peak list, which has no mode numbers to linearise with (it keeps
    the scan's order)."""
    try:
        return Sensitivities.at_start(
            job["model"], job["measurements"], job["parameters"], job["pairings"]
        ).predicted_sum_squares(job["parameters"])
    except LayerIdError:
        return math.inf


def _position(on: SwitchedOn) -> list[Parameter]:
    """The free x and y of a switched-on point mass."""
    return [p for p in on.free if p.kind in ("x", "y")]


def _mass(on: SwitchedOn) -> Parameter:
    """The free mass of a switched-on point mass."""
    return next(p for p in on.free if p.kind == "mass")


def _fitted(job: dict) -> FitResult:
    """``fit_layers`` of ``job``'s model and measurements with its other keywords (module
    level: runs in a worker process)."""
    rest = {k: v for k, v in job.items() if k not in ("model", "measurements")}
    return fit_layers(job["model"], job["measurements"], **rest)


def _quadrant_grid(model: SpecimenModel, best: dict | None) -> tuple[dict, ...]:
    """Point-mass starts on a 3 x 3 grid over the quarter of the plate that holds the
    residual scan's best point (mirrored quarters are equivalent by symmetry)."""
    a, b = model.specimen.length, model.specimen.width
    x0, y0 = best["xy"] if best else (a, b)
    mass = best["mass_kg"] if best else None
    out = []
    for fx in (0.2, 0.5, 0.8):
        for fy in (0.2, 0.5, 0.8):
            x = a / 2 + (1 if x0 >= a / 2 else -1) * fx * a / 2
            y = b / 2 + (1 if y0 >= b / 2 else -1) * fy * b / 2
            out.append({"xy": (x, y), "mass_kg": mass})
    return tuple(out)


def _differs(
    a: FitResult | SpecimenModel, b: FitResult | SpecimenModel, parameters, tolerance: float = 0.05
) -> bool:
    """Effect parameters more than 5 % apart (positions: 5 % of the plate, folded by symmetry)."""
    span = max(a.specimen.length, a.specimen.width)
    for p in parameters:
        va, vb = a.value(p), b.value(p)
        if p.kind in ("x", "y"):
            size = a.specimen.length if p.kind == "x" else a.specimen.width
            va, vb = abs(va - size / 2), abs(vb - size / 2)
            if abs(va - vb) > tolerance * span:
                return True
        elif abs(va - vb) > tolerance * max(abs(vb), 1e-300):
            return True
    return False


__all__ = [
    "fit",
    "fit_with_effects",
    "add_effect",
    "prepare_effect",
    "AddedEffect",
    "Prepared",
    "PruneBelow",
    "with_determined_shear",
    "spec_start",
    "restarted_from_spec",
    "fit_holding_bounds",
    "released",
]
