"""A hidden sensor, diagnosed: the model misses a 3 g accelerometer; `diagnose` finds it.

The virtual measurement is made with a 3 g accelerometer on the plate at (125, 110) mm,
but the spec does not say so. The fit of the layers alone is then a `poor_fit`: the
misfit is far above the 0.05 % scatter. `diagnose` tries the candidate effects with
their parameters free, keeps the one the Bayesian information criterion says pays for
itself, and refits: the point mass comes back with its mass and its position (up to the
plate's symmetry: (x, y), (L - x, y), (x, W - y) and (L - x, W - y) give the same
frequencies), and the misfit falls to the noise level.

    .venv/bin/python docs/examples/hidden_sensor.py
"""

import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import tomli_w

import identify
from identify.examples import COATED_PLATE

TABLE_1 = {
    "bottom_coating": (68.0, 71.0, 24.0, 0.32),
    "steel": (201.0, 200.0, 78.0, 0.29),
    "top_coating": (73.0, 70.0, 25.0, 0.34),
}
SENSOR = {"kind": "point_mass", "mass_g": 3.0, "x_mm": 125.0, "y_mm": 110.0}
SCATTER = 5e-4  # relative std of a measured frequency
MODES = 8  # per configuration: five leave the sensor's position undetermined
CANDIDATES = ["point_mass", "transverse_shear", "suspension", "adhesive"]


def spec(folder: Path, name: str, truth: bool) -> Path:
    """The bundled spec; with ``truth`` at the Table 1 properties and with the sensor."""
    data = tomllib.loads(Path(COATED_PLATE).read_text())
    data["model"]["modes"] = MODES
    if truth:
        for material, (e1, e2, g12, nu12) in TABLE_1.items():
            data["materials"][material].update(E1_GPa=e1, E2_GPa=e2, G12_GPa=g12, nu12=nu12)
        data["effects"] = [SENSOR]
    path = folder / name
    path.write_text(tomli_w.dumps(data))
    return path


def measure(model, path: Path, seed: int = 3) -> Path:
    """The truth's frequencies with the stated scatter, as a measurement CSV."""
    rng = np.random.default_rng(seed)
    rows = []
    for configuration, frequencies in identify.predict(model).frequencies_hz.items():
        for mode, f in enumerate(frequencies, 1):
            rows.append(
                {
                    "configuration": configuration,
                    "mode": mode,
                    "frequency_hz": round(f * (1 + SCATTER * rng.standard_normal()), 3),
                    "std_hz": round(SCATTER * f, 3),
                }
            )
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def main() -> identify.Diagnosis:
    folder = Path(tempfile.mkdtemp())
    measured = measure(identify.load_spec(spec(folder, "truth.toml", truth=True)), folder / "measured.csv")
    model = identify.load_spec(spec(folder, "start.toml", truth=False))
    data = identify.load_measurements(measured, model)

    baseline = identify.fit(model, data)
    print(f"layers alone: {baseline.status.value}, RMS error {100 * baseline.rms_rel_error:.3f} %")
    diagnosis = identify.diagnose(model, data, CANDIDATES)
    print(diagnosis.report())
    return diagnosis


if __name__ == "__main__":
    main()
