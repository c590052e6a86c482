"""The lab's whole chain on simulated tap recordings: recordings -> peaks -> fit.

The paper's coated plate (Table 1 properties) with a 3 g accelerometer, in its three
configurations, is tapped five times each: hammer pulses of varying force, hit-to-hit
scatter of the modes (0.03 %), noise on both channels, one double hit per configuration
and one record cut short.  The response is the exact modal superposition of the FE
model's own modes (mass-normalised shapes at the excitation and sensor points give the
modal constants), so the frequencies are known.  ``identify-layers peaks`` turns each
configuration's recordings into a peak list (no mode numbers: close pairs merge into one
peak, modes with a node at the sensor are missing), and ``fit`` identifies the layers
from the paper's Table 6 start, with the accelerometer in the spec as a lab knows it.

    python -m studies.tap_test [--out DIR]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from fem.model import SpecimenModel
from fem.solver.attachments import PointMass
from fem.solver.mode_shapes import deflection_operator
from identify.engine.result import FitResult
from identify.fitting.driver import fit
from identify.measurements import parse_measurements
from identify.recordings.peaks import extract_peaks
from identify.recordings.tap_simulation import Modes, Session, write_csv

from .common import parse_args, report_folder, start_model, true_model, write_text

#: Where the plate is tapped and where the 3 g accelerometer sits [m] (from the corner).
EXCITATION = (0.040, 0.025)
SENSOR = (0.125, 0.110)
SENSOR_MASS = 3e-3
#: Modes simulated per configuration (the peaks found are fewer: pairs merge, nodes hide).
MODES = 8


@dataclass(frozen=True)
class TapTest:
    true_hz: dict[str, np.ndarray]  # the truth's frequencies per configuration
    peaks: pd.DataFrame  # the peak list the recordings gave
    rejected: int  # hits rejected (double hits)
    fit: FitResult
    z: dict[str, float]  # (identified - true) / std per parameter


def modal_data(model: SpecimenModel, configuration: str, seed: int) -> Modes:
    """Frequencies, damping ratios (0.3-1.1 %) and accelerance modal constants
    phi(excitation) phi(sensor) of the first ``MODES`` modes."""
    solution = model.solve(configuration)
    points = deflection_operator(solution.units, [EXCITATION[0], SENSOR[0]], [EXCITATION[1], SENSOR[1]])
    w = points @ solution.modes.shapes[:, :MODES]
    damping = np.random.default_rng(seed).uniform(0.003, 0.011, MODES)
    return Modes(solution.frequencies_hz[:MODES], damping, w[0] * w[1])


def run(out=None, seed: int = 1) -> TapTest:
    sensor = [PointMass(SENSOR_MASS, *SENSOR, "accelerometer")]
    truth = true_model().with_attachments(sensor).with_options(modes=MODES + 2)
    folder = report_folder("tap_test", out)
    lists, rejected, true_hz = [], 0, {}
    for k, c in enumerate(truth.specimen.configurations):
        session = Session(
            modal_data(truth, c.name, seed + k), n_hits=5, seed=seed + k, double_hits=(2,), cut_short={4: 0.4}
        )
        paths = []
        for i, hit in enumerate(session.hits()):
            paths.append(folder / "recordings" / c.name / f"hit{i + 1}.csv")
            write_csv(hit, paths[-1])
        peaks = extract_peaks(paths, c.name)
        peaks.write_csv(folder / f"peaks_{c.name}.csv")
        lists.append(peaks.to_frame()[["configuration", "frequency_hz", "std_hz", "damping_ratio"]])
        rejected += len(peaks.rejected)
        true_hz[c.name] = truth.solve(c.name).frequencies_hz[:MODES]
    peak_list = pd.concat(lists, ignore_index=True)
    write_text(folder / "peaks.csv", peak_list.to_csv(index=False))
    start = start_model().with_attachments(sensor)
    result = fit(start, parse_measurements(peak_list, start, "peaks.csv"))
    z = {
        p.name: (v - truth.value(p)) / s
        for p, v, s in zip(result.parameters, result.values, result.uncertainty.std)
    }
    lines = ["Tap test: recordings -> peaks -> fit (the paper's plate, 3 g accelerometer)", ""]
    for name, f in true_hz.items():
        found = peak_list[peak_list["configuration"] == name]["frequency_hz"].to_numpy()
        lines.append(f"{name}: true {np.round(f, 2).tolist()} Hz; peaks {np.round(found, 2).tolist()} Hz")
    lines += ["", f"hits rejected: {rejected}", "", result.report(), "(identified - true) / std:"]
    lines += [f"  {name:24s} {value:+.2f}" for name, value in z.items()]
    write_text(folder / "summary.txt", "\n".join(lines) + "\n")
    return TapTest(true_hz, peak_list, rejected, result, z)


if __name__ == "__main__":
    run(parse_args("tap_test", __doc__).out)
    print("report written to reports/tap_test (or --out)")
