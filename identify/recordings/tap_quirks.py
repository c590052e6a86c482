"""Real-world quirks of impact recordings, added to simulated hits (seeded), and a
real-like plate with 30+ modes in band.

Real exports differ from the simulator's exact hits: the time column is printed with
few digits, the channels are integer ADC counts on an offset, mains hum rides on the
response, a hard hit clips the force or the sensor, the plate bounces on its
suspension and the sensor cable rattles at low frequency.  Each quirk here is a
function of a :class:`~identify.recordings.readers.Hit` (or of its export) so a corpus can
combine them; :func:`real_like_plate` gives modal data shaped like a real plate's
(constant modal density, damping 0.3-1.1 %, modal constants of both signs over two
decades, a few modes with a node near the sensor).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from fem.io import write_text

from .readers import Hit
from .tap_simulation import Modes


def real_like_plate(
    n_modes: int = 36, band_hz: tuple[float, float] = (60.0, 1900.0), seed: int = 0, above: int = 40
) -> Modes:
    """``n_modes`` modes spread over ``band_hz`` [Hz] (a plate's modal density is
    constant in frequency: evenly spaced with 30 % random shifts) and ``above`` more up
    to 12 kHz, damping ratios log-uniform in 0.3-1.1 %, modal constants log-uniform over
    two decades with random signs (every 9th mode 30 dB lower: a node near the sensor)."""
    rng = np.random.default_rng(seed)
    step = (band_hz[1] - band_hz[0]) / n_modes
    f = band_hz[0] + step * (np.arange(n_modes) + 0.5 + 0.3 * rng.uniform(-1, 1, n_modes))
    f = np.concatenate([f, np.sort(rng.uniform(band_hz[1] * 1.05, 12000.0, above))])
    zeta = np.exp(rng.uniform(np.log(0.003), np.log(0.011), len(f)))
    residue = np.exp(rng.uniform(np.log(0.1), np.log(10.0), len(f))) * rng.choice([-1.0, 1.0], len(f))
    residue[4:n_modes:9] *= 10 ** (-30 / 20)
    return Modes(f, zeta, residue)


def with_snr(hit: Hit, snr_db: float, rng: np.random.Generator) -> Hit:
    """White noise on the response at ``snr_db`` below its RMS over the first 0.1 s [dB]."""
    head = hit.response[: max(int(0.1 * hit.sample_rate), 8)]
    level = np.sqrt(np.mean(head**2)) * 10 ** (-snr_db / 20)
    return replace(hit, response=hit.response + level * rng.standard_normal(len(hit.response)))


def with_hum(hit: Hit, mains_hz: float = 50.0, level_rel: float = 3e-3, harmonics: int = 5) -> Hit:
    """Mains hum on the response: ``mains_hz`` and its harmonics, the first at
    ``level_rel`` of the response's peak, each harmonic half the previous [-]."""
    t = np.arange(len(hit.response)) / hit.sample_rate
    peak = np.abs(hit.response).max()
    hum = sum(
        level_rel * peak * 0.5**k * np.sin(2 * np.pi * (k + 1) * mains_hz * t + k) for k in range(harmonics)
    )
    return replace(hit, response=hit.response + hum)


def with_bounce(
    hit: Hit, frequency_hz: float = 6.0, level_rel: float = 0.05, damping_ratio: float = 0.05
) -> Hit:
    """The plate bouncing on its suspension: a slow damped swing from the hit on."""
    t = np.arange(len(hit.response)) / hit.sample_rate
    w = 2 * np.pi * frequency_hz
    swing = np.exp(-damping_ratio * w * t) * np.sin(w * t)
    return replace(hit, response=hit.response + level_rel * np.abs(hit.response).max() * swing)


def with_rattle(hit: Hit, rng: np.random.Generator, level_rel: float = 0.02, below_hz: float = 15.0) -> Hit:
    """A sensor cable's low-frequency rattle: noise low-passed below ``below_hz`` [Hz]."""
    from scipy import signal

    sos = signal.butter(4, below_hz, fs=hit.sample_rate, output="sos")
    rattle = signal.sosfilt(sos, rng.standard_normal(len(hit.response)))
    rattle *= level_rel * np.abs(hit.response).max() / (np.abs(rattle).max() + 1e-300)
    return replace(hit, response=hit.response + rattle)


def clipped(hit: Hit, channel: str = "force", at_rel: float = 0.7) -> Hit:
    """The ``channel`` ("force" or "response") saturated at ``at_rel`` of its peak."""
    x = getattr(hit, channel)
    limit = at_rel * np.abs(x).max()
    return replace(hit, **{channel: np.clip(x, -limit, limit)})


def write_rounded_csv(hit: Hit, path: str | Path, digits: int = 7) -> None:
    """``time_s,force,<quantity>`` with every value printed to ``digits`` significant
    digits (``%.7g``: what DAQ exports and ``numpy.savetxt`` write)."""
    frame = pd.DataFrame(
        {
            "time_s": np.arange(len(hit.response)) / hit.sample_rate,
            "force": hit.force,
            hit.quantity: hit.response,
        }
    )
    write_text(path, frame.to_csv(index=False, float_format=f"%.{digits}g"))


def write_counts_csv(
    hit: Hit, path: str | Path, bits: int = 24, offset_counts: int = 1200, headroom: float = 1.5
) -> None:
    """``force,<quantity>`` as integer ADC counts of a ``bits``-bit converter on an
    ``offset_counts`` DC offset, full scale ``headroom`` x each channel's peak; no time
    column (read with ``sample_rate``)."""
    full = 2 ** (bits - 1) - 1
    columns = {}
    for name, x in (("force", hit.force), (hit.quantity, hit.response)):
        columns[name] = np.rint(x / (headroom * np.abs(x).max()) * full).astype(np.int64) + offset_counts
    write_text(path, pd.DataFrame(columns).to_csv(index=False))
