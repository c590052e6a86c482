"""Why a fit is poor: the likely causes, ranked, in the user's words.

A fit whose misfit the scatter cannot explain has a reason, and its residuals usually
show which:

- units: every measured frequency is the same factor off the model's (kHz typed as Hz,
  rad/s for Hz), which no layer property can absorb, so the moduli run to their bounds;
- configurations: the data of two configurations fit each other's model better (rows
  mixed up in the file), or one configuration alone carries the misfit (its added
  layers or its data);
- pairing: residuals that alternate in sign from mode to mode (a peak list matched off
  by a mode, a start too far away), or a peak list of which fewer than half the peaks
  match a mode at the solution (its misfit on the rest then says nothing);
- missing physics: a smooth pattern over the modes (``compare``'s signatures): run
  ``diagnose``;
- data: none of these, and the misfit is large: the data may not belong to this spec.

Each is scored by the share of the misfit it accounts for (0..1).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from ..engine.objective import solving_model
from ..engine.peak_lists import too_few_matched
from ..engine.result import FitResult, FitStatus
from ..engine.statistics import weighted_residuals
from .patterns import PATTERN_SHARE, residual_patterns

#: Known factors between a frequency in Hz and a slip of unit: what each would mean.
UNIT_SLIPS = {
    1000.0: "kHz read as Hz, or a length in mm typed as m",
    1e-3: "Hz read as kHz, or metres typed as mm",
    2 * math.pi: "angular frequency (rad/s) given as Hz",
    1 / (2 * math.pi): "Hz given where rad/s were meant",
    60.0: "cycles per minute given as Hz",
}
#: A cause is named when it accounts for at least this share of the misfit.
NAMED = 0.5
#: Relative RMS misfit above which frequencies unlike the specimen's are suspected.
UNLIKE = 0.05


@dataclass(frozen=True)
class Cause:
    """A likely reason for a poor fit: ``kind``, the share of the misfit it accounts for
    (0..1) and what to do, in the user's words."""

    kind: str
    score: float
    text: str

    def to_dict(self) -> dict:
        return {"cause": self.kind, "score": round(float(self.score), 3), "text": self.text}


def _units(result: FitResult) -> Cause | None:
    q = np.log(result.measurements.table["frequency_hz"].to_numpy() / result.model_hz)
    mean, spread = float(np.mean(q)), float(np.std(q))
    if len(q) < 3 or abs(mean) < math.log(1.03) or spread > 0.2 * abs(mean):
        return None
    factor = math.exp(mean)
    slip = min(UNIT_SLIPS, key=lambda f: abs(math.log(factor / f)))
    hint = f": {UNIT_SLIPS[slip]}?" if abs(math.log(factor / slip)) < math.log(1.3) else ""
    bounded = [p.name for p, at in zip(result.parameters, result.uncertainty.bounded) if at]
    pinned = f"; {', '.join(bounded)} ran to their bounds trying" if bounded else ""
    return Cause(
        "units",
        1 - spread / abs(mean),
        f"every measured frequency is about {factor:.4g}x the model's{hint} Check the units of the "
        f"measurements and of the spec's lengths, moduli and densities{pinned}",
    )


def _configurations(result: FitResult) -> Cause | None:
    table = result.measurements.table
    r = weighted_residuals(result.model_hz, result.measurements)
    total = float(r @ r)
    names = result.measurements.configurations
    if total <= 0 or len(names) < 2:
        return None
    configs = table["configuration"].to_numpy()
    solver = solving_model(result.model, result.measurements)
    measured = table["frequency_hz"].to_numpy()
    sigma = table["std_hz"].to_numpy() if result.measurements.has_std else measured
    best = None
    for a, b in itertools.combinations(names, 2):
        rows_a, rows_b = np.flatnonzero(configs == a), np.flatnonzero(configs == b)
        fa, fb = solver.solve(a).frequencies_hz, solver.solve(b).frequencies_hz
        ranks_a, ranks_b = table["mode"].to_numpy()[rows_a] - 1, table["mode"].to_numpy()[rows_b] - 1
        if ranks_a.max() >= len(fb) or ranks_b.max() >= len(fa):
            continue
        now = float(np.sum(r[rows_a] ** 2) + np.sum(r[rows_b] ** 2))
        crossed = float(
            np.sum(((fb[ranks_a] - measured[rows_a]) / sigma[rows_a]) ** 2)
            + np.sum(((fa[ranks_b] - measured[rows_b]) / sigma[rows_b]) ** 2)
        )
        if crossed < 0.5 * now and (best is None or now - crossed > best[0]):
            best = (now - crossed, a, b)
    if best is not None:
        gain, a, b = best
        return Cause(
            "configurations",
            min(gain / total, 1.0),
            f"the data of '{a}' and '{b}' fit each other's model better: are the configurations mixed up "
            "in the measurement file?",
        )
    shares = {name: float(np.sum(r[configs == name] ** 2)) / total for name in names}
    worst = max(shares, key=shares.get)
    if shares[worst] > 0.7 and np.mean(configs == worst) < 0.5:
        return Cause(
            "configurations",
            shares[worst],
            f"configuration '{worst}' carries {100 * shares[worst]:.0f} % of the misfit: check its added "
            "layers (materials, thicknesses, the adhesive) and that its data are its own",
        )
    return None


