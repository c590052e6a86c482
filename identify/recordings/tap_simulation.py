"""Simulated impact tests of a freely suspended plate, from modal data alone.

The structure is a sum of modes given by natural frequencies f_r [Hz], damping ratios
zeta_r and modal constants A_r (residues phi_r(excitation) * phi_r(sensor), any sign) of
the accelerance

    H(s) = sum_r A_r s^2 / (s^2 + 2 zeta_r w_r s + w_r^2),   w_r = 2 pi f_r.

The hammer force is a half-sine pulse; the force between samples is taken as the
straight line through them (first-order hold), and each mode's response to that input
is computed exactly by its first-order-hold discretisation (``cont2discrete``) and a
recursive filter, so the simulated recordings are exact to rounding before the noise
is added.  Writers put hits into CSV, WAV (float32) and UFF58 files for the readers.
A roving-hammer test (:func:`roving_hits`) is such hits at each point of a grid, the
modal constants taken from mode-shape functions where each hit lands.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import signal

from fem.io import atomic_path, write_text

from .readers import UFF_FRF, UFF_TIME, Hit


@dataclass(frozen=True)
class Modes:
    """Modal data: natural frequencies [Hz], damping ratios [-], accelerance modal
    constants [response unit per force unit]."""

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    residues: np.ndarray

    def __post_init__(self):
        for name in ("frequencies_hz", "damping_ratios", "residues"):
            object.__setattr__(self, name, np.atleast_1d(np.asarray(getattr(self, name), dtype=float)))
        if not len(self.frequencies_hz) == len(self.damping_ratios) == len(self.residues):
            raise ValueError("frequencies_hz, damping_ratios and residues need one value per mode")

    def accelerance(self, frequency_hz) -> np.ndarray:
        """H(i w) at ``frequency_hz`` [Hz] (complex)."""
        s = 2j * np.pi * np.asarray(frequency_hz, dtype=float)[..., None]
        w = 2 * np.pi * self.frequencies_hz
        return (self.residues * s**2 / (s**2 + 2 * self.damping_ratios * w * s + w**2)).sum(axis=-1)


@dataclass(frozen=True)
class TapOptions:
    """How one hit is recorded.

    pulse_ms: half-sine width; amplitude: its peak (force units); jitter_rel: relative
    std of each mode's frequency from hit to hit; noise_rel: std of white noise on each
    channel relative to that channel's peak; pretrigger_s: time before the hit;
    double_hit_ms: a second pulse this long after the first (None: none), of
    ``double_hit_ratio`` times the amplitude; duration_s: record length (a short one is
    "cut short": the response has not decayed).
    """

    sample_rate: float = 48000.0
    duration_s: float = 2.0
    pulse_ms: float = 0.7
    amplitude: float = 100.0
    jitter_rel: float = 3e-4
    noise_rel: float = 1e-4
    pretrigger_s: float = 0.002
    double_hit_ms: float | None = None
    double_hit_ratio: float = 0.5


def hammer_force(options: TapOptions) -> np.ndarray:
    """The sampled force: half-sine pulse(s) after the pre-trigger."""
    t = np.arange(round(options.duration_s * options.sample_rate)) / options.sample_rate
    width = options.pulse_ms * 1e-3

    def pulse(start):
        u = (t - start) / width
        return np.where((u > 0) & (u < 1), np.sin(np.pi * np.clip(u, 0, 1)), 0.0)

    force = pulse(options.pretrigger_s)
    if options.double_hit_ms is not None:
        force = force + options.double_hit_ratio * pulse(options.pretrigger_s + options.double_hit_ms * 1e-3)
    return options.amplitude * force


def exact_response(modes: Modes, force: np.ndarray, sample_rate: float) -> np.ndarray:
    """Acceleration of the modal model under ``force`` (linear between samples), exact."""
    response = np.zeros_like(force)
    w = 2 * np.pi * modes.frequencies_hz
    for a, z, wr in zip(modes.residues, modes.damping_ratios, w):
        b, den, _ = signal.cont2discrete(
            ([a, 0.0, 0.0], [1.0, 2 * z * wr, wr**2]), 1 / sample_rate, method="foh"
        )
        response += signal.lfilter(np.ravel(b), den, force)
    return response


def simulate_hit(
    modes: Modes, rng: np.random.Generator, options: TapOptions = TapOptions(), source: str = "<simulated>"
) -> Hit:
    """One recorded hit: the modes jittered by ``options.jitter_rel``, noise on both channels."""
    jittered = Modes(
        modes.frequencies_hz * (1 + options.jitter_rel * rng.standard_normal(len(modes.frequencies_hz))),
        modes.damping_ratios,
        modes.residues,
    )
    force = hammer_force(options)
    response = exact_response(jittered, force, options.sample_rate)
    noisy = [x + options.noise_rel * np.abs(x).max() * rng.standard_normal(len(x)) for x in (force, response)]
    return Hit(source, options.sample_rate, noisy[1], noisy[0], "acceleration")


@dataclass(frozen=True)
class Session:
    """A series of hits on one configuration: ``n_hits`` with amplitudes varying by
    ``amplitude_spread`` (std of the log), pre-triggers of 0.5-1.5 x the options'; the
    hits numbered in ``double_hits`` (0-based) get a second pulse ``double_hit_ms``
    later, those in ``cut_short`` (index -> record length [s]) a short record."""

    modes: Modes
    n_hits: int = 5
    seed: int = 0
    options: TapOptions = TapOptions()
    amplitude_spread: float = 0.3
    double_hits: tuple[int, ...] = ()
    double_hit_ms: float = 3.0
    cut_short: dict[int, float] = field(default_factory=dict)

    def hits(self) -> list[Hit]:
        rng = np.random.default_rng(self.seed)
        out = []
        for i in range(self.n_hits):
            o = replace(
                varied(self.options, rng, self.amplitude_spread),
                double_hit_ms=self.double_hit_ms if i in self.double_hits else None,
                duration_s=self.cut_short.get(i, self.options.duration_s),
            )
            out.append(simulate_hit(self.modes, rng, o, source=f"hit{i + 1}"))
        return out


def varied(options: TapOptions, rng: np.random.Generator, amplitude_spread: float) -> TapOptions:
    """One hit's options: the amplitude times exp(``amplitude_spread`` x a standard normal
    draw), the pre-trigger 0.5-1.5 x the options' (a hand-held hammer's hits differ)."""
    return replace(
        options,
        amplitude=options.amplitude * np.exp(amplitude_spread * rng.standard_normal()),
        pretrigger_s=options.pretrigger_s * rng.uniform(0.5, 1.5),
    )


@dataclass(frozen=True)
class RovingSetup:
    """How a roving-hammer test is run: the sensor fixed at ``sensor_mm`` (x, y) [mm],
    ``hits`` hits at each point, each landing off its point by a normal scatter of
    ``position_std_mm`` [mm] per axis; every hit recorded with ``options``, its amplitude
    and pre-trigger varied by :func:`varied` (``amplitude_spread``: std of the log
    amplitude [-]); ``seed`` seeds the random draws."""

    sensor_mm: tuple[float, float]
    hits: int = 3
    position_std_mm: float = 1.0
    seed: int = 0
    options: TapOptions = TapOptions()
    amplitude_spread: float = 0.3


def roving_hits(
    frequencies_hz, damping_ratios, shapes, points: pd.DataFrame, setup: RovingSetup
) -> dict[str, list[Hit]]:
    """A roving-hammer test run as ``setup`` says: its hits at each point of ``points``
    (columns point, x_mm, y_mm).  ``shapes``: one callable shape(x_mm, y_mm) per mode,
    mass-normalised, so that a hit at (x, y) has the modal constants shape_r(x, y)
    shape_r(sensor) (response unit per force unit).  Each hit's modal constants are the
    shapes' values where it landed; otherwise each hit is :func:`simulate_hit` with
    :func:`varied` options."""
    rng = np.random.default_rng(setup.seed)
    at_sensor = np.array([shape(*setup.sensor_mm) for shape in shapes], dtype=float)
    out = {}
    for point, x, y in points[["point", "x_mm", "y_mm"]].itertuples(index=False):
        out[str(point)] = []
        for k in range(setup.hits):
            landed = (x, y) + setup.position_std_mm * rng.standard_normal(2)
            constants = np.array([shape(*landed) for shape in shapes], dtype=float) * at_sensor
            modes = Modes(frequencies_hz, damping_ratios, constants)
            hit = simulate_hit(
                modes,
                rng,
                varied(setup.options, rng, setup.amplitude_spread),
                source=f"{point}/hit{k + 1}",
            )
            out[str(point)].append(hit)
    return out


def write_roving(hits_by_point: dict[str, list[Hit]], folder: str | Path) -> dict[str, list[Path]]:
    """Every point's hits as ``folder/<point>/hit<k>.csv`` (:func:`write_csv`): the file
    lists per point that ``identify.recordings.shapes.estimate_shapes`` reads."""
    out = {}
    for point, hits in hits_by_point.items():
        out[point] = [Path(folder) / point / f"hit{k + 1}.csv" for k in range(len(hits))]
        for hit, path in zip(hits, out[point], strict=True):
            write_csv(hit, path)
    return out


def write_csv(hit: Hit, path: str | Path, time_column: bool = True) -> None:
    """``time_s,force,<quantity>`` (``time_s`` left out when ``time_column`` is False)."""
    frame = pd.DataFrame({"force": hit.force, hit.quantity: hit.response})
    if time_column:
        frame.insert(0, "time_s", np.arange(len(hit.response)) / hit.sample_rate)
    write_text(path, frame.to_csv(index=False, float_format="%.10g"))


def write_wav(hit: Hit, path: str | Path, force_channel: bool = True) -> None:
    """Float32 WAV: channels (force, response), or the response alone."""
    from scipy.io import wavfile

    data = np.column_stack([hit.force, hit.response]) if force_channel else hit.response
    with atomic_path(path) as tmp:
        wavfile.write(tmp, round(hit.sample_rate), data.astype(np.float32))


@dataclass(frozen=True)
class _Record:
    """What a UFF58 record holds: its function type (``UFF_TIME`` or ``UFF_FRF``), the
    data type codes of its ordinate and of the ordinate's denominator (12 acceleration,
    13 force, 0 none) and its name (id1)."""

    func_type: int
    ordinate: int
    denominator: int
    name: str


_FORCE = _Record(UFF_TIME, 13, 0, "force")
_ACCELERATION = _Record(UFF_TIME, 12, 0, "acceleration")
_ACCELERANCE = _Record(UFF_FRF, 12, 13, "accelerance")


def _uff58(record: _Record, data, x_min: float, x_inc: float) -> dict:
    """One UFF58 record of ``data`` on the abscissa ``x_min + k x_inc`` [s or Hz]."""
    import pyuff

    return pyuff.prepare_58(
        binary=0,
        func_type=record.func_type,
        id1=record.name,
        rsp_node=1,
        rsp_dir=3,
        ref_node=1,
        ref_dir=3,
        data=np.asarray(data),
        x=x_min + x_inc * np.arange(len(data)),
        abscissa_spacing=1,
        abscissa_min=x_min,
        abscissa_inc=x_inc,
        abscissa_spec_data_type=17 if record.func_type == UFF_TIME else 18,
        ordinate_spec_data_type=record.ordinate,
        orddenom_spec_data_type=record.denominator,
    )


def write_uff(
    path: str | Path, hit: Hit | None = None, frf: tuple[np.ndarray, np.ndarray] | None = None
) -> None:
    """UFF58: a hit as two time records (force: data type 13, acceleration: 12), or an
    FRF ``(frequency_hz, H)`` as one record of function type 4."""
    import pyuff

    if hit is not None:
        dt = 1 / hit.sample_rate
        sets = [
            _uff58(_FORCE, hit.force, 0.0, dt),
            _uff58(_ACCELERATION, hit.response, 0.0, dt),
        ]
    else:
        f, h = frf
        sets = [_uff58(_ACCELERANCE, h, f[0], f[1] - f[0])]
    with atomic_path(path) as tmp:
        tmp.unlink()
        pyuff.UFF(str(tmp)).write_sets(sets, mode="overwrite")
