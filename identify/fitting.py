"""``fit``: identify the layers of a specimen, optionally with physical effects whose
parameters are estimated together with the layer properties."""
from __future__ import annotations

from dataclasses import replace
from typing import Callable, Sequence

from fem.effects import effect
from fem.model import SpecimenModel

from .measurements import Measurements
from .parameters import display
from .peak_lists import fit_peak_list
from .budget import with_budget
from .causes import likely_causes
from .result import FitResult, FitStatus, Iteration
from .updating import FitOptions, update

#: Iterations per point-mass start (the best start is then continued).
POINT_MASS_ITERATIONS = 12
#: Two effect estimates whose chi^2 differ by less than this (about 2 std) are rivals.
RIVAL_CHI2 = 4.0


def fit(model: SpecimenModel, measurements: Measurements, effects: Sequence[str] = (), *,
        parameters=None, options: FitOptions = FitOptions(),
        progress: Callable[[Iteration | str], None] | None = None) -> FitResult:
    """Identify E1, E2, G12, nu12 of every identified material of ``model`` (or the given
    ``parameters``) from the measured frequencies of all configurations at once.

    effects: kinds switched on with their parameters free (e.g. ``["point_mass"]``): the
    layers are fitted first, then again with the effects; the result's ``baseline`` is
    the fit without them.  Values are SI inside; ``report()`` and ``to_dict()`` print
    in the spec's units (GPa, mm, g).  ``progress`` is called with every accepted
    iteration (or, with effects, a line of text per refit).  When the spec states the
    known inputs' std, the result carries the uncertainty budget and its std includes them.
    """
    if effects:
        for kind in effects:
            effect(kind)  # unknown kinds fail before any work
        return with_budget(fit_with_effects(model, measurements, list(effects), progress=progress))
    return with_budget(fit_layers(model, measurements, parameters, options, progress))


def fit_layers(model: SpecimenModel, measurements: Measurements, parameters=None, options: FitOptions = FitOptions(),
               progress: Callable[[Iteration], None] | None = None, effect_of: dict | None = None,
               like: FitResult | None = None, explain: bool = True) -> FitResult:
    """The multi-model updating of ranked measurements, or of a peak list (matched to the
    model's modes as it goes).  ``like``: a fit of the same peak list whose final matching
    starts this one (an effect's refit starts from its baseline's).  ``explain``: give a
    poor fit its likely causes (``causes``)."""
    if measurements.ranked:
        result = update(model, measurements, parameters, options, progress, effect_of)
    else:
        start = like.peaks.matches() if like is not None and like.peaks is not None else None
        result = fit_peak_list(model, measurements, parameters, options, progress, effect_of, start)
    if explain and result.status is FitStatus.POOR_FIT:
        causes = likely_causes(result)
        result = replace(result, causes=causes, message=f"{result.message}; likely: {causes[0].text}")
    return result


def fit_with_effects(model: SpecimenModel, measurements: Measurements, kinds: list[str], comparison=None,
                     progress: Callable[[str], None] | None = None) -> FitResult:
    """The fit with ``kinds`` switched on, their parameters free, starting from the
    baseline fit's layer properties (``comparison.fitted``, computed when not given).

    A point mass starts at each of the positions the residual scan suggests and on a grid
    over that quarter of the plate; the lowest misfit is kept and rivals that fit about as
    well are reported.
    """
    from .compare import compare

    comparison = comparison or compare(model, measurements)
    baseline = comparison.fitted
    start = baseline.model
    free, effect_of = [], {}
    result = baseline
    notes = []
    for kind in kinds:
        hints = comparison.point_mass_hints if kind == "point_mass" else (None,)
        if kind == "point_mass":
            hints = tuple(hints[:1]) + _quadrant_grid(start, hints[0] if hints else None)
        trials = []
        for hint in hints or (None,):
            variants = effect(kind).free(start, hint) if hint else [effect(kind).free_all(start)]
            for on in variants:
                if progress:
                    progress(f"fitting with {kind} {on.note}".strip())
                trial = fit_layers(on.model, measurements, list(baseline.parameters) + free + list(on.free),
                                   FitOptions(max_iterations=POINT_MASS_ITERATIONS if kind == "point_mass" else 40),
                                   effect_of={**effect_of, **{p: kind for p in on.free}}, like=baseline,
                                   explain=False)
                trials.append((trial, on))
        result, on = min(trials, key=lambda t: t[0].statistics.sum_squares)
        if not result.finished:  # the best start was still moving: let it finish
            result = fit_layers(result.model, measurements, list(result.parameters), FitOptions(max_iterations=80),
                                effect_of=result.effect_of, like=result, explain=False)
        rivals = [t for t, o in trials if t is not result and t.finished
                  and t.statistics.sum_squares - result.statistics.sum_squares < RIVAL_CHI2 * result.statistics.chi2_unit
                  and _differs(t, result, o.free)]
        if rivals:
            described = "; ".join(", ".join(f"{p.kind} {display(p, r.value(p)):.4g}" for p in on.free) for r in rivals)
            notes.append((kind, f"{kind}: {len(rivals)} other solution(s) fit about as well ({described}): the "
                                "effect's parameters are not unique with these modes; measure more modes to separate "
                                "them"))
        start = result.model
        free += list(on.free)
        effect_of.update({p: kind for p in on.free})
    if result.status is FitStatus.POOR_FIT:
        causes = likely_causes(result)
        result = replace(result, causes=causes, message=f"{result.message}; likely: {causes[0].text}")
    return replace(result, warnings=result.warnings + tuple(text for _, text in notes), effect_notes=tuple(notes),
                   baseline=baseline)


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


def _differs(a: FitResult, b: FitResult, parameters, tolerance: float = 0.05) -> bool:
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


__all__ = ["fit", "fit_with_effects"]
