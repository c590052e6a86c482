"""The lab's chain on recordings with real-world quirks: recordings -> peaks -> fit ->
diagnose -> report, one run per variant of a corpus made by the tap simulator.

The plate is the tap test's (``studies.tap_test``: the paper's coated plate, Table 1
properties, a 3 g accelerometer in the spec, three configurations, five hits each, hit 3
a double hit).  Each variant adds what real exports and real setups add
(``identify.recordings.tap_quirks``): a time column printed with 7 digits, integer ADC counts on an
offset without a time column, mains hum, the plate bouncing on its suspension and the
sensor cable rattling, a clipped hit, a noise floor 30 dB under the response.  All of
those are *honest* data (the true properties must come out within 3 reported std, with
an honest status); "all_clipped" cannot be used and must be refused with the reason, and
"sensor_not_in_spec" leaves the accelerometer's 3 g out of the spec, a misfit that
``diagnose`` must explain.  A last run measures ``peaks`` on a real-like plate with 30+
modes in band (``tap_quirks.real_like_plate``).

    python -m studies.recording_chain [--out DIR]
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from fem.errors import MeasurementError
from fem.solver.attachments import PointMass
from identify.diagnosis.diagnose import diagnose
from identify.fitting.driver import fit
from identify.measurements import parse_measurements
from identify.recordings.peaks import extract_peaks
from identify.recordings.readers import Hit
from identify.recordings.tap_quirks import (
    clipped,
    real_like_plate,
    with_bounce,
    with_hum,
    with_rattle,
    with_snr,
    write_counts_csv,
    write_rounded_csv,
)
from identify.recordings.tap_simulation import Session, TapOptions, write_csv

from .common import parse_args, report_folder, start_model, true_model, write_text
from .tap_test import MODES, SENSOR, SENSOR_MASS, modal_data

RATE = 48000.0


def _clean(hit: Hit, rng: np.random.Generator, index: int) -> Hit:
    return hit


@dataclass(frozen=True)
class Variant:
    """A way the recordings of every configuration come out: ``quirk`` applied to each
    hit (its index in the session), written by ``writer`` ("full", "rounded" or
    "counts"); ``honest``: the data are trustworthy (the layers must be found);
    ``sensor_in_spec``: the spec knows the accelerometer."""

    name: str
    description: str
    quirk: Callable[[Hit, np.random.Generator, int], Hit] = _clean
    writer: str = "full"
    honest: bool = True
    sensor_in_spec: bool = True


VARIANTS = (
    Variant("clean", "the simulator's exact hits, full-precision CSV"),
    Variant("rounded_time", "time column printed with %.7g (DAQ export)", writer="rounded"),
    Variant("adc_counts", "24-bit integer counts on a 1200-count offset, no time column", writer="counts"),
    Variant(
        "hum",
        "50 Hz mains hum and 4 harmonics at 3 % of the response's peak",
        lambda h, rng, i: with_hum(h, 50.0, 3e-2),
    ),
    Variant(
        "bounce_rattle",
        "suspension bounce at 6 Hz and cable rattle below 15 Hz",
        lambda h, rng, i: with_rattle(with_bounce(h), rng),
    ),
    Variant(
        "one_clipped",
        "hit 1's force clipped at 70 % of its peak (rejected, the others used)",
        lambda h, rng, i: clipped(h, "force") if i == 0 else h,
    ),
    Variant(
        "noisy",
        "response noise floor 30 dB under its first 0.1 s (lab range 5-40 dB)",
        lambda h, rng, i: with_snr(h, 30.0, rng),
    ),
    Variant(
        "very_noisy",
        "noise floor 20 dB under the response: close pairs merge into one peak each",
        lambda h, rng, i: with_snr(h, 20.0, rng),
    ),
    Variant(
        "all_clipped",
        "every hit's response clipped: nothing usable",
        lambda h, rng, i: clipped(h, "response"),
        honest=False,
    ),
    Variant(
        "sensor_not_in_spec",
        "the 3 g accelerometer left out of the spec: a misfit to diagnose",
        honest=False,
        sensor_in_spec=False,
    ),
)


@dataclass(frozen=True)
class Outcome:
    """One variant's run: the peaks' status ("ok" or the refusal), the fit's status,
    (identified - true) / std per parameter, the effects diagnose selected."""

    variant: str
    honest: bool
    peaks: str
    n_peaks: int = 0
    rejected: int = 0
    status: str | None = None
    z: dict = field(default_factory=dict)
    selected: tuple[str, ...] = ()
    seconds: float = 0.0

    @property
    def max_z(self) -> float | None:
        return max(abs(v) for v in self.z.values()) if self.z else None


def _write(hit: Hit, path, writer: str) -> None:
    {"full": write_csv, "rounded": write_rounded_csv, "counts": write_counts_csv}[writer](hit, path)


def run_variant(variant: Variant, folder, seed: int = 1, run_diagnosis: bool = True) -> Outcome:
    """Recordings -> peaks -> fit (-> diagnose when the fit is not consistent with the
    scatter) for one variant; files and a text report in ``folder``."""
    start_clock = time.perf_counter()
    sensor = [PointMass(SENSOR_MASS, *SENSOR, "accelerometer")]
    truth = true_model().with_attachments(sensor).with_options(modes=MODES + 2)
    lists, rejected, lines = [], 0, [f"{variant.name}: {variant.description}", ""]
    for k, c in enumerate(truth.specimen.configurations):
        session = Session(modal_data(truth, c.name, seed + k), n_hits=5, seed=seed + k, double_hits=(2,))
        rng = np.random.default_rng(seed + 100 + k)
        paths = []
        for i, hit in enumerate(session.hits()):
            paths.append(folder / "recordings" / c.name / f"hit{i + 1}.csv")
            _write(variant.quirk(hit, rng, i), paths[-1], variant.writer)
        try:
            peaks = extract_peaks(paths, c.name, sample_rate=RATE if variant.writer == "counts" else None)
        except MeasurementError as error:
            lines.append(f"peaks of {c.name} refused: {error}")
            write_text(folder / "report.txt", "\n".join(lines) + "\n")
            return Outcome(
                variant.name, variant.honest, f"refused: {error}", seconds=time.perf_counter() - start_clock
            )
        lines += [peaks.report(), ""]
        lists.append(peaks.to_frame()[["configuration", "frequency_hz", "std_hz", "damping_ratio"]])
        rejected += len(peaks.rejected)
    peak_list = pd.concat(lists, ignore_index=True)
    write_text(folder / "peaks.csv", peak_list.to_csv(index=False))
    start = start_model().with_attachments(sensor if variant.sensor_in_spec else [])
    measurements = parse_measurements(peak_list, start, "peaks.csv")
    result = fit(start, measurements)
    z = {
        p.name: float((v - truth.value(p)) / s)
        for p, v, s in zip(result.parameters, result.values, result.uncertainty.std, strict=True)
    }
    lines += [result.report(), "(identified - true) / std:"] + [f"  {n:24s} {v:+.2f}" for n, v in z.items()]
    selected: tuple[str, ...] = ()
    if run_diagnosis and result.status.value != "converged":
        diagnosis = diagnose(start, measurements, workers=1)
        selected = tuple(c.kind for c in diagnosis.selected)
        lines += ["", diagnosis.report()]
    write_text(folder / "report.txt", "\n".join(lines) + "\n")
    return Outcome(
        variant.name,
        variant.honest,
        "ok",
        len(peak_list),
        rejected,
        result.status.value,
        z,
        selected,
        time.perf_counter() - start_clock,
    )


@dataclass(frozen=True)
class DensePlate:
    """``peaks`` on a real-like plate: modes in band, modes found within 3 std, seconds."""

    in_band: int
    found: int
    seconds: float


def dense_plate(seed: int = 0) -> DensePlate:
    """5 hits x 2 s at 48 kHz on ``real_like_plate`` (36 modes in 60-1900 Hz and more
    above; 0.35 ms pulses excite up to about 3 kHz): how many in-band modes of
    detectable strength come out within 3 std of the truth, and how long it takes."""
    modes = real_like_plate(seed=seed)
    hits = Session(modes, n_hits=5, seed=seed, options=TapOptions(pulse_ms=0.35, noise_rel=3e-5)).hits()
    clock = time.perf_counter()
    result = extract_peaks(hits)
    seconds = time.perf_counter() - clock
    f, std = result.table["frequency_hz"].to_numpy(), result.table["std_hz"].to_numpy()
    truth = modes.frequencies_hz[
        (modes.frequencies_hz > result.band_hz[0]) & (modes.frequencies_hz < result.band_hz[1])
    ]
    found = sum(bool(np.any(np.abs(f - x) < 3 * np.maximum(std, 1e-9))) for x in truth)
    return DensePlate(len(truth), found, seconds)


def run(
    out=None, variants=VARIANTS, seed: int = 1, run_diagnosis: bool = True, with_dense_plate: bool = True
) -> tuple[list[Outcome], DensePlate | None]:
    folder = report_folder("recording_chain", out)
    outcomes = [run_variant(v, folder / v.name, seed, run_diagnosis) for v in variants]
    dense = dense_plate() if with_dense_plate else None
    lines = [
        "Recording chain: recordings -> peaks -> fit -> diagnose, per variant of the corpus",
        "",
        f"{'variant':20s} {'honest':>6s} {'peaks':>5s} {'rejected':>8s} {'fit status':>14s} {'max |z|':>8s} "
        f"{'diagnosed':>12s} {'s':>6s}",
    ]
    for o in outcomes:
        z = f"{o.max_z:.2f}" if o.max_z is not None else "-"
        status = o.status or o.peaks.split(":")[0]
        lines.append(
            f"{o.variant:20s} {str(o.honest):>6s} {o.n_peaks:>5d} {o.rejected:>8d} {status:>14s} {z:>8s} "
            f"{','.join(o.selected) or '-':>12s} {o.seconds:>6.1f}"
        )
    if dense is not None:
        lines += [
            "",
            f"real-like plate: {dense.found} of {dense.in_band} modes in band found within 3 std "
            f"in {dense.seconds:.1f} s (5 hits x 2 s at 48 kHz)",
        ]
    write_text(folder / "summary.txt", "\n".join(lines) + "\n")
    write_text(
        folder / "summary.json",
        json.dumps(
            {
                "variants": [
                    {
                        "variant": o.variant,
                        "honest": o.honest,
                        "peaks": o.peaks,
                        "n_peaks": o.n_peaks,
                        "rejected": o.rejected,
                        "status": o.status,
                        "max_abs_z": o.max_z,
                        "z": o.z,
                        "selected": list(o.selected),
                    }
                    for o in outcomes
                ],
                "dense_plate": None if dense is None else {"in_band": dense.in_band, "found": dense.found},
            },
            indent=2,
        )
        + "\n",
    )
    return outcomes, dense


if __name__ == "__main__":
    run(parse_args("recording_chain", __doc__).out)
    print("report written to reports/recording_chain (or --out)")
