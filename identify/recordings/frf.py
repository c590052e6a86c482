"""From hits to the averaged FRF: hit detection and cutting, double-hit rejection, force
and exponential windows, H1 and coherence.

Each hit is cut at its force onset (the first sample above ``PULSE_LEVEL`` of the force
peak, less ``PRE_TRIGGER_S``).  The force window keeps the pulse (onset to the pulse's
end plus one pulse width) and zeroes the rest, removing the force channel's noise.  A
second force excursion above ``DOUBLE_HIT_LEVEL`` of the peak (or a second maximum of
that prominence within the pulse), or a notch deeper than ``NOTCH_DB`` in a hit's force
spectrum within the band, rejects that hit (a double hit).

A response that has not decayed to ``DECAYED`` of its level just after the hit (RMS
over ``LEVEL_WINDOW_S``) by the end of its record (a record cut short) would leak when
padded to the longest record; then the exponential window exp(-r t) is applied to both
channels of *every* hit (H1 averages them, so they must share their poles), with the
one rate r that brings the worst record down to ``WINDOW_TARGET`` (the level of a fully
decayed record: a 1e-2 target leaves the slowest mode truncated at a few percent and
biases damping by up to 5 %).  Windowing both channels alike makes the
windowed FRF exactly H(s + r): every pole moves left by r, and
:func:`correct_for_window` moves it back.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import fft

from fem.errors import MeasurementError

from .maxima import find_peaks
from .readers import Hit, MeasuredFRF

PULSE_LEVEL = 0.05
DOUBLE_HIT_LEVEL = 0.10
NOTCH_DB = 6.0
PRE_TRIGGER_S = 0.5e-3
DECAYED = 1e-2
WINDOW_TARGET = 1e-3
LEVEL_WINDOW_S = 0.02
#: A hit must stand this many times above the force channel's noise.
MIN_HIT_SNR = 20.0
#: Lower band edge by default: a free plate's suspension modes lie below it.
SUSPENSION_HZ = 20.0
#: Upper band edge by default: where the mean force spectrum falls this far below its
#: level at the lower edge (the hammer tip no longer excites the plate).
FORCE_DROP_DB = 10.0
#: A channel is clipped (the ADC's or amplifier's limit) when this many consecutive
#: samples sit at its extreme value: a smooth signal's maximum is one sample.
CLIP_RUN = 3
#: Mains frequencies [Hz] looked for, how far each may drift [Hz], and the level of a
#: harmonic above its neighbourhood in the record's tail that counts as hum [dB].
MAINS_HZ = (50.0, 60.0)
MAINS_DRIFT_HZ = 0.2
HUM_DB = 15.0
#: Hum is steady: its amplitude over the tail's second half within these factors of the first's.
HUM_STEADY = (0.7, 1.4)
#: A harmonic's neighbourhood in the tail's spectrum: 9 lines either side, 3 lines clear of it.
NEIGHBOURHOOD = np.r_[-12:-3, 4:13]


@dataclass(frozen=True)
class Rejection:
    """A hit left out of the average, and why."""

    source: str
    reason: str


@dataclass(frozen=True, eq=False)
class AveragedFRF:
    """The FRF of one configuration on lines ``frequency_hz`` [Hz].

    h1: H1 = sum_k Y_k X_k* / sum_k |X_k|^2 (response unit / force unit); response-only
    recordings: the mean response spectrum mean_k Y_k instead (no force, so no FRF: the
    FRF times the hammer's smooth force spectrum; the hits are cut at their onsets, so
    their phases agree).  coherence: gamma^2 = |sum Y X*|^2 / (sum |X|^2 sum |Y|^2) (NaN without force or
    with one hit).  per_hit: each hit's H_k = Y_k / X_k (response-only: Y_k).  weights:
    each hit's share of H1 at each line, |X_k|^2 / sum |X|^2, so H1 = sum_k weights_k H_k
    (response-only: |Y_k|^2 / sum |Y|^2, each hit's share of the response power).
    decay_rate: r of the exponential window exp(-r t) on both channels [1/s] (0: none).
    """

    frequency_hz: np.ndarray
    h1: np.ndarray
    coherence: np.ndarray
    per_hit: np.ndarray
    weights: np.ndarray
    sources: tuple[str, ...]
    rejected: tuple[Rejection, ...] = ()
    decay_rate: float = 0.0
    has_force: bool = True
    quantity: str = "acceleration"
    notes: tuple[str, ...] = ()

    @property
    def n_hits(self) -> int:
        return len(self.sources)

    @property
    def resolution_hz(self) -> float:
        return float(self.frequency_hz[1] - self.frequency_hz[0])

    def line(self, frequency_hz) -> np.ndarray:
        """Index of the line nearest each frequency [Hz]."""
        i = np.rint((np.asarray(frequency_hz) - self.frequency_hz[0]) / self.resolution_hz).astype(int)
        return np.clip(i, 0, len(self.frequency_hz) - 1)

    def lines(self, band_hz) -> np.ndarray:
        """Indices of the lines inside ``band_hz`` (inclusive)."""
        return np.flatnonzero((self.frequency_hz >= band_hz[0]) & (self.frequency_hz <= band_hz[1]))


def correct_for_window(pole: np.ndarray, decay_rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency [Hz] and damping ratio of a pole lambda [rad/s] identified on
    exponentially windowed data: the true pole is lambda + r, so

        f_n = |lambda + r| / (2 pi),   zeta = -Re(lambda + r) / |lambda + r|

    (to first order zeta = zeta_windowed - r / w_n)."""
    true = np.asarray(pole) + decay_rate
    return np.abs(true) / (2 * np.pi), -true.real / np.abs(true)


@dataclass(frozen=True)
class _Cut:
    source: str
    force: np.ndarray | None
    response: np.ndarray
    decay_ratio: float


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def _double_hit(f: np.ndarray, start: int, end: int, fs: float) -> str | None:
    """Why the force ``f`` (main pulse on samples start:end) is a double hit, if it is:
    a second excursion above DOUBLE_HIT_LEVEL of the peak outside the pulse, or a second
    maximum of that prominence inside it (a rebound before the first pulse ended)."""
    peak = np.abs(f).max()
    outside = np.abs(f) >= DOUBLE_HIT_LEVEL * peak
    outside[start:end] = False
    if outside.any():
        second = int(np.flatnonzero(outside)[0])
        side = "after" if second > start else "before"
        return (
            f"double hit: a second force pulse of {np.abs(f[outside]).max() / peak:.0%} of the first, "
            f"{abs(second - start) / fs * 1e3:.1f} ms {side} it"
        )
    maxima = find_peaks(np.abs(f[start:end]), DOUBLE_HIT_LEVEL * peak)[0]
    if len(maxima) > 1:
        return (
            f"double hit: the force pulse has {len(maxima)} maxima, {(maxima[1] - maxima[0]) / fs * 1e3:.2f} "
            "ms "
            "apart (a rebound within the pulse)"
        )
    return None


def clipped_run(x: np.ndarray) -> tuple[int, int] | None:
    """(first sample, length) of the longest run of at least ``CLIP_RUN`` samples at the
    channel's maximum or minimum value, if any (a clipped channel).  Only an extreme at
    least half the largest excursion from the baseline (median) counts: a noise-free
    channel rests at its baseline for long runs."""
    best = None
    baseline = np.median(x)
    reach = np.abs(x - baseline).max()
    for extreme in (x.max(), x.min()):
        if reach == 0 or abs(extreme - baseline) < 0.5 * reach:
            continue
        at = np.concatenate([[0], (x == extreme).astype(np.int8), [0]])
        edges = np.flatnonzero(np.diff(at))
        starts, lengths = edges[0::2], edges[1::2] - edges[0::2]
        if lengths.size and lengths.max() >= CLIP_RUN and (best is None or lengths.max() > best[1]):
            best = (int(starts[np.argmax(lengths)]), int(lengths.max()))
    return best


def _clipping(hit: Hit) -> str | None:
    """Why a hit is refused for clipping, naming the channel, if it is."""
    for name, x in (("force", hit.force), ("response", hit.response)):
        run = None if x is None else clipped_run(x)
        if run:
            return (
                f"{name} clipped: {run[1]} consecutive samples at its limit {x[run[0]]:g} from "
                f"{run[0] / hit.sample_rate * 1e3:.1f} ms (overload: the peak is cut off, H1 would be "
                "wrong); "
                "repeat the hit softer or raise the input range"
            )
    return None


def remove_hum(hit: Hit) -> tuple[Hit, str | None]:
    """Mains hum (50 or 60 Hz and harmonics up to the Nyquist frequency) on the response,
    removed: the harmonics standing ``HUM_DB`` above their neighbourhood in the spectrum
    of the record's last half (the modes have decayed there, the hum has not) are fitted
    as sinusoids there (fundamental refined within ``MAINS_DRIFT_HZ``) and, if steady
    over the tail (``HUM_STEADY``: a mode ringing near a harmonic decays), subtracted
    from the whole record.  Returns the hit and a note, or the hit unchanged and None."""
    fs, y = hit.sample_rate, hit.response
    tail = y[len(y) // 2 :] - np.median(y[len(y) // 2 :])
    n = len(tail)
    spectrum = np.abs(fft.rfft(tail * np.hanning(n)))
    f = fft.rfftfreq(n, 1 / fs)
    step = f[1]
    found = None
    for mains in MAINS_HZ:
        k = np.arange(1, int(0.5 * fs / mains))
        lines = np.rint(k * mains / step).astype(int)
        k, lines = k[(lines >= 12) & (lines + 12 < len(f))], lines[(lines >= 12) & (lines + 12 < len(f))]
        if not len(lines):
            continue
        level = spectrum[lines[:, None] + np.arange(-1, 2)].max(axis=1)
        around = np.median(spectrum[lines[:, None] + NEIGHBOURHOOD], axis=1)
        standing = (level >= 10 ** (HUM_DB / 20) * around) & (level > 0)
        if standing[:3].sum() >= 1 and (found is None or standing.sum() > found[1].sum()):
            found = (mains, standing, k)
    if found is None:
        return hit, None
    mains, standing, k = found
    t = np.arange(len(y)) / fs
    t_tail = t[len(y) // 2 :]

    def fitted(f0, part=slice(None)):
        harmonics = k[standing] * f0
        phase = 2 * np.pi * t_tail[part, None] * harmonics
        basis = np.hstack([np.cos(phase), np.sin(phase)])
        c = np.linalg.lstsq(basis, tail[part], rcond=None)[0]
        return float(np.sum((basis @ c - tail[part]) ** 2)), harmonics, c

    drift = np.linspace(mains - MAINS_DRIFT_HZ, mains + MAINS_DRIFT_HZ, 41)
    f0 = drift[int(np.argmin([fitted(x)[0] for x in drift]))]
    _, harmonics, c = fitted(f0)
    amplitude = [
        np.hypot(*fitted(f0, part)[2].reshape(2, -1)).sum()
        for part in (slice(None, n // 2), slice(n // 2, None))
    ]
    if not HUM_STEADY[0] <= amplitude[1] / amplitude[0] <= HUM_STEADY[1]:
        return hit, None  # decaying over the tail: a mode's ring-down near a harmonic, not hum
    hum = (
        np.hstack([np.cos(2 * np.pi * t[:, None] * harmonics), np.sin(2 * np.pi * t[:, None] * harmonics)])
        @ c
    )
    return (
        replace(hit, response=y - hum),
        f"{hit.source}: mains hum at {f0:.2f} Hz removed ({len(harmonics)} harmonic(s) up to "
        f"{harmonics.max():.0f} Hz, fitted on the record's last half)",
    )


def _cut(hit: Hit) -> _Cut | Rejection:
    """Cut a hit at its onset, window the force, measure the response's decay."""
    fs = hit.sample_rate
    clipping = _clipping(hit)
    if clipping:
        return Rejection(hit.source, clipping)
    pre = round(PRE_TRIGGER_S * fs)
    level_n = max(int(LEVEL_WINDOW_S * fs), 8)
    if hit.force is None:
        onset = int(np.argmax(np.abs(hit.response) >= PULSE_LEVEL * np.abs(hit.response).max()))
        force = None
    else:
        f = hit.force - np.median(hit.force[len(hit.force) // 2 :])
        peak = int(np.argmax(np.abs(f)))
        noise = 1.4826 * np.median(np.abs(f[len(f) // 2 :]))
        if f[peak] == 0:
            return Rejection(hit.source, "no hit: the force channel is flat (cable unplugged?)")
        if abs(f[peak]) < MIN_HIT_SNR * noise:
            return Rejection(
                hit.source,
                f"no hit: force peak only {abs(f[peak]) / noise:.1f} times the noise (need {MIN_HIT_SNR:g})",
            )
        above = np.abs(f) >= PULSE_LEVEL * abs(f[peak])
        onset = peak - int(np.argmin(above[peak::-1])) + 1 if not above[: peak + 1].all() else 0
        end = peak + int(np.argmin(above[peak:])) if not above[peak:].all() else len(f)
        reason = _double_hit(f, onset, end, fs)
        if reason:
            return Rejection(hit.source, reason)
        window = np.zeros_like(f)
        window[max(onset - pre, 0) : end + (end - onset) + pre] = (
            1.0  # the pulse, one pulse width and margins
        )
        force = (f * window)[max(onset - pre, 0) :]
    first = max(onset - pre, 0)
    response = hit.response[first:] - np.median(hit.response)
    head = _rms(response[:level_n])
    if head == 0:
        return Rejection(
            hit.source, "no response: the response channel is flat after the hit (sensor unplugged?)"
        )
    return _Cut(hit.source, force, response, _rms(response[-level_n:]) / head)


def _notch(
    force_spectrum: np.ndarray, frequency_hz: np.ndarray, lines: np.ndarray
) -> tuple[float, float] | None:
    """Deepest notch (depth [dB], frequency [Hz]) of a force spectrum in the band, if any
    is deeper than NOTCH_DB.  Only lines within FORCE_DROP_DB of the level at the band's
    low edge count: there a single pulse's spectrum is smooth, beyond it the pulse's
    own zeros (at 1.5, 2.5, ... / pulse width) are the hammer's limit, not a double hit."""
    level = 20 * np.log10(np.abs(force_spectrum[lines]) + 1e-300)
    level = level[: np.argmax(np.append(level < level[0] - FORCE_DROP_DB, True))]
    if len(level) < 3:
        return None
    dips, depth = find_peaks(-level, NOTCH_DB)
    if not dips.size:
        return None
    i = int(np.argmax(depth))
    return float(depth[i]), float(frequency_hz[lines][dips[i]])


def default_band(hits: list[Hit]) -> tuple[float, float]:
    """[SUSPENSION_HZ, where the mean force spectrum has dropped FORCE_DROP_DB] [Hz],
    at most 0.4 x the sample rate; response-only: [SUSPENSION_HZ, 2 kHz]."""
    fs = hits[0].sample_rate
    top = 0.4 * fs
    forced = [h for h in hits if h.force is not None]
    if not forced:
        return SUSPENSION_HZ, min(2000.0, top)
    n = fft.next_fast_len(max(len(h.force) for h in forced), real=True)
    f = fft.rfftfreq(n, 1 / fs)
    power = np.mean([np.abs(fft.rfft(h.force - np.median(h.force), n)) ** 2 for h in forced], axis=0)
    low = power[np.searchsorted(f, SUSPENSION_HZ)]
    dropped = np.flatnonzero((f > SUSPENSION_HZ) & (power < low * 10 ** (-FORCE_DROP_DB / 10)))
    return SUSPENSION_HZ, float(min(f[dropped[0]] if dropped.size else top, top))


def _all_rejected(rejected: list[Rejection]) -> MeasurementError:
    return MeasurementError(
        f"every hit was rejected ({'; '.join(f'{r.source}: {r.reason}' for r in rejected)}); "
        "repeat the test with single clean hits"
    )


def average_hits(hits: list[Hit], band_hz: tuple[float, float]) -> AveragedFRF:
    """Cut, check, window and average the hits of one configuration (H1)."""
    fs = hits[0].sample_rate
    cuts, rejected, notes = [], [], []
    for hit in hits:
        hit, hum = remove_hum(hit)
        notes += [hum] if hum else []
        cut = _cut(hit)
        (rejected if isinstance(cut, Rejection) else cuts).append(cut)
    n = fft.next_fast_len(max((len(c.response) for c in cuts), default=1), real=True)
    frequency = fft.rfftfreq(n, 1 / fs)
    lines = np.flatnonzero((frequency >= band_hz[0]) & (frequency <= band_hz[1]))
    kept = []
    for c in cuts:
        notch = None if c.force is None else _notch(fft.rfft(c.force, n), frequency, lines)
        if notch is None:
            kept.append(c)
        else:
            rejected.append(
                Rejection(
                    c.source,
                    f"double hit: force spectrum has a {notch[0]:.0f} dB notch at "
                    f"{notch[1]:.1f} Hz within the band",
                )
            )
    if not kept:
        raise _all_rejected(rejected)
    rate = 0.0
    worst = max(kept, key=lambda c: c.decay_ratio)
    if worst.decay_ratio > DECAYED:
        rate = np.log(worst.decay_ratio / WINDOW_TARGET) * fs / len(worst.response)
        notes.append(
            f"{worst.source}: response at {worst.decay_ratio:.1%} of its start level at the record's end "
            f"(not decayed): exponential window exp(-{rate:.3g} t) on every hit, damping corrected for it"
        )
    window = [np.exp(-rate * np.arange(len(c.response)) / fs) for c in kept]
    y = np.array([fft.rfft(c.response * w, n) for c, w in zip(kept, window, strict=True)])
    sources = tuple(c.source for c in kept)
    if kept[0].force is None:
        notes.append(
            "no force channel: modes fitted to the response spectrum as if the hammer's force were flat "
            "over the band (no FRF and no coherence; damping from the free decay)"
        )
        syy = np.sum(np.abs(y) ** 2, axis=0)
        return AveragedFRF(
            frequency,
            np.mean(y, axis=0),
            np.full(len(frequency), np.nan),
            y,
            np.abs(y) ** 2 / syy,
            sources,
            tuple(rejected),
            rate,
            False,
            hits[0].quantity,
            tuple(notes),
        )
    x = np.array([fft.rfft(c.force * w[: len(c.force)], n) for c, w in zip(kept, window, strict=True)])
    sxx = np.sum(np.abs(x) ** 2, axis=0)
    sxy = np.sum(y * x.conj(), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        syy = np.sum(np.abs(y) ** 2, axis=0)
        coherence = np.abs(sxy) ** 2 / (sxx * syy) if len(x) > 1 else np.full(len(frequency), np.nan)
        return AveragedFRF(
            frequency,
            sxy / sxx,
            coherence,
            y / x,
            np.abs(x) ** 2 / sxx,
            sources,
            tuple(rejected),
            rate,
            True,
            hits[0].quantity,
            tuple(notes),
        )


def from_measured(frfs: list[MeasuredFRF]) -> AveragedFRF:
    """FRF records averaged by the acquisition: used as they are (several: their mean,
    each record then counting as one hit)."""
    f = frfs[0].frequency_hz
    for r in frfs[1:]:
        if len(r.frequency_hz) != len(f) or not np.allclose(r.frequency_hz, f, rtol=1e-9, atol=1e-9):
            raise MeasurementError(
                f"{r.source}: FRF lines differ from {frfs[0].source}'s; export every FRF on the "
                "same frequency lines"
            )
    h = np.array([r.frf for r in frfs])
    k = len(frfs)
    return AveragedFRF(
        f,
        h.mean(axis=0),
        np.full(len(f), np.nan),
        h,
        np.full(h.shape, 1 / k),
        tuple(r.source for r in frfs),
        (),
        0.0,
        True,
        frfs[0].quantity,
        ("FRF records as averaged by the acquisition: no coherence, no windows applied",),
    )
