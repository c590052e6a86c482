"""From tap recordings to the layers: `peaks` on every configuration, then `fit`.

A lab taps each configuration of the paper's coated plate a few times and records the
hammer's force and an accelerometer's response. Here those recordings are simulated, so
the truth is known: the plate's modes (frequencies from the model of the paper's Table 1
plate, damping ratios of 0.4-0.8 %) excited by a half-sine hammer pulse, with noise and
a small hit-to-hit scatter of the frequencies. Each hit is written as the CSV time series
the tool reads (`time_s,force,acceleration`). `identify-layers peaks` turns each
configuration's hits into a peak list (no mode numbers: the close pair of modes 4 and 5
merges into one peak), and `fit` identifies the layers from the three peak lists.

    .venv/bin/python docs/examples/recordings_to_layers.py [FOLDER]
"""

import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import tomli_w

import identify
from identify.cli import main as identify_layers
from identify.examples import COATED_PLATE

#: The paper's Table 1 layer properties (the truth the recordings are made from).
TABLE_1 = {
    "bottom_coating": (68.0, 71.0, 24.0, 0.32),
    "steel": (201.0, 200.0, 78.0, 0.29),
    "top_coating": (73.0, 70.0, 25.0, 0.34),
}
SAMPLE_RATE = 4000.0  # Hz: the modes of interest lie below 1 kHz
DURATION = 1.5  # s per hit
HITS = 3


def true_model():
    """The bundled spec with the Table 1 properties instead of the start values."""
    data = tomllib.loads(Path(COATED_PLATE).read_text())
    for name, (e1, e2, g12, nu12) in TABLE_1.items():
        data["materials"][name].update(E1_GPa=e1, E2_GPa=e2, G12_GPa=g12, nu12=nu12)
    return identify.load_spec(write_spec(data, Path(tempfile.mkdtemp()) / "truth.toml"))


def write_spec(data: dict, path: Path) -> Path:
    path.write_text(tomli_w.dumps(data))
    return path


def hit(frequencies_hz: np.ndarray, rng: np.random.Generator) -> pd.DataFrame:
    """One tap: a 0.3 ms half-sine force pulse and the accelerance response of modes with
    alternating signs, each frequency scattered by 0.02 % from hit to hit, plus noise."""
    n = int(SAMPLE_RATE * DURATION)
    t = np.arange(n) / SAMPLE_RATE
    width = 3e-4
    force = np.where(t < width, np.sin(np.pi * t / width), 0.0) * rng.uniform(0.8, 1.2)
    omega = 2 * np.pi * np.fft.rfftfreq(n, 1 / SAMPLE_RATE)
    spectrum = np.zeros_like(omega, dtype=complex)
    for i, f in enumerate(frequencies_hz):
        w = 2 * np.pi * f * (1 + 2e-4 * rng.standard_normal())
        zeta = 0.004 + 0.001 * i
        spectrum += (-1) ** i * -(omega**2) / (w**2 - omega**2 + 2j * zeta * w * omega)
    response = np.fft.irfft(spectrum * np.fft.rfft(force), n)
    response += 1e-3 * np.abs(response).max() * rng.standard_normal(n)
    return pd.DataFrame(
        {"time_s": t, "force": force + 1e-3 * rng.standard_normal(n), "acceleration": response}
    )


def main(folder: Path | None = None) -> identify.FitResult:
    folder = Path(folder or tempfile.mkdtemp())
    folder.mkdir(parents=True, exist_ok=True)
    truth = identify.predict(true_model())
    rng = np.random.default_rng(7)
    peak_lists = []
    for name, frequencies in truth.frequencies_hz.items():
        files = []
        for i in range(HITS):
            files.append(folder / f"{name}_hit{i + 1}.csv")
            hit(frequencies, rng).to_csv(files[-1], index=False)
        peak_lists.append(folder / f"{name}_peaks.csv")
        identify_layers(["peaks", *map(str, files), "--configuration", name, "--out", str(peak_lists[-1])])
    measured = folder / "peaks.csv"
    pd.concat([pd.read_csv(p) for p in peak_lists]).to_csv(measured, index=False)
    print(f"\npeak lists of {len(peak_lists)} configurations in {measured}\n")

    model = identify.load_spec(COATED_PLATE)  # the paper's Table 6 start values
    result = identify.fit(model, identify.load_measurements(measured, model))
    print(result.report())
    return result


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else None)
