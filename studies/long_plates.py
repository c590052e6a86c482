"""Long wooden plates end to end, as a lab runs them: recordings -> peaks -> fit ->
diagnose, each step timed; the diagnosis ends with the layers refitted with the effects it
selects (its ``final``), which is the loop's answer.

The plates are shaped like the spruce plates of a public tap-test data set (about
580 x 213 x 5 mm, grain along the length), tapped five times each near a corner, an
accelerometer on the far side; 48 kHz, 2 s a hit, the response 40 dB above its noise
floor, 1 % mains hum, the plate bouncing on its suspension and the cable rattling
(``identify.recordings.tap_quirks``), written with the time column printed to 7 digits as
DAQ exports do.  The modes are the project's own model at properties drawn around
clear spruce (E1 11.5, E2 0.85, G12 0.70 GPa, nu12 0.40, +-10-20 %): 40 modes, of which
``peaks`` finds 28-33 (close pairs merge, nodes at the sensor hide modes, suspension and
hum add spurious peaks).

A plate is "thin" (Kirchhoff, nothing missing) or "real-like": transverse shear with
wood's rolling shear modulus (G13 ~ G12, G23 ~ G12 / 16) and a 4 g accelerometer, which
the thin-plate spec does not know, so ``fit`` ends as a poor fit and ``diagnose`` has
something to find.  Every fit starts from handbook spruce (E1 10.0, E2 0.80, G12 0.62 GPa,
nu12 0.40) with no mode numbers.

    python -m studies.long_plates [--out DIR]

``run(..., confirm=True)`` also runs ``fit --effect`` with the selection (the same model
refitted from the thin-plate fit) and records its seconds and z-scores beside the loop's.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import tomli_w

from fem.solver.attachments import PointMass
from fem.solver.mode_shapes import deflection_operator
from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.diagnosis.diagnose import diagnose
from identify.fitting.driver import fit
from identify.measurements import parse_measurements
from identify.recordings.peaks import extract_peaks
from identify.recordings.tap_quirks import with_bounce, with_hum, with_rattle, with_snr, write_rounded_csv
from identify.recordings.tap_simulation import Modes, Session

from .common import parse_args, report_folder, write_text

LENGTH, WIDTH, THICKNESS = 0.580, 0.213, 0.005
#: The spec a lab writes: measured size and density, handbook spruce as the start.
HANDBOOK = {
    "specimen": {
        "name": "spruce plate",
        "length_mm": LENGTH * 1e3,
        "width_mm": WIDTH * 1e3,
        "layers": [{"material": "spruce", "thickness_mm": THICKNESS * 1e3}],
    },
    "materials": {
        "spruce": {
            "E1_GPa": 10.0,
            "E2_GPa": 0.80,
            "G12_GPa": 0.62,
            "nu12": 0.40,
            "density_kg_m3": 440.0,
            "identify": True,
        }
    },
    "configurations": [{"name": "original"}],
    "model": {"modes": 12},
}
#: Modes simulated per plate (up to about 1.7 kHz, beyond the hammer's band).
SIMULATED_MODES = 40
SENSOR_MASS = 0.004
SNR_DB = 40.0
PROPERTIES = ("E1", "E2", "G12", "nu12")


def handbook_model():
    return parse_spec(HANDBOOK, "<long_plates handbook spruce>")


def spec_text() -> str:
    """The handbook spec as the TOML file a lab writes (for the command line)."""
    return tomli_w.dumps(HANDBOOK)


@dataclass(frozen=True)
class Plate:
    """One simulated plate: its true properties [SI], where it was tapped and sensed [m],
    the recordings and whether it is real-like (shear and a sensor the spec lacks)."""

    seed: int
    truth: dict[str, float]
    recordings: tuple[Path, ...]
    real_like: bool
    excitation: tuple[float, float]
    sensor: tuple[float, float]


def simulate(seed: int, folder: Path, real_like: bool = True) -> Plate:
    """Five hits on plate ``seed`` written as CSV exports into ``folder``."""
    rng = np.random.default_rng(seed)
    truth = {
        "E1": 11.5e9 * rng.uniform(0.9, 1.1),
        "E2": 0.85e9 * rng.uniform(0.8, 1.2),
        "G12": 0.70e9 * rng.uniform(0.9, 1.1),
        "nu12": rng.uniform(0.35, 0.45),
    }
    excitation = (rng.uniform(0.05, 0.15) * LENGTH, rng.uniform(0.1, 0.3) * WIDTH)
    sensor = (rng.uniform(0.6, 0.9) * LENGTH, rng.uniform(0.6, 0.9) * WIDTH)
    model = handbook_model()
    if real_like:
        truth.update(G13=0.65e9 * rng.uniform(0.8, 1.2), G23=0.045e9 * rng.uniform(0.7, 1.3))
        model = model.with_options(transverse_shear=True, rotary_inertia=True)
        model = model.with_attachments([PointMass(SENSOR_MASS, *sensor, "accelerometer")])
    model = model.with_values({Parameter(k, "spruce"): v for k, v in truth.items()})
    solution = model.with_options(modes=SIMULATED_MODES).solve("original")
    points = deflection_operator(solution.units, [excitation[0], sensor[0]], [excitation[1], sensor[1]])
    w = points @ solution.modes.shapes[:, :SIMULATED_MODES]
    damping = np.exp(rng.uniform(np.log(0.003), np.log(0.011), SIMULATED_MODES))
    modes = Modes(solution.frequencies_hz[:SIMULATED_MODES], damping, w[0] * w[1])
    paths = []
    for i, hit in enumerate(Session(modes, n_hits=5, seed=seed).hits()):
        hit = with_rattle(with_bounce(with_hum(with_snr(hit, SNR_DB, rng), 50.0, 1e-2)), rng)
        paths.append(folder / f"hit{i + 1}.csv")
        write_rounded_csv(hit, paths[-1])
    return Plate(seed, truth, tuple(paths), real_like, excitation, sensor)


@dataclass(frozen=True)
class Outcome:
    """One plate's loop: seconds per step, the fits' statuses, the peaks used, the
    effects selected and (identified - true) / std of the layer properties of the
    diagnosis's refit with them (the baseline fit's where nothing was selected; NaN where
    the std is infinite); ``confirm_z``: the same of ``fit --effect`` with the selection,
    when it was run (its time is ``seconds["confirm"]``, not part of the loop)."""

    seed: int
    real_like: bool
    seconds: dict[str, float]
    peaks: int
    used: int
    fit_status: str
    fit_rms: float
    selected: tuple[str, ...] = ()
    refit_status: str | None = None
    refit_rms: float | None = None
    z: dict[str, float] = field(default_factory=dict)
    ratio: dict[str, float] = field(default_factory=dict)
    confirm_z: dict[str, float] = field(default_factory=dict)

    @property
    def loop_seconds(self) -> float:
        """peaks + fit + diagnose [s] (the confirming refit is not part of the loop)."""
        return sum(v for k, v in self.seconds.items() if k != "confirm")


def run_plate(plate: Plate, folder: Path, workers: int | None = None, confirm: bool = False) -> Outcome:
    """peaks -> fit -> diagnose, timed; ``workers`` as in ``fit`` and ``diagnose`` (default
    None: two processes where it pays, as the command line runs them); ``confirm``: then
    ``fit`` with the selected effects as well, timed apart."""
    seconds = {}
    clock = time.perf_counter()
    peak_list = extract_peaks(list(plate.recordings), "original")
    seconds["peaks"] = time.perf_counter() - clock
    table = peak_list.to_frame()[["configuration", "frequency_hz", "std_hz", "damping_ratio"]]
    write_text(folder / "peaks.csv", table.to_csv(index=False))
    model = handbook_model()
    measurements = parse_measurements(table, model, "peaks.csv")

    clock = time.perf_counter()
    baseline = fit(model, measurements, workers=workers)
    seconds["fit"] = time.perf_counter() - clock
    clock = time.perf_counter()
    diagnosis = diagnose(model, measurements, workers=workers)
    seconds["diagnose"] = time.perf_counter() - clock
    selected = tuple(c.kind for c in diagnosis.selected)
    final = diagnosis.final or baseline
    z, ratio = _scores(final, plate.truth)
    # Where nothing was selected the answer is the baseline, whose report is already first.
    reports = [baseline.report(), diagnosis.report()] + (
        [final.report()] if diagnosis.final is not None else []
    )
    confirm_z = {}
    if confirm and selected:
        clock = time.perf_counter()
        confirmed = fit(model, measurements, list(selected), workers=workers)
        seconds["confirm"] = time.perf_counter() - clock
        confirm_z = _scores(confirmed, plate.truth)[0]
        reports.append(confirmed.report())
    write_text(folder / "report.txt", "\n\n".join(reports) + "\n")
    used = int((final.peaks.modes > 0).sum()) if final.peaks is not None else len(measurements)
    return Outcome(
        plate.seed,
        plate.real_like,
        seconds,
        len(table),
        used,
        baseline.status.value,
        baseline.rms_rel_error,
        selected,
        final.status.value if selected else None,
        final.rms_rel_error if selected else None,
        z,
        ratio,
        confirm_z,
    )


def _scores(result, truth: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """(identified - true) / std and identified / true of the spruce's properties."""
    z, ratio = {}, {}
    for p, v, s in zip(result.parameters, result.values, result.uncertainty.std):
        if p.target == "spruce" and p.kind in PROPERTIES:
            # An undetermined estimate (infinite std) has no z-score, not a perfect one.
            z[p.kind] = float((v - truth[p.kind]) / s) if np.isfinite(s) and s > 0 else math.nan
            ratio[p.kind] = float(v / truth[p.kind])
    return z, ratio


