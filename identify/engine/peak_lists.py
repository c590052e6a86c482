"""Fitting a peak list: measured frequencies without mode numbers, as recordings give them.

1. Per configuration, the start model's spectrum is laid over the peaks (``matching.align``:
   the best scale factor) and the peaks are matched to modes, leaving out those that fit
   no mode; the original plate's factor also rescales the start moduli (frequencies go
   as the square root of stiffness), a closed-form start like the plate formulas IET
   and Resonalyser users apply.
2. The matched peaks are fitted as ranked measurements (``updating.update``).
3. At the solution the peaks are matched again with a narrower tolerance (``TIGHTENING``;
   not when the fit starts from another fit's matching, already at a solution), then
   with the model's remaining error as the tolerance; if a different set of peaks
   or modes is matched, the fit is redone from there, until the matching settles (at
   most ``MAX_ROUNDS``).
Every peak left out, and every model mode in the band no peak was matched to, is
reported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from fem.errors import MeasurementError
from fem.model import MAX_MODES, MAX_SOLVED_MODES, SpecimenModel
from fem.specimen import Parameter

from ..measurements import Measurements
from .matching import GATE, SHAPE_GATE, Match, align, match, matched_count
from .objective import solving_model
from .pairing import permits
from .parameters import display
from .peak_assignment import PeakAssignment, peak_table
from .peak_screen import SCREEN_TOLERANCE, screen
from .result import FitResult, FitStatus, Iteration
from .statistics import ASSUMED_SCATTER_REL
from .updating import FitOptions, Follow, Settle, update

#: Model modes solved beyond the number of peaks of a configuration (spurious peaks and
#: missing modes shift the ranks by a few).
EXTRA_MODES = 4
#: Match-fit rounds at the final tolerance before the matching must have settled.
MAX_ROUNDS = 4
#: Tolerances (relative model error) of the first re-matches after the start's 3 %: the
#: gate narrows as the model comes closer, so a true peak left out early is taken back and
#: a spurious one matched early is dropped before the final, data-driven tolerance.
TIGHTENING = (0.01, 0.003)
#: Start moduli are rescaled when the original plate's spectrum is off by more than this.
RESCALE_ABOVE = 0.02
#: Floor of the matching tolerance at the solution (relative): the model is never taken as
#: exact to better than a tenth of the usual scatter.
SOLUTION_TOLERANCE_FLOOR = 0.1 * ASSUMED_SCATTER_REL
MODULI = ("E1", "E2", "G12", "G13", "G23")
#: A peak-list fit is converged only when it matches at least this share of the peaks
#: (``_without_redundancy``): a lab's peak list has some spurious peaks (hum, rattle, a
#: double-hit's echo) and misses modes at the sensor's nodes, but a model of the plate
#: explains most of it.  Two real-like spruce plates' thin-plate fits, 0.44 % and 1 % off
#: (their sensor and shear missing), matched 22 of 35 and 23 of 30 peaks; a refit of the
#: second that kept 11 of 30 was "converged" on a wrong sensor.
MATCHED_SHARE = 0.5


def too_few_matched(matched: int, listed: int) -> bool:
    """Whether ``matched`` of ``listed`` peaks are too few for a fit of the list to be
    tested by them (``MATCHED_SHARE``)."""
    return matched < MATCHED_SHARE * listed


def _by_rank(peaks: Measurements) -> Measurements:
    """The peaks as if each configuration's were its modes 1, 2, ... (before any matching)."""
    table = peaks.table.assign(mode=peaks.table.groupby("configuration").cumcount() + 1)
    return replace(peaks, table=table)


def _options(options: FitOptions, peaks: Measurements, ranked: Measurements) -> FitOptions:
    """The fit's options with enough extra modes that it solves every mode the matching
    needs (the most peaks of a configuration + ``EXTRA_MODES``), as far as a model may
    solve beyond its highest matched mode (a far model's matching can keep 6 of 13 peaks).
    The matching then solves the fit's own model (:func:`_solver`) and, at a solution,
    reuses its solves (``fem.model.solve_laminate`` is cached) instead of solving a second
    model."""
    most = int(peaks.table.groupby("configuration").size().max())
    highest = int(ranked.table["mode"].max())
    needed = min(most + EXTRA_MODES - highest, MAX_SOLVED_MODES - MAX_MODES)
    return replace(options, extra_modes=max(options.extra_modes, needed))


def _solver(
    model: SpecimenModel, peaks: Measurements, options: FitOptions, ranked: Measurements | None = None
) -> SpecimenModel:
    """The model as the fit of ``ranked`` (the peaks as matched; None: by rank) solves it."""
    ranked = _by_rank(peaks) if ranked is None else ranked
    return solving_model(model, ranked, _options(options, peaks, ranked).extra_modes)


