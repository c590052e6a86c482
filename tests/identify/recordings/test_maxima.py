"""identify.recordings.maxima against the scipy.signal functions it stands in for
(find_peaks, peak_prominences): the same peaks and the same prominences, bit for bit, on
any curve, flat runs and ties included (hypothesis)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from identify.recordings.maxima import find_peaks, local_maxima, prominences

#: Curves with many ties and flat runs (few distinct levels) and curves of any floats.
few_levels = st.lists(st.integers(0, 3).map(float), max_size=80)
any_floats = st.lists(st.floats(-1e6, 1e6, allow_nan=False), max_size=80)
curves = st.one_of(few_levels, any_floats).map(np.array)


@settings(max_examples=400, deadline=None)
@given(curves)
def test_local_maxima_and_prominences_match_scipy(x):
    expected = signal.find_peaks(x)[0] if len(x) else np.array([], dtype=int)
    found = local_maxima(x)
    assert np.array_equal(found, expected)
    if len(found):
        assert np.array_equal(prominences(x, found), signal.peak_prominences(x, found)[0])


@settings(max_examples=200, deadline=None)
@given(curves, st.sampled_from([0.0, 0.5, 1.0, 2.5]))
def test_find_peaks_with_a_prominence_matches_scipy(x, minimum):
    expected, props = (
        signal.find_peaks(x, prominence=minimum)
        if len(x)
        else (np.array([], dtype=int), {"prominences": np.zeros(0)})
    )
    found, prominent = find_peaks(x, minimum)
    assert np.array_equal(found, expected)
    assert np.array_equal(prominent, props["prominences"])


def test_a_noisy_spectrum_matches_scipy():
    """The size of a 2-s hit's band (6000 lines in dB), where the tables are 13 deep."""
    rng = np.random.default_rng(3)
    x = 20 * np.log10(np.abs(rng.standard_normal(6000) + 1j * rng.standard_normal(6000)))
    expected, props = signal.find_peaks(x, prominence=0.3)
    found, prominent = find_peaks(x, 0.3)
    assert np.array_equal(found, expected) and np.array_equal(prominent, props["prominences"])