def _shown(z: float):
    return round(z, 2) if math.isfinite(z) else "undetermined"


def run(
    out=None, seeds=(10, 11, 12), real_like: bool = True, workers: int | None = None, confirm: bool = False
) -> list[Outcome]:
    folder = report_folder("long_plates", out)
    outcomes = []
    for seed in seeds:
        plate_folder = folder / f"plate{seed}"
        plate_folder.mkdir(parents=True, exist_ok=True)
        outcomes.append(run_plate(simulate(seed, plate_folder, real_like), plate_folder, workers, confirm))
    rows = [
        {
            "plate": o.seed,
            "peaks": o.peaks,
            "used": o.used,
            "fit": o.fit_status,
            "fit_rms_%": round(100 * o.fit_rms, 3),
            "selected": " + ".join(o.selected) or "-",
            "refit": o.refit_status or "-",
            **{f"{k}_s": round(v, 1) for k, v in o.seconds.items()},
            "loop_s": round(o.loop_seconds, 1),
            **{f"z_{k}": _shown(v) for k, v in o.z.items()},
            **{f"confirm_z_{k}": _shown(v) for k, v in o.confirm_z.items()},
        }
        for o in outcomes
    ]
    summary = pd.DataFrame(rows).to_string(index=False)
    write_text(folder / "summary.txt", "Long spruce-like plates, recordings to layers\n\n" + summary + "\n")
    return outcomes


if __name__ == "__main__":
    args = parse_args("long_plates", __doc__)
    for outcome in run(args.out):
        print(outcome)