def _match_all(solver: SpecimenModel, peaks: Measurements, tolerance: float | None) -> dict[str, Match]:
    """Per configuration, the peaks matched to the solver's modes (``tolerance`` None: at
    the start, laid over by the best scale)."""
    out = {}
    for name in peaks.configurations:
        rows = peaks.of(name)
        solution = solver.solve(name)
        std = rows["std_hz"].to_numpy() if peaks.has_std else None
        shapes = peaks.shapes_of(rows)
        allowed = permits(solution, rows["label"].tolist(), shapes)[0]
        shaped = [s is not None and not allowed[i].all() for i, s in enumerate(shapes)]
        gate = np.where(shaped, SHAPE_GATE, GATE)
        f = rows["frequency_hz"].to_numpy()
        out[name] = (
            align(f, std, solution.frequencies_hz, allowed, gate)
            if tolerance is None
            else match(f, std, solution.frequencies_hz, tolerance, allowed, gate)
        )
    return out


def _ranked(peaks: Measurements, matches: dict[str, Match]) -> Measurements:
    """The matched peaks as ranked measurements (mode = the matched model mode)."""
    table = peaks.table.copy()
    for name, m in matches.items():
        table.loc[table["configuration"] == name, "mode"] = m.modes + 1
    kept = table[table["mode"] > 0].copy()
    order = {name: i for i, name in enumerate(peaks.configurations)}
    kept["_order"] = kept["configuration"].map(order)
    kept = kept.sort_values(["_order", "mode"]).drop(columns="_order").reset_index(drop=True)
    return replace(peaks, table=kept)


def _signature(matches: dict[str, Match]) -> dict:
    """Which peaks and which modes are matched (not who with whom: that is the pairing's
    business, settled by ``ambiguity``)."""
    return {
        name: (tuple(np.flatnonzero(m.matched)), tuple(sorted(m.modes[m.matched])))
        for name, m in matches.items()
    }


def _rescaled_start(model: SpecimenModel, scale: float, parameters) -> tuple[SpecimenModel, str]:
    """Identified moduli x scale^2, when the original plate's spectrum is off by more
    than ``RESCALE_ABOVE``."""
    if abs(np.log(scale)) <= RESCALE_ABOVE:
        return model, ""
    moduli = [p for p in parameters if p.kind in MODULI]
    if not moduli:
        return model, ""
    values = {p: model.value(p) * scale**2 for p in moduli}
    return model.with_values(values), (
        f"start moduli x {scale**2:.3g}: the start model's spectrum of "
        f"'{model.specimen.configurations[0].name}' lies {scale:.3g} x over the "
        "peaks (frequencies go as the square root of stiffness)"
    )


def _screened_start(
    handbook: SpecimenModel,
    scaled: SpecimenModel,
    matches: dict[str, Match],
    peaks: Measurements,
    parameters,
    options: FitOptions,
) -> tuple[SpecimenModel, dict[str, Match], str]:
    """The screen's start and matching (``peak_screen``) in place of the scaled start's,
    where the screen runs."""
    screened = screen(_solver(handbook, peaks, options), peaks, parameters, scaled)
    if screened is None:
        return scaled, matches, ""
    moved = ", ".join(
        f"{p.name} {display(p, scaled.value(p)):.4g} -> {display(p, v):.4g}"
        for p, v in screened.values.items()
        if not np.isclose(v, scaled.value(p), rtol=1e-6)
    )
    count = matched_count(screened.matches)
    scaled_cost = (
        f"{screened.scaled_cost:.3g}" if np.isfinite(screened.scaled_cost) else "inadmissible"
    )  # polished onto an inadmissible material
    return (
        scaled.with_values(screened.values),
        screened.matches,
        (
            f"start screened over {screened.scored} points of the moduli on a reduced model: {moved}; on a "
            "full solve "
            f"it matches {count} of {len(peaks)} peaks within {SCREEN_TOLERANCE:.0%} (matching cost "
            f"{screened.cost:.3g}; "
            f"the scaled start polished: {scaled_cost})"
        ),
    )


