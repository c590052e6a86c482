"""A roving-hammer test, end to end: recordings per grid point -> peaks with shapes -> fit
paired by shape -> a report with the MAC matrices and the maps.

The paper's coated plate carries its 3 g accelerometer at (125, 110) mm (the spec says
so: it is a known mass). The hammer visits a 5 x 4 grid, two hits a point, each landing
about 1 mm off its point; the force and acceleration are recorded as the CSV time series
the tool reads. Here the recordings are simulated from the model at the paper's Table 1
properties, so the truth is known. For each configuration `identify-layers peaks
--points` finds the modes over the points and estimates their shapes (LSFD), then `fit
--shapes` pairs every peak with the model mode whose shape it has, with no mode numbers
and no labels given, and `--report` draws the MAC matrices, the measured nodal lines over
the model's, and where on the plate the shapes disagree.

    .venv/bin/python docs/examples/roving_hammer.py [FOLDER]
"""

import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import tomli_w

import identify
from fem.solver.mode_shapes import deflection_operator
from identify.cli import main as identify_layers
from identify.examples import COATED_PLATE
from identify.recordings.tap_simulation import RovingSetup, TapOptions, roving_hits, write_roving

TABLE_1 = {
    "bottom_coating": (68.0, 71.0, 24.0, 0.32),
    "steel": (201.0, 200.0, 78.0, 0.29),
    "top_coating": (73.0, 70.0, 25.0, 0.34),
}
SENSOR = {"kind": "point_mass", "mass_g": 3.0, "x_mm": 125.0, "y_mm": 110.0}
MODES = 8
GRID_X, GRID_Y = np.linspace(7.5, 142.5, 5), np.linspace(7.5, 142.5, 4)
RECORDING = TapOptions(sample_rate=4000.0, duration_s=1.5)
BAND_HZ = (100.0, 1300.0)


def spec(folder: Path, name: str, truth: bool) -> Path:
    """The bundled spec with the sensor and 8 modes; with ``truth`` at Table 1."""
    data = tomllib.loads(Path(COATED_PLATE).read_text())
    data["model"]["modes"] = MODES
    data["effects"] = [SENSOR]
    if truth:
        for material, (e1, e2, g12, nu12) in TABLE_1.items():
            data["materials"][material].update(E1_GPa=e1, E2_GPa=e2, G12_GPa=g12, nu12=nu12)
    path = folder / name
    path.write_text(tomli_w.dumps(data))
    return path


def tap(truth, configuration: str, points: pd.DataFrame, folder: Path, seed: int) -> None:
    """The roving-hammer recordings of one configuration: its modes' shapes (the truth's
    deflection w at any point) drive the simulated hits."""
    solution = truth.solve(configuration)
    field = solution.modes.shapes[:, :MODES]

    def shape(r):
        return lambda x, y: float((deflection_operator(solution.units, x / 1000, y / 1000) @ field[:, r])[0])

    damping = np.linspace(0.004, 0.007, MODES)
    hits = roving_hits(
        solution.frequencies_hz[:MODES],
        damping,
        [shape(r) for r in range(MODES)],
        points,
        RovingSetup((SENSOR["x_mm"], SENSOR["y_mm"]), hits=2, seed=seed, options=RECORDING),
    )
    write_roving(hits, folder)
    points.to_csv(folder / "points.csv", index=False)


def main(folder: Path | None = None) -> identify.FitResult:
    folder = Path(folder or tempfile.mkdtemp())
    folder.mkdir(parents=True, exist_ok=True)
    truth = identify.load_spec(spec(folder, "truth.toml", truth=True))
    points = pd.DataFrame(
        [(f"P{i}{j}", x, y) for i, x in enumerate(GRID_X) for j, y in enumerate(GRID_Y)],
        columns=["point", "x_mm", "y_mm"],
    )
    peaks, shapes = [], []
    for seed, name in enumerate(c.name for c in truth.specimen.configurations):
        tap(truth, name, points, folder / name, seed)
        peaks.append(folder / f"{name}_peaks.csv")
        shapes.append(folder / f"{name}_shapes.csv")
        identify_layers(
            [
                "peaks",
                "--points",
                str(folder / name / "points.csv"),
                "--configuration",
                name,
                "--band",
                *map(str, BAND_HZ),
                "--out",
                str(peaks[-1]),
                "--shapes-out",
                str(shapes[-1]),
            ]
        )
    for parts, name in ((peaks, "peaks.csv"), (shapes, "shapes.csv")):
        pd.concat([pd.read_csv(p, dtype=str) for p in parts]).to_csv(folder / name, index=False)

    start = spec(folder, "spec.toml", truth=False)  # the paper's Table 6 start values
    identify_layers(
        [
            "fit",
            str(start),
            str(folder / "peaks.csv"),
            "--shapes",
            str(folder / "shapes.csv"),
            "--report",
            str(folder / "report"),
        ]
    )
    model = identify.load_spec(start)
    measurements = identify.load_measurements(folder / "peaks.csv", model)
    from identify.measured_shapes import load_shapes

    return identify.fit(model, load_shapes(folder / "shapes.csv", model, measurements))


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else None)
