"""Which physical effect is the model missing?

The baseline (layer properties fitted, no effect) is compared with one refit per
candidate effect, its parameters free together with the layer properties.  Each is
judged by the Bayesian information criterion, BIC = chi^2 + k ln n (chi^2 in units of the
measurement scatter, k free parameters, n frequencies), so an effect's extra parameters
must pay for themselves; without a stated scatter, chi^2 is replaced by n ln(RSS / n).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from fem.effects import REGISTRY, SwitchedOn, effect
from fem.errors import LayerIdError
from fem.model import ModelOptions
from fem.specimen import Specimen

from .compare import Comparison, compare
from .measurements import Measurements
from .parameters import display, json_key
from .updating import FitOptions, FitResult, fit

#: A baseline reduced chi^2 below this is at the noise level: nothing is clearly missing.
NOISE_CHI2 = 2.0


def information_criterion(result: FitResult) -> float:
    """BIC of a fit: chi^2 + k ln n, or n ln(RSS/n) + k ln n without a stated scatter."""
    table = result.measurements.table
    n, k = len(table), len(result.parameters)
    if result.measurements.has_std:
        chi2 = float(np.sum(((result.model_hz - table["frequency_hz"]) / table["std_hz"]) ** 2))
    else:
        chi2 = n * math.log(max(float(np.mean(result.rel_error**2)), 1e-300))
    return chi2 + k * math.log(n)


@dataclass(frozen=True)
class Candidate:
    """One effect refitted: its fit, the BIC gain over the baseline (positive = better)."""

    kind: str
    note: str
    switched_on: SwitchedOn
    fit: FitResult | None
    gain: float
    error: str = ""

    @property
    def rms_rel_error(self) -> float:
        return self.fit.rms_rel_error if self.fit else float("nan")

    def effect_values(self) -> dict[str, float]:
        """The effect's own parameters in display units (e.g. mass_g, x_mm)."""
        if not self.fit:
            return {}
        return {json_key(p) if p.kind not in ("angle", "thickness") else f"{p.target}.{json_key(p)}":
                display(p, self.fit.value(p)) for p in self.switched_on.free}


@dataclass(frozen=True)
class Diagnosis:
    baseline: FitResult
    comparison: Comparison
    candidates: tuple[Candidate, ...]        # best first

    @property
    def at_noise_level(self) -> bool:
        chi2 = self.baseline.uncertainty.reduced_chi2
        return bool(self.baseline.measurements.has_std and np.isfinite(chi2) and chi2 < NOISE_CHI2)

    @property
    def verdict(self) -> str:
        if self.at_noise_level:
            return "nothing beyond the measurement scatter remains: no effect is needed"
        best = self.candidates[0] if self.candidates else None
        if best is None or best.gain <= 0:
            return "no candidate effect explains the misfit well enough to pay for its parameters"
        return (f"most likely missing: {best.kind} (RMS error {100 * self.baseline.rms_rel_error:.3g} % -> "
                f"{100 * best.rms_rel_error:.3g} %)")

    def to_dict(self) -> dict:
        return {
            "rms_rel_error": self.baseline.rms_rel_error,
            "reduced_chi2": self.baseline.uncertainty.reduced_chi2 if self.baseline.measurements.has_std else None,
            "verdict": self.verdict,
            "at_noise_level": self.at_noise_level,
            "ranking": [{"effect": c.kind, "rms_rel_error_after": c.rms_rel_error if c.fit else None,
                         "bic_gain": c.gain if np.isfinite(c.gain) else None, "parameters": c.effect_values(),
                         "note": " ".join(x for x in (c.note, c.error) if x)} for c in self.candidates],
        }

    def report(self) -> str:
        lines = ["== diagnosis ==", "", self.verdict, "",
                 f"baseline: RMS relative error {100 * self.baseline.rms_rel_error:.4f} %, "
                 f"reduced chi^2 {self.baseline.uncertainty.reduced_chi2:.3g}", "",
                 f"  {'effect':18s} {'RMS after %':>12s} {'BIC gain':>10s}  parameters"]
        for c in self.candidates:
            values = ", ".join(f"{k} = {v:.4g}" for k, v in c.effect_values().items())
            gain = f"{c.gain:10.1f}" if np.isfinite(c.gain) else f"{'failed':>10s}"
            lines.append(f"  {c.kind:18s} {100 * c.rms_rel_error:12.4f} {gain}  {values} {c.note} {c.error}".rstrip())
        return "\n".join(lines) + "\n\n" + self.comparison.report()


