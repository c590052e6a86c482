"""Which physical effect is the model missing?

The baseline (layer properties fitted, no effect) is compared with one refit per
candidate effect, its parameters free together with the layer properties.  Each is
judged by the Bayesian information criterion, BIC = chi^2 + k ln n (chi^2 in units of the
measurement scatter, k free parameters, n frequencies), so an effect's extra parameters
must pay for themselves; without a stated scatter, chi^2 is replaced by n ln(RSS / n).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from fem.effects import REGISTRY, SwitchedOn, effect
from fem.errors import LayerIdError
from fem.io import html_pre
from fem.model import SpecimenModel

from .compare import Comparison, compare
from .fitting import fit_with_effects
from .measurements import Measurements
from .parameters import display, json_key
from .result import FitResult


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
        return self.comparison.at_noise_level

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
            "reduced_chi2": self.baseline.statistics.reduced_chi2 if self.baseline.statistics.scatter_known else None,
            "verdict": self.verdict,
            "at_noise_level": self.at_noise_level,
            "ranking": [{"effect": c.kind, "rms_rel_error_after": c.rms_rel_error if c.fit else None,
                         "bic_gain": c.gain if np.isfinite(c.gain) else None, "parameters": c.effect_values(),
                         "note": " ".join(x for x in (c.note, c.error) if x)} for c in self.candidates],
        }

    def _repr_html_(self) -> str:
        return html_pre(self.report())

    def report(self) -> str:
        lines = ["== diagnosis ==", "", self.verdict, "",
                 f"baseline: RMS relative error {100 * self.baseline.rms_rel_error:.4f} %, "
                 f"reduced chi^2 {self.baseline.statistics.reduced_chi2:.3g}", "",
                 f"  {'effect':18s} {'RMS after %':>12s} {'BIC gain':>10s}  parameters"]
        for c in self.candidates:
            values = ", ".join(f"{k} = {v:.4g}" for k, v in c.effect_values().items())
            gain = f"{c.gain:10.1f}" if np.isfinite(c.gain) else f"{'failed':>10s}"
            lines.append(f"  {c.kind:18s} {100 * c.rms_rel_error:12.4f} {gain}  {values} {c.note} {c.error}".rstrip())
        return "\n".join(lines) + "\n\n" + self.comparison.report()


def diagnose(model: SpecimenModel, measurements: Measurements, kinds: list[str] | None = None,
             progress: Callable[[str], None] | None = None) -> Diagnosis:
    """Rank the candidate effects by how much of the misfit they explain (best first)."""
    kinds = list(kinds) if kinds is not None else list(REGISTRY)
    for kind in kinds:
        effect(kind)  # unknown kinds fail before any work
    comparison = compare(model, measurements)
    baseline = comparison.fitted
    layer_parameters = list(baseline.parameters)
    candidates = []
    for kind in kinds:
        if progress:
            progress(f"trying {kind}")
        try:
            result = fit_with_effects(model, measurements, [kind], comparison)
        except LayerIdError as exc:
            candidates.append(Candidate(kind, "", SwitchedOn(kind, baseline.model), None, float("-inf"),
                                        f"failed: {exc}"))
            continue
        on = SwitchedOn(kind, result.model, tuple(p for p in result.parameters if p not in layer_parameters))
        gain = baseline.statistics.bic - result.statistics.bic if result.converged else float("-inf")
        note = "; ".join(text for k, text in result.effect_notes if k == kind) if result.converged else result.message
        candidates.append(Candidate(kind, note, on, result, gain))
    return Diagnosis(baseline, comparison, tuple(sorted(candidates, key=lambda c: -c.gain)))
