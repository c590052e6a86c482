"""``matching.align`` scans the scales cheapest lower bound first and stops early: it
must pick exactly the scale, matching and cost of trying every scale."""

import numpy as np
import pytest

from identify.engine.matching import SCALES, START_TOLERANCE, Match, align, match


def every_scale(peaks_hz, std_hz, model_hz, allowed):
    """The reference: every scale of SCALES tried, ties to the scale nearest 1."""
    best = None
    for scale in SCALES:
        trial = match(peaks_hz, std_hz, scale * model_hz, START_TOLERANCE, allowed)
        key = (round(trial.cost, 9), abs(np.log(scale)))
        if best is None or key < best[0]:
            best = (key, Match(trial.modes, trial.cost, float(scale)))
    return best[1]


@pytest.mark.parametrize("seed", range(12))
def test_align_equals_the_full_scan(seed):
    """Random spectra laid over at 0.5-2x, 1 % scatter, modes missing, spurious peaks,
    with and without std and label restrictions."""
    rng = np.random.default_rng(seed)
    model = np.sort(rng.uniform(50, 1000, rng.integers(5, 14)))
    n = int(rng.integers(3, len(model)))
    peaks = np.sort(
        rng.choice(model, n, replace=False) * rng.uniform(0.5, 2) * (1 + 0.01 * rng.standard_normal(n))
    )
    if seed % 3 == 0:
        peaks = np.sort(np.append(peaks, rng.uniform(50, 1000, 2)))
    std = None if seed % 2 else 0.002 * peaks
    allowed = None if seed % 4 else rng.uniform(size=(len(peaks), len(model))) > 0.2
    fast, full = align(peaks, std, model, allowed), every_scale(peaks, std, model, allowed)
    assert fast.scale == full.scale and fast.cost == full.cost
    np.testing.assert_array_equal(fast.modes, full.modes)
