"""Matching a peak list to model modes: some modes are missing (a node near the sensor),
some peaks are spurious (suspension, anti-resonances, cable, double hits).

For one configuration, peak i at p_i (std s_i) may be matched to model mode j at f_j at
the cost ((p_i - f_j) / sigma_ij)^2, sigma_ij^2 = s_i^2 + (tau f_j)^2, where tau is how far
the model may still be off (large at the start, small at the solution); a peak left out
costs ``GATE^2`` (so it is matched only within about ``GATE`` sigma of a mode), a mode
left out costs nothing (missing modes are common).  The optimal one-to-one assignment
with these leave-out options is a linear assignment problem (scipy's).

A labelled peak may only match modes that show its nodal pattern, a peak with a measured
shape only modes that resemble it (``pairing.permits``).

At the start the model may be off by tens of percent in stiffness; what survives such
an error is the spectrum's shape.  ``align`` therefore first finds, per configuration,
the factor s that lays s f_j best over the peaks (a scan of the matching cost over s),
and matches there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from .statistics import ASSUMED_SCATTER_REL

#: A peak further than this many sigma from every mode is left out as spurious.
GATE = 3.0
#: The same for a peak whose measured shape resembles a model mode (``pairing.permits``):
#: a spurious peak (suspension, cable, electrical noise) has no plate mode's shape, so
#: such a peak is a mode, and is left out only when far from every mode it may be.
SHAPE_GATE = 10.0
#: How far the start model may be off in the spectrum's shape after the scale alignment
#: (relative): mode ratios of a start within the usual handbook range agree to a few %.
START_TOLERANCE = 0.03
#: Scale factors scanned at the start: the model's frequencies x 1/3 .. 3 (stiffness off
#: by up to a factor 9), log-spaced finely enough (0.1 %) to fall within any tolerance.
SCALES = np.exp(np.linspace(np.log(1 / 3), np.log(3), 2200))
#: Cost that forbids a match (a label the mode does not show).
FORBIDDEN = 1e12


@dataclass(frozen=True)
class Match:
    """For one configuration's peaks: the model mode (0-based) each is matched with, or
    -1 when left out; the cost of the matching; and the scale the model was laid at."""

    modes: np.ndarray
    cost: float
    scale: float = 1.0

    @property
    def matched(self) -> np.ndarray:
        return self.modes >= 0


def matched_count(matches: dict[str, Match]) -> int:
    """How many peaks the configurations' matchings ``matches`` match, in all."""
    return sum(int(m.matched.sum()) for m in matches.values())


def _sigma(peaks_hz: np.ndarray, std_hz: np.ndarray | None) -> np.ndarray:
    return std_hz if std_hz is not None else ASSUMED_SCATTER_REL * peaks_hz


def match(
    peaks_hz: np.ndarray,
    std_hz: np.ndarray | None,
    model_hz: np.ndarray,
    tolerance: float,
    allowed: np.ndarray | None = None,
    gate: np.ndarray | None = None,
) -> Match:
    """The cheapest assignment of peaks to model modes with leave-out options.

    tolerance: relative error the model may still have; allowed: (peaks, modes) bool, the
    matches labels and shapes permit (None: all); gate: per peak, how many sigma from
    every mode it is left out (None: ``GATE``).
    """
    n, m = len(peaks_hz), len(model_hz)
    sigma2 = _sigma(peaks_hz, std_hz)[:, None] ** 2 + (tolerance * model_hz[None, :]) ** 2
    cost = (peaks_hz[:, None] - model_hz[None, :]) ** 2 / sigma2
    if allowed is not None:
        cost = np.where(allowed, cost, FORBIDDEN)
    # Columns: the m modes, then one leave-out slot per peak (cost GATE^2 for its own peak only).
    leave = np.full((n, n), FORBIDDEN)
    np.fill_diagonal(leave, _gates(n, gate) ** 2)
    full = np.hstack([np.minimum(cost, FORBIDDEN), leave])
    rows, cols = linear_sum_assignment(full)
    modes = np.where(cols < m, cols, -1)[np.argsort(rows)]
    total = float(full[rows, cols].sum())
    return Match(modes, total)


def _gates(n: int, gate: np.ndarray | None) -> np.ndarray:
    return np.full(n, GATE) if gate is None else np.asarray(gate, dtype=float)


def _relaxed_costs(
    peaks_hz: np.ndarray,
    std_hz: np.ndarray | None,
    model_hz: np.ndarray,
    allowed: np.ndarray | None,
    gate: np.ndarray | None,
) -> np.ndarray:
    """A lower bound of ``match``'s cost at every scale of ``SCALES``: each peak takes its
    cheapest mode or its leave-out, as if two peaks could share a mode."""
    scaled = SCALES[:, None] * model_hz[None, :]  # (scales, modes)
    sigma2 = _sigma(peaks_hz, std_hz)[None, :, None] ** 2 + (START_TOLERANCE * scaled[:, None, :]) ** 2
    cost = (peaks_hz[None, :, None] - scaled[:, None, :]) ** 2 / sigma2
    if allowed is not None:
        cost = np.where(allowed[None], cost, FORBIDDEN)
    return np.minimum(cost.min(axis=2, initial=FORBIDDEN), _gates(len(peaks_hz), gate) ** 2).sum(axis=1)


def align(
    peaks_hz: np.ndarray,
    std_hz: np.ndarray | None,
    model_hz: np.ndarray,
    allowed: np.ndarray | None = None,
    gate: np.ndarray | None = None,
) -> Match:
    """The match of the peaks to the model's frequencies scaled by the factor that fits
    them best (``SCALES``), at ``START_TOLERANCE``; ties go to the factor nearest 1.

    The scales are tried cheapest lower bound first (:func:`_relaxed_costs`) and the
    scan stops where the bound exceeds the best cost found: the same optimum as trying
    every scale, with a few assignments instead of thousands."""
    bound = np.round(_relaxed_costs(peaks_hz, std_hz, model_hz, allowed, gate), 9)
    distance = np.abs(np.log(SCALES))
    best = None
    for i in np.lexsort((distance, bound)):
        if best is not None and (bound[i], distance[i]) >= best[0]:
            break
        trial = match(peaks_hz, std_hz, SCALES[i] * model_hz, START_TOLERANCE, allowed, gate)
        key = (round(trial.cost, 9), distance[i])
        if best is None or key < best[0]:
            best = (key, Match(trial.modes, trial.cost, float(SCALES[i])))
    return best[1]


__all__ = ["Match", "match", "matched_count", "align", "GATE", "SHAPE_GATE"]
