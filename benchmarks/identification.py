"""Identification benchmarks: the paper's three configurations from Table 6's start
(target < 1 s) and the same data as a peak list without mode numbers (target within
1.5x the ranked fit, in the process and as ``identify-layers fit`` on the bundled
example's data with and without its mode column, start-up included); a long spruce
plate's peak list from simulated recordings (``studies.long_plates``, 30 peaks, handbook
start): ``fit`` as a process, with its peak memory; and a real-like one (transverse shear,
rotary inertia and a 4 g sensor in the recordings, none in the spec): ``fit``, ``fit
--effect point_mass`` and ``diagnose``, each a process with its peak memory (targets 60 s,
3 min and 2 GB).  Solutions are cached by content, so the cache is cleared before each
timed fit."""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from fem.model import solve_laminate
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
from identify.fitting.driver import fit
from identify.measurements import Measurements
from identify.recordings.peaks import extract_peaks
from identify.recordings.synthetic import synthetic_measurements
from studies import long_plates
from studies.common import start_model, true_model

from .peaks import _command, _wall

#: A peak-list fit at most this many times the labelled fit of the same data.
TARGET_RATIO = 1.5
#: Wall-time targets [s] of the commands on the real-like plate's peak list, and the peak
#: memory [MiB] of any of them (a lab laptop has 8-16 GB).
REAL_LIKE_TARGETS = {"fit --effect point_mass": 60.0, "diagnose": 180.0}
MEMORY_TARGET_MIB = 2048


def timed_fit(data: Measurements) -> tuple[float, int]:
    start = start_model()
    solve_laminate.cache_clear()
    t0 = time.perf_counter()
    result = fit(start, data)
    return time.perf_counter() - t0, result.iterations


def main() -> None:
    print("== identification: paper plate, 3 configurations x 5 modes, 12 unknowns, Table 6 start ==")
    labelled = synthetic_measurements(true_model(), modes=5, labels="close")
    ranked, iterations = timed_fit(labelled)
    print(
        f"close modes labelled (the lab's usual data): {ranked:.2f} s, {iterations} iterations (target < 1 s)"
    )
    seconds, iterations = timed_fit(synthetic_measurements(true_model(), modes=5, labels="none"))
    print(
        f"frequencies only (every assignment of the 3 close pairs refitted): {seconds:.2f} s, "
        f"{iterations} iterations on the winning branch"
    )
    peaks = Measurements(labelled.table.assign(mode=0), "<peak list>")
    seconds, iterations = timed_fit(peaks)
    print(
        f"the labelled data as a peak list (no mode numbers: matched, fitted, matched again): {seconds:.2f} "
        "s, "
        f"{seconds / ranked:.2f}x the ranked fit (target <= {TARGET_RATIO:g}x)"
    )
    labelled_s, peaks_s = command_line_pair()
    print(
        f"identify-layers fit on the bundled example: labelled {labelled_s:.2f} s, as a bare peak list (mode "
        "column "
        f"dropped) {peaks_s:.2f} s: {peaks_s / labelled_s:.2f}x (target <= {TARGET_RATIO:g}x; whole "
        "processes, "
        "medians of 3 taken in turn, start-up included)"
    )
    n_peaks, (seconds, mib, _) = long_plate(["fit"], real_like=False)
    print(
        f"identify-layers fit on a long spruce plate's peak list ({n_peaks} peaks from 5 simulated hits, "
        "handbook "
        f"start, screened): {seconds:.1f} s, peak memory {mib:.0f} MiB"
    )
    commands = ["fit", *REAL_LIKE_TARGETS]
    n_peaks, *runs = long_plate(commands, real_like=True)
    print(
        f"the same on a real-like spruce plate ({n_peaks} peaks; the recordings carry transverse shear, "
        "rotary inertia and a 4 g sensor, the spec none of them):"
    )
    for command, (seconds, mib, code) in zip(commands, runs, strict=True):
        target = REAL_LIKE_TARGETS.get(command)
        goal = "no target"
        if target:
            goal = f"target <= {target:.0f} s, {'met' if seconds <= target else 'not met'}"
        print(
            f"  identify-layers {command:24s} {seconds:6.1f} s ({goal}), peak memory {mib:5.0f} MiB "
            f"(target <= {MEMORY_TARGET_MIB}), exit code {code}"
        )


def long_plate(commands: list[str], seed: int = 0, real_like: bool = False) -> list:
    """Peaks found on a long spruce plate's simulated recordings (``real_like``: with the
    physics a thin-plate spec lacks), and for each of ``commands`` (``identify-layers``
    subcommands and options, run on them from handbook spruce) its wall time [s], peak
    memory [MiB] and exit code (non-zero for a fit that is not consistent with the scatter).
    Returns [the number of peaks, (s, MiB, code) of each command]."""
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        plate = long_plates.simulate(seed, folder, real_like=real_like)
        table = extract_peaks(list(plate.recordings), "original").to_frame()
        (folder / "peaks.csv").write_text(
            table[["configuration", "frequency_hz", "std_hz"]].to_csv(index=False)
        )
        spec = folder / "spruce.toml"
        spec.write_text(long_plates.spec_text())
        # Each command in a process of its own, whose peak memory its parent reports.
        probe = (
            "import resource, subprocess, sys; code = subprocess.run(sys.argv[1:], capture_output=True)"
            ".returncode; print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, code)"
        )
        runs = []
        for command in commands:
            start = time.perf_counter()
            done = subprocess.run(
                [sys.executable, "-c", probe, *_command(*command.split(), spec, folder / "peaks.csv")],
                capture_output=True,
                text=True,
                check=True,
            )
            kib, code = done.stdout.split()[-2:]
            runs.append((time.perf_counter() - start, int(kib) / 1024, int(code)))
    return [len(table), *runs]


def command_line_pair(repeat: int = 3) -> tuple[float, float]:
    """Median wall times [s] of ``identify-layers fit`` on the bundled measurements and on
    the same without the ``mode`` column, run in turn."""
    with tempfile.TemporaryDirectory() as folder:
        bare = Path(folder) / "peaks.csv"
        table = pd.read_csv(COATED_PLATE_MEASURED, comment="#", dtype={"label": str})
        bare.write_text(table.drop(columns="mode").to_csv(index=False))
        labelled, peaks = [], []
        for _ in range(repeat):
            labelled.append(_wall(_command("fit", COATED_PLATE, COATED_PLATE_MEASURED)))
            peaks.append(_wall(_command("fit", COATED_PLATE, bare)))
    return float(np.median(labelled)), float(np.median(peaks))


if __name__ == "__main__":
    main()