def fit_peak_list(
    model: SpecimenModel,
    peaks: Measurements,
    parameters: list[Parameter] | None = None,
    options: FitOptions = FitOptions(),
    progress: Callable[[Iteration], None] | None = None,
    follow: Follow = Follow(),
) -> FitResult:
    """Identify ``parameters`` from a peak list (no mode numbers): match, fit, match again
    at the solution until settled; the result's ``peaks`` says what became of each peak.
    ``follow.matches`` (``Match`` per configuration) skips the alignment (e.g. a baseline
    fit's final matching); ``follow.effect_of`` names each parameter's effect.  The final
    fit checks its pairings as ``follow.settle`` asks (default in full); the modes are
    paired afresh in every round."""
    parameters = list(parameters) if parameters is not None else model.specimen.material_parameters()
    start_matches, effect_of = follow.matches, follow.effect_of
    notes = []
    matches = start_matches or _match_all(_solver(model, peaks, options), peaks, None)
    if start_matches is None:
        first = peaks.configurations[0]
        handbook = model
        model, note = _rescaled_start(model, matches[first].scale, parameters)
        notes += [note] if note else []
        matches = _match_all(_solver(model, peaks, options), peaks, None) if note else matches
        model, matches, note = _screened_start(handbook, model, matches, peaks, parameters, options)
        notes += [note] if note else []
    matched = matched_count(matches)
    if matched < len(parameters):
        raise MeasurementError(
            f"only {matched} of {len(peaks)} peaks match a mode of the start model, fewer than the "
            f"{len(parameters)} unknowns: the peaks are not this specimen's modes, or the start is far off; "
            "check the units (Hz) and the start properties, or give the mode numbers (a 'mode' column)"
        )
    # From a solution's matching the model is as close as it gets: no narrowing rounds, its
    # own error is the tolerance at once.
    narrowing = TIGHTENING if start_matches is None else ()
    seen, revisited = [_signature(matches)], []
    history: list[Iteration] = []
    result = None
    for round_ in range(MAX_ROUNDS + len(narrowing)):
        ranked = _ranked(peaks, matches)
        if result is None:  # a round whose matching is the last fit's would refit the same problem
            # Rounds while the matching moves skip the pairing checks; the settled one does them.
            moving = Follow(effect_of, settle=Settle.NONE)
            result = update(model, ranked, parameters, _options(options, peaks, ranked), progress, moving)
            history += _renumbered(result.history, history)
            model = result.model  # the last fit's solution: where the next round and the final fit start
        tightening = round_ < len(narrowing)
        tolerance = narrowing[round_] if tightening else model_error(result)
        again = _match_all(_solver(result.model, peaks, options, ranked), peaks, tolerance)
        kept = matched_count(again)
        if kept <= len(parameters):
            # A fit still far off (a start in the wrong basin) matches too few peaks at this
            # tolerance to fit its unknowns and test the fit (``_without_redundancy``): the
            # last matching stays.
            notes.append(
                f"re-matching at {tolerance:.2%} kept {kept} of {len(peaks)} peaks, no more than the "
                f"{len(parameters)} unknowns: the last matching was kept (the model is far from the peaks)"
            )
            if tightening:
                continue
            break
        unchanged = all(np.array_equal(again[c].modes, matches[c].modes) for c in matches)
        if not tightening and _signature(again) == seen[-1]:
            matches = again
            break
        if tightening:  # a peak left out while the model was still far off gets another chance
            seen.append(_signature(again))
            matches, result = again, (result if unchanged else None)
            continue
        # it cycles: keep the last fit, say so
        if _signature(again) in seen and _signature(again) in revisited:
            notes.append(
                "the peak matching did not settle (it cycles between alternatives): check the "
                "left-out peaks and unseen modes below"
            )
            break
        if _signature(again) in seen:
            # Back to a matching fitted before, now from another solution: a fit from a far
            # start can end in a local minimum that a peak or two left out lets it escape,
            # and the matching back from the better solution is then settled, not a cycle.
            revisited.append(_signature(again))
        seen.append(_signature(again))
        notes.append("peaks re-matched at the solution (a different set of peaks or modes fits): refitted")
        matches, result = again, None
    else:
        # The last round may have re-matched after its fit (result None): the final fit
        # below starts from that fit's solution with the new matching.
        notes.append(f"the peak matching had not settled after {MAX_ROUNDS} rounds at the final tolerance")
    ranked = _ranked(peaks, matches)
    final = Follow(effect_of, settle=follow.settle)
    result = update(model, ranked, parameters, _options(options, peaks, ranked), progress, final)
    history += _renumbered(result.history, history)
    assignment = _assignment(result.model, peaks, matches, _options(options, peaks, ranked), ranked)
    return replace(
        _without_redundancy(result, len(peaks)),
        warnings=tuple(notes) + tuple(assignment.notes()) + result.warnings,
        peaks=assignment,
        history=tuple(history),
    )