def _pairing(result: FitResult) -> Cause | None:
    r = weighted_residuals(result.model_hz, result.measurements)
    total = float(r @ r)
    if total <= 0:
        return None
    configs = result.measurements.table["configuration"].to_numpy()
    typical = math.sqrt(result.statistics.chi2_unit)
    alternating = np.zeros(len(r), dtype=bool)
    for name in result.measurements.configurations:
        rows = np.flatnonzero(configs == name)
        for a, b in zip(rows[:-1], rows[1:]):
            if r[a] * r[b] < 0 and min(abs(r[a]), abs(r[b])) > 2 * typical:
                alternating[[a, b]] = True
    share = float(np.sum(r[alternating] ** 2)) / total
    if share < 0.3:
        return None
    peaks = (
        " or a peak list matched off by a mode (see the left-out peaks and unseen modes)"
        if result.peaks is not None
        else ""
    )
    return Cause(
        "pairing",
        share,
        "residuals alternate in sign from mode to mode: modes paired with the wrong "
        f"partners{peaks}, or a start far from the solution; label the close modes "
        "(a 'label' column) or start nearer",
    )


def _few_matched(result: FitResult) -> Cause | None:
    """A peak-list fit that matched too few of its peaks (``too_few_matched``): its misfit
    on the peaks it kept says nothing of the others, so this cause comes first whatever
    their residuals show."""
    if result.peaks is None:
        return None
    matched, listed = int(result.peaks.matched.sum()), len(result.peaks.matched)
    if not too_few_matched(matched, listed):
        return None
    return Cause(
        "pairing",
        1.0,
        f"{matched} of {listed} peaks matched: the left-out peaks near unseen modes are likely real modes "
        "that a far model (several effects missing, a wrong basin) cannot place; give the mode numbers you "
        "know (a 'mode' column) or run 'identify-layers diagnose'",
    )


def _missing_physics(result: FitResult) -> Cause | None:
    patterns, *_ = residual_patterns(
        solving_model(result.model, result.measurements),
        result.measurements,
        result.model_hz,
        result.pairings,
        result.jacobian,
    )
    best = max(patterns, key=lambda p: p.share)
    if best.share < PATTERN_SHARE:
        return None
    return Cause(
        "missing_physics",
        best.share,
        f"a smooth pattern over the modes ('{best.name}', {100 * best.share:.0f} % of the misfit) points at "
        f"missing physics ({', '.join(best.suggests)}): run 'identify-layers diagnose'",
    )


def with_causes(result: FitResult) -> FitResult:
    """A poor fit with its likely causes attached and the first named in its message; any
    other fit as it is."""
    if result.status is not FitStatus.POOR_FIT:
        return result
    causes = likely_causes(result)
    return replace(result, causes=causes, message=f"{result.message}; likely: {causes[0].text}")


def likely_causes(result: FitResult) -> tuple[Cause, ...]:
    """The causes the residuals of a poor fit show, most likely first (never empty)."""
    few = _few_matched(result)
    if few is not None:
        return (few,)
    found = [c for c in (_units(result), _configurations(result), _pairing(result)) if c is not None]
    if not any(c.score >= NAMED for c in found):
        physics = _missing_physics(result)
        found += [physics] if physics is not None else []
    found.sort(key=lambda c: -c.score)
    if found and found[0].score >= NAMED:
        return tuple(found)
    if result.statistics.rms_rel_error > UNLIKE:
        data = Cause(
            "data",
            1.0,
            f"the misfit ({100 * result.statistics.rms_rel_error:.3g} % RMS) follows no "
            "pattern: do the measurements belong to this specimen and spec (layers, "
            "thicknesses, densities, size)?",
        )
    else:
        data = Cause(
            "unexplained",
            1.0,
            "no single cause explains the misfit: look at the residuals per mode "
            "('identify-layers compare') and at the stated scatter",
        )
    return (data,) + tuple(found)


__all__ = ["Cause", "likely_causes", "with_causes"]
