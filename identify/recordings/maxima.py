"""Local maxima of a sampled curve and their prominences, as ``scipy.signal.find_peaks``
and ``scipy.signal.peak_prominences`` define them (without ``wlen`` or the other
criteria).

Why not scipy's: importing ``scipy.signal`` takes 0.4 s (its peak-finding module
imports ``scipy.stats``), which was a tenth of ``identify-layers peaks`` on 5 hits and
more than the finding itself ever costs; these two definitions are all the recordings
need.  ``tests/identify/recordings/test_maxima.py`` checks both against scipy's on random curves,
plateaus and ties included.
"""

from __future__ import annotations

import numpy as np


def local_maxima(x: np.ndarray) -> np.ndarray:
    """Indices of the local maxima of ``x``: a sample, or the middle of a flat run
    (rounded down), higher than the samples either side; never the first or last."""
    x = np.asarray(x, dtype=float)
    if len(x) < 3:
        return np.array([], dtype=np.intp)
    start = np.flatnonzero(np.concatenate([[True], x[1:] != x[:-1]]))  # flat runs
    end = np.append(start[1:], len(x)) - 1
    level = x[start]
    run = np.flatnonzero((level[1:-1] > level[:-2]) & (level[1:-1] > level[2:])) + 1
    return (start[run] + end[run]) // 2


def prominences(x: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """Prominence of each of the ``peaks`` (indices) of ``x``: its height above the
    higher of the lowest samples between it and the nearest strictly higher sample on
    either side (or that side's end)."""
    x = np.asarray(x, dtype=float)
    peaks = np.asarray(peaks, dtype=np.intp)
    if not len(peaks):
        return np.zeros(0)
    highest, lowest = _range_tables(x, np.maximum), _range_tables(x, np.minimum)
    height = x[peaks]
    # The nearest strictly higher sample on each side, by binary lifting over the
    # range maxima: widen the range below the peak while it stays at most its height.
    left, right = peaks.copy(), peaks + 1
    for level in reversed(range(len(highest))):
        width = 1 << level
        table = highest[level]
        step = left - width
        move = (step >= 0) & (table[np.maximum(step, 0)] <= height)
        left = np.where(move, step, left)
        move = (right + width <= len(x)) & (table[np.minimum(right, len(table) - 1)] <= height)
        right = np.where(move, right + width, right)
    return height - np.maximum(_range_min(lowest, left, peaks), _range_min(lowest, peaks, right - 1))


def find_peaks(x: np.ndarray, prominence: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The local maxima of ``x`` of at least ``prominence``, and their prominences."""
    peaks = local_maxima(x)
    prominent = prominences(x, peaks)
    keep = prominent >= prominence
    return peaks[keep], prominent[keep]


def _range_tables(x: np.ndarray, reduce) -> list[np.ndarray]:
    """Sparse table: entry [k][i] is ``reduce`` over x[i : i + 2**k]."""
    tables = [x]
    width = 1
    while 2 * width <= len(x):
        tables.append(reduce(tables[-1][:-width], tables[-1][width:]))
        width *= 2
    return tables


def _range_min(lowest: list[np.ndarray], first: np.ndarray, last: np.ndarray) -> np.ndarray:
    """min(x[first : last + 1]) for each pair (first <= last) from the minimum tables."""
    level = np.floor(np.log2(last - first + 1)).astype(np.intp)
    out = np.empty(len(first))
    for k in np.unique(level):
        at = level == k
        table = lowest[k]
        out[at] = np.minimum(table[first[at]], table[last[at] - (1 << k) + 1])
    return out
