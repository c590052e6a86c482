"""Identification benchmarks: the paper's three configurations from Table 6's start
(target < 1 s) and the same data as a peak list without mode numbers (target within
1.5x the ranked fit, in the process and as ``identify-layers fit`` on the bundled
example's data with and without its mode column, start-up included).  Solutions are
cached by content, so the cache is cleared before each timed fit."""
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from fem.model import solve_laminate
from identify.fitting.driver import fit
from identify.measurements import Measurements
from identify.recordings.synthetic import synthetic_measurements
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
from studies.common import start_model, true_model

from .peaks import _command, _wall

#: A peak-list fit at most this many times the labelled fit of the same data.
TARGET_RATIO = 1.5


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
    print(f"close modes labelled (the lab's usual data): {ranked:.2f} s, {iterations} iterations (target < 1 s)")
    seconds, iterations = timed_fit(synthetic_measurements(true_model(), modes=5, labels="none"))
    print(f"frequencies only (every assignment of the 3 close pairs refitted): {seconds:.2f} s, "
          f"{iterations} iterations on the winning branch")
    peaks = Measurements(labelled.table.assign(mode=0), "<peak list>")
    seconds, iterations = timed_fit(peaks)
    print(f"the labelled data as a peak list (no mode numbers: matched, fitted, matched again): {seconds:.2f} s, "
          f"{seconds / ranked:.2f}x the ranked fit (target <= {TARGET_RATIO:g}x)")
    labelled_s, peaks_s = command_line_pair()
    print(f"identify-layers fit on the bundled example: labelled {labelled_s:.2f} s, as a bare peak list (mode column "
          f"dropped) {peaks_s:.2f} s: {peaks_s / labelled_s:.2f}x (target <= {TARGET_RATIO:g}x; whole processes, "
          "medians of 3 taken in turn, start-up included)")


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