def _without_redundancy(result: FitResult, n_peaks: int) -> FitResult:
    """A peak-list fit that chose too few of the ``n_peaks`` peaks to be tested is not
    converged, whatever its misfit on them.  With no more matched peaks than unknowns it
    is not identifiable: the fit chose which mode each peak is, and with no frequency to
    spare every such choice fits exactly, so nothing tests it (a 20 dB recording chain
    gave 12 peaks for 12 unknowns, "converged" with a modulus 7.6 std off).  With fewer
    than half the peaks matched it is a poor fit (``MATCHED_SHARE``): the matching
    tolerance at the solution is the fit's own error, so a fit that explains a few peaks
    exactly leaves out every other one and passes the chi^2 test on the peaks it kept (a
    real-like spruce plate's thick-plate and point-mass refit kept 11 of 30 peaks,
    "converged" at 0.65 x the scatter, with a 1.5 g sensor 75 mm from the true 4 g one and
    peaks 0.12-0.37 % from unmatched modes left out as spurious)."""
    st = result.statistics
    if result.status is not FitStatus.CONVERGED:
        return result
    if st.dof > 0 and not too_few_matched(st.n, n_peaks):
        return result
    if st.dof > 0:
        return replace(
            result,
            status=FitStatus.POOR_FIT,
            message=(
                f"poor fit: {st.n} of {n_peaks} peaks match a mode at the solution, fewer than "
                f"{MATCHED_SHARE:.0%}: the fit explains the peaks it kept ({st.describe()}) and "
                "leaves out the others as spurious, which tests nothing; likely a start or a model far "
                "from the plate (see the left-out peaks and unseen modes; run 'identify-layers "
                "diagnose'), or give the mode numbers (a 'mode' column)"
            ),
        )
    return replace(
        result,
        status=FitStatus.NOT_IDENTIFIABLE,
        message=(
            f"not identifiable: {st.n} matched peaks for {st.k} unknowns, so the peaks' pairing with the "
            "model's modes "
            "is chosen by the fit and nothing is left to test it; measure more modes, give the mode numbers "
            "(a 'mode' "
            "column), or identify fewer parameters"
        ),
    )


def matching_cost(result: FitResult, peaks: Measurements, tolerance: float) -> float:
    """The cost of matching every peak of ``peaks`` to ``result``'s model at ``tolerance``
    (``matching.match``: a matched peak its squared error in sigma, a left-out one
    ``GATE^2``): two fits of one peak list compared on all its peaks at one tolerance,
    whichever peaks each of them matched."""
    solver = _solver(result.model, peaks, FitOptions(), result.measurements)
    return sum(m.cost for m in _match_all(solver, peaks, tolerance).values())


def start_matching_cost(model: SpecimenModel, peaks: Measurements) -> float:
    """The cost of matching every peak of ``peaks`` to ``model`` as it stands, laid over by
    the best scale (``matching.match`` at the start's tolerance, as a first fit matches):
    starts of one peak list compared before any is fitted."""
    return sum(m.cost for m in _match_all(_solver(model, peaks, FitOptions()), peaks, None).values())


def model_error(result: FitResult) -> float:
    """How far the model may be off at a solution (relative): a robust scale of the
    residuals (1.48 x their median absolute value), at least ``SOLUTION_TOLERANCE_FLOOR``."""
    return max(1.4826 * float(np.median(np.abs(result.rel_error))), SOLUTION_TOLERANCE_FLOOR)


def _renumbered(rounds: tuple[Iteration, ...], before: list[Iteration]) -> list[Iteration]:
    """A round's iterations continuing the numbering of those ``before`` (its start, the
    previous round's end, dropped)."""
    if not before:
        return list(rounds)
    offset = before[-1].number
    return [replace(it, number=it.number + offset) for it in rounds[1:]]


def matched_at(model: SpecimenModel, peaks: Measurements) -> Measurements:
    """The peaks matched to the model as it stands (laid over by the best scale), ranked:
    for comparing a peak list without fitting."""
    return _ranked(peaks, _match_all(_solver(model, peaks, FitOptions()), peaks, None))


def _assignment(
    model: SpecimenModel,
    peaks: Measurements,
    matches: dict[str, Match],
    options: FitOptions,
    ranked: Measurements,
) -> PeakAssignment:
    solver = _solver(model, peaks, options, ranked)
    table = peaks.table
    modes = np.zeros(len(table), dtype=int)
    model_hz = np.zeros(len(table))
    nearest = np.zeros(len(table), dtype=int)
    unseen = {}
    for name, m in matches.items():
        rows = np.flatnonzero(table["configuration"].to_numpy() == name)
        f = solver.solve(name).frequencies_hz
        measured = table["frequency_hz"].to_numpy()[rows]
        near = np.argmin(np.abs(measured[:, None] / f[None, :] - 1), axis=1)
        chosen = np.where(m.matched, m.modes, near)
        modes[rows] = np.where(m.matched, m.modes + 1, 0)
        model_hz[rows], nearest[rows] = f[chosen], chosen + 1
        band = np.flatnonzero((f >= measured.min()) & (f <= measured.max()))
        unseen[name] = [int(j) + 1 for j in band if j not in set(m.modes[m.matched].tolist())]
    return PeakAssignment(peaks, modes, model_hz, nearest, unseen, dict(matches))


__all__ = ["PeakAssignment", "fit_peak_list", "matched_at", "matching_cost", "model_error", "peak_table"]