def fit_with_effects(specimen: Specimen, measurements: Measurements, model: ModelOptions, kinds: list[str],
                     comparison: Comparison | None = None,
                     progress: Callable[[str], None] | None = None) -> tuple[FitResult, FitResult]:
    """The baseline fit and the fit with ``kinds`` switched on, their parameters free.

    The effects start from the baseline's layer properties; a point mass starts at each
    of the positions the residual scan suggests, and the lowest misfit is kept.
    """
    comparison = comparison or compare(specimen, measurements, model)
    baseline = comparison.fitted
    start, options = baseline.specimen, model
    free, effect_of = [], {}
    result = baseline
    for kind in kinds:
        hints = comparison.point_mass_hints if kind == "point_mass" else (None,)
        if kind == "point_mass":
            hints = tuple(hints[:1]) + _quadrant_grid(start, hints[0] if hints else None)
        trials = []
        for hint in hints or (None,):
            variants = effect(kind).free(start, options, hint) if hint else [effect(kind).free_all(start, options)]
            for on in variants:
                if progress:
                    progress(f"fitting with {kind} {on.note}".strip())
                trial = fit(on.specimen, measurements, parameters=list(baseline.parameters) + free + list(on.free),
                            model=on.options, options=FitOptions(max_iterations=12 if kind == "point_mass" else 40),
                            effects={**effect_of, **{p: kind for p in on.free}})
                trials.append((trial, on))
        result, on = min(trials, key=lambda t: _misfit(t[0], converged_only=False))
        if not result.converged:  # the best start was still moving: let it finish
            result = fit(result.specimen, measurements, parameters=list(result.parameters), model=on.options,
                         options=FitOptions(max_iterations=80), effects=result.effect_of)
        rivals = [t for t, o in trials if t is not result and _misfit(t) - _misfit(result) < 4.0 * _scale(result)
                  and _differs(t, result, o.free)]
        if rivals:
            described = "; ".join(", ".join(f"{p.kind} {display(p, r.value(p)):.4g}" for p in on.free) for r in rivals)
            result = replace(result, warnings=result.warnings + (
                f"{kind}: {len(rivals)} other solution(s) fit about as well ({described}): the effect's "
                "parameters are not unique with these modes; measure more modes to separate them",))
        start, options = result.specimen, on.options
        free += list(on.free)
        effect_of.update({p: kind for p in on.free})
    return baseline, result


def _quadrant_grid(specimen: Specimen, best: dict | None) -> tuple[dict, ...]:
    """Point-mass starts on a 3 x 3 grid over the quarter of the plate that holds the
    residual scan's best point (mirrored quarters are equivalent by symmetry)."""
    a, b = specimen.length, specimen.width
    x0, y0 = best["xy"] if best else (a, b)
    mass = best["mass_kg"] if best else None
    out = []
    for fx in (0.2, 0.5, 0.8):
        for fy in (0.2, 0.5, 0.8):
            x = a / 2 + (1 if x0 >= a / 2 else -1) * fx * a / 2
            y = b / 2 + (1 if y0 >= b / 2 else -1) * fy * b / 2
            out.append({"xy": (x, y), "mass_kg": mass})
    return tuple(out)


def _scale(result: FitResult) -> float:
    """chi^2 units: 1 with a stated scatter, else the residual variance."""
    if result.measurements.has_std:
        return 1.0
    dof = max(len(result.measurements) - len(result.parameters), 1)
    return _misfit(result) / dof


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


def _misfit(result: FitResult, converged_only: bool = True) -> float:
    """Weighted misfit used to choose between starts (non-converged fits last unless asked)."""
    r = result.rel_error
    if result.measurements.has_std:
        r = (result.model_hz - result.measurements.table["frequency_hz"]) / result.measurements.table["std_hz"]
    return float(r @ r) if result.converged or not converged_only else float("inf")


def diagnose(specimen: Specimen, measurements: Measurements, model: ModelOptions = ModelOptions(),
             kinds: list[str] | None = None, progress: Callable[[str], None] | None = None) -> Diagnosis:
    """Rank the candidate effects by how much of the misfit they explain (best first)."""
    kinds = list(kinds) if kinds is not None else list(REGISTRY)
    comparison = compare(specimen, measurements, model)
    baseline = comparison.fitted
    base_bic = information_criterion(baseline)
    start = baseline.specimen
    layer_parameters = list(baseline.parameters)
    candidates = []
    for kind in kinds:
        if progress:
            progress(f"trying {kind}")
        try:
            _, result = fit_with_effects(specimen, measurements, model, [kind], comparison)
        except LayerIdError as exc:
            on = SwitchedOn(kind, start, model)
            candidates.append(Candidate(kind, "", on, None, float("-inf"), f"failed: {exc}"))
            continue
        on = SwitchedOn(kind, result.specimen, model, tuple(p for p in result.parameters if p not in layer_parameters))
        gain = base_bic - information_criterion(result) if result.converged else float("-inf")
        notes = [w for w in result.warnings if w.startswith(kind)]
        note = "; ".join(notes) if result.converged else f"{result.status}"
        candidates.append(Candidate(kind, note, on, result, gain))
    return Diagnosis(baseline, comparison, tuple(sorted(candidates, key=lambda c: -c.gain)))
