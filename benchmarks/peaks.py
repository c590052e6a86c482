"""Measurement front-end benchmark: ``extract_peaks`` on 5 recorded hits of 2 s at
48 kHz (CSV files, as a lab exports them), target < 5 s on the 2-core reference
machine; ``identify-layers peaks`` on a real-like plate (30+ modes in band, time column
printed with 7 digits) against ``identify-layers predict`` on the bundled example, as
whole processes measured in the same run (targets: <= 5 s and <= 3x predict); then the
accuracy and the calibration of std_hz over simulated sessions.

The session is the test plate of ``tests/identify/recordings/test_peaks.py``: modes of the
paper's coated steel plate, a suspension mode, a node at the sensor, a weak mode, a
close pair; hit 3 is a double hit, hit 5 is cut short at 0.4 s.
"""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from identify.examples import COATED_PLATE
from identify.recordings.peaks import extract_peaks
from identify.recordings.tap_quirks import real_like_plate, write_rounded_csv
from identify.recordings.tap_simulation import Modes, Session, TapOptions, write_csv

TARGET_S = 5.0
#: ``peaks`` on the real-like plate at most this many times ``predict`` (same run).
TARGET_VS_PREDICT = 3.0
PLATE = Modes(
    [8.0, 129.2, 191.6, 238.8, 275.0, 337.11, 337.14, 383.0, 440.0, 560.0, 590.0],
    [0.03, 0.006, 0.005, 0.004, 0.005, 0.004, 0.004, 0.005, 0.011, 0.005, 0.003],
    [0.05, 1.0, -0.8, 0.6, 1e-4, 0.5, 0.4, 1.2, -0.7, 0.015, 0.9],
)
SEPARATED = [1, 2, 3, 7, 8, 10]


def timed_from_files() -> tuple[float, float]:
    """Wall time of extract_peaks on 5 CSV hits: first call in this process (imports
    included) and the best of three after."""
    hits = Session(PLATE, n_hits=5, seed=0, double_hits=(2,), cut_short={4: 0.4}).hits()
    with tempfile.TemporaryDirectory() as folder:
        paths = [Path(folder) / f"{h.source}.csv" for h in hits]
        for hit, path in zip(hits, paths, strict=True):
            write_csv(hit, path)
        start = time.perf_counter()
        extract_peaks(paths)
        cold = time.perf_counter() - start
        warm = []
        for _ in range(3):
            start = time.perf_counter()
            extract_peaks(paths)
            warm.append(time.perf_counter() - start)
    return cold, min(warm)


def _command(*args) -> list[str]:
    """The ``identify-layers`` command of this environment with ``args``."""
    return [str(Path(sys.executable).with_name("identify-layers")), *map(str, args)]


def _wall(command: list[str]) -> float:
    """Wall time [s] of one run of ``command`` as a process (start-up included)."""
    start = time.perf_counter()
    subprocess.run(
        command,
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    return time.perf_counter() - start


def real_like_vs_predict(repeat: int = 3) -> tuple[int, int, float, float]:
    """Modes in band, peaks found, and the median wall times [s] of ``identify-layers
    peaks`` on 5 real-like hits (rounded time column) and of ``identify-layers predict``
    on the bundled example, run in turn (A B A B ...) so both see the same load."""
    modes = real_like_plate()
    hits = Session(modes, n_hits=5, seed=1, options=TapOptions(pulse_ms=0.35, noise_rel=3e-5)).hits()
    with tempfile.TemporaryDirectory() as folder:
        paths = [Path(folder) / f"{h.source}.csv" for h in hits]
        for hit, path in zip(hits, paths, strict=True):
            write_rounded_csv(hit, path)
        result = extract_peaks(paths)
        peaks, predict = [], []
        for _ in range(repeat):
            peaks.append(_wall(_command("peaks", *paths)))
            predict.append(_wall(_command("predict", COATED_PLATE)))
    band = result.band_hz
    in_band = int(np.sum((modes.frequencies_hz > band[0]) & (modes.frequencies_hz < band[1])))
    return in_band, len(result), float(np.median(peaks)), float(np.median(predict))


def monte_carlo(sessions: int) -> dict:
    """Clean 5-hit sessions: frequency error, std_hz calibration, damping error."""
    truth = PLATE.frequencies_hz[SEPARATED]
    zeta = PLATE.damping_ratios[SEPARATED]
    f, std, damping = [], [], []
    for seed in range(sessions):
        table = extract_peaks(Session(PLATE, n_hits=5, seed=2000 + seed).hits()).table
        rows = [int(np.argmin(np.abs(table["frequency_hz"].to_numpy() - x))) for x in truth]
        f.append(table["frequency_hz"].to_numpy()[rows])
        std.append(table["std_hz"].to_numpy()[rows])
        damping.append(table["damping_ratio"].to_numpy()[rows])
    f, std, damping = map(np.array, (f, std, damping))
    rms = np.sqrt(np.mean((f - truth) ** 2, axis=0))
    return {
        "truth": truth,
        "rms_hz": rms,
        "mean_std_hz": std.mean(axis=0),
        "ratio": std.mean(axis=0) / rms,
        "pooled": np.mean(std / truth) / np.sqrt(np.mean(((f - truth) / truth) ** 2)),
        "beyond_3": np.mean(np.abs(f - truth) > 3 * std),
        "damping_error": damping / zeta - 1,
    }


def main(sessions: int = 50) -> None:
    print("== measurement front end: 5 hits x 2 s x 48 kHz (CSV) -> peak list ==")
    cold, warm = timed_from_files()
    print(
        f"extract_peaks: {cold:.2f} s first call (imports included), {warm:.2f} s after "
        f"(target < {TARGET_S:g} s: {cold / TARGET_S:.2f} and {warm / TARGET_S:.2f} of it)"
    )
    in_band, found, peaks_s, predict_s = real_like_vs_predict()
    print(
        f"identify-layers peaks, real-like plate ({in_band} modes in band, 5 hits x 2 s x 48 kHz, %.7g time "
        f"column; {found} peaks): {peaks_s:.2f} s (target <= {TARGET_S:g} s); identify-layers predict on the "
        f"bundled example: {predict_s:.2f} s; ratio {peaks_s / predict_s:.2f} (target <= "
        f"{TARGET_VS_PREDICT:g}; "
        "whole processes, medians of 3, same run)"
    )
    mc = monte_carlo(sessions)
    print(f"{sessions} clean 5-hit sessions (jitter 3e-4, noise 1e-4), separated modes:")
    print(
        f"{'f_true Hz':>10s} {'RMS error Hz':>13s} {'mean std_hz':>12s} {'ratio':>6s} {'damping err %':>14s}"
    )
    for i, f in enumerate(mc["truth"]):
        error = mc["damping_error"][:, i]
        print(
            f"{f:>10.2f} {mc['rms_hz'][i]:>13.4f} {mc['mean_std_hz'][i]:>12.4f} {mc['ratio'][i]:>6.2f} "
            f"{100 * error.mean():>+7.2f} +- {100 * error.std():.2f}"
        )
    print(
        f"std_hz calibration (mean std_hz / RMS error, pooled): {mc['pooled']:.2f} (target 1 +- 0.3); "
        f"|error| > 3 std_hz: {100 * mc['beyond_3']:.1f} % (Student's t, 4 dof: 4 %)"
    )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50)
