"""Measured mode shapes on the paper's plate: a hidden sensor seen in the shapes, and the
bundled example's shape file.

A roving-hammer test of the paper's plate carrying a 3 g accelerometer at (125, 110) mm
that the spec does not know: 8 modes per configuration (0.05 % scatter), their shapes
on a 5 x 4 grid (1 % noise, hits 1 mm off their points), fitted as a peak list (no mode
numbers, no labels) without the sensor.  Per seed:

- the pairing: how many peaks are paired with the model mode the truth says (the truth
  model's mode of the same rank, followed to the fitted model by MAC over the whole
  plate), by frequency alone and with the shapes;
- where the shapes say the sensor is: the best node of the shapes' point-mass map
  (``fitting.patterns.shape_point_map``), the worst point of the shape residual and of
  COMAC, each as a distance from the sensor, and the mass the map estimates.

And on the blind study's held-out cases, whose 3-D models' top-face shapes are stored
(``tests/data/solid3d/blind_shapes``): the start pairing of each measured mode with the
user's start model (handbook values, nominal angles, no sensor, thin plate), by rank, by
the study's labels, and by the shapes (the 13 x 11 grid, and a 5 x 4 subset of it),
against the start model's mode that carries the truth's (``blind_pairing``).

    python -m studies.measured_shapes [--out DIR] [--seeds N] [--grid NX NY] [--blind]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.sparse as sp
from scipy.optimize import linear_sum_assignment

from fem.solver.attachments import PointMass
from fem.solver.mode_shapes import deflection_operator
from identify.diagnosis.compare import Comparison, compare
from identify.engine.objective import solving_model
from identify.engine.pairing import ModePairing, mac_matrix
from identify.examples import COATED_PLATE_MEASURED
from identify.measured_shapes import parse_shapes, shapes_frame
from identify.measurements import Measurements, load_measurements
from identify.recordings.synthetic import AlsoMeasured, synthetic_measurements

from . import blind_diagnosis
from .common import start_model, true_model, write_text

SENSOR = PointMass(3e-3, 0.125, 0.110)
GRID = (5, 4)
MODES = 8
SHAPE_NOISE = 0.01
HAMMER_STD_MM = 1.0
#: The bundled example's measurements were computed on a 20 x 20 mesh (their header).
EXAMPLE_DIVISIONS = 20
EXAMPLE_SEED = 2026


def hidden_sensor_data(seed: int, grid: tuple[int, int] = GRID) -> Measurements:
    """The peak list (no mode numbers) with its shapes, of the plate carrying the sensor."""
    data = synthetic_measurements(
        true_model().with_attachments([SENSOR]),
        modes=MODES,
        noise_rel=5e-4,
        seed=seed,
        also=AlsoMeasured(shape_grid=grid, shape_noise_rel=SHAPE_NOISE, hammer_std_mm=HAMMER_STD_MM),
    )
    return Measurements(data.table.assign(mode=0), data.source, data.shapes)


def _truly_paired(comparison: Comparison, data: Measurements) -> int:
    """Peaks paired with the model mode that is the truth's mode of the same rank (the
    peaks' order: 0.05 % noise does not reorder these modes, 0.2 % apart at the closest),
    the two followed by MAC of the deflection over the whole plate (mass-weighted)."""
    fitted = comparison.solver
    truth = (
        true_model()
        .with_attachments([SENSOR])
        .with_options(modes=fitted.options.modes, divisions=fitted.options.divisions)
    )
    result = comparison.fitted
    right = 0
    for name in data.configurations:
        peaks = data.of(name)["frequency_hz"].to_numpy()
        true_solution, model_solution = truth.solve(name), fitted.solve(name)
        mac = mac_matrix(
            true_solution.modes.shapes[:, :MODES],
            model_solution.modes.shapes,
            model_solution.units.first_unit_mass,
        )
        expected = np.argmax(mac, axis=1)  # the fitted model's mode of each true rank
        matched = result.measurements.of(name)["frequency_hz"].to_numpy()
        for f, mode in zip(matched, result.pairings[name].indices):
            right += int(mode == expected[int(np.argmin(np.abs(peaks - f)))])
    return right


def hidden_sensor_run(seed: int, grid: tuple[int, int] = GRID) -> dict:
    """One seed: pairing counts without and with shapes, and where the shapes point."""
    data = hidden_sensor_data(seed, grid)
    frequency_only = compare(start_model(), Measurements(data.table, data.source))
    with_shapes = compare(start_model(), data)
    sensor = np.array([SENSOR.x, SENSOR.y])
    residual = sum(c.residual**2 for c in with_shapes.shapes.values())
    comac = sum(1 - c.comac for c in with_shapes.shapes.values())
    xy = next(iter(with_shapes.shapes.values())).xy
    hint = with_shapes.shape_map.hint()
    return {
        "seed": seed,
        "grid": f"{grid[0]}x{grid[1]}",
        "peaks": len(data),
        "paired_right_frequency_only": _truly_paired(frequency_only, data),
        "paired_right_with_shapes": _truly_paired(with_shapes, data),
        "rms_frequency_only_%": 100 * frequency_only.rms_rel_error,
        "rms_with_shapes_%": 100 * with_shapes.rms_rel_error,
        "map_distance_mm": 1e3 * float(np.hypot(*(np.array(hint["xy"]) - sensor))),
        "map_mass_g": 1e3 * hint["mass_kg"],
        "residual_worst_distance_mm": 1e3 * float(np.hypot(*(xy[np.argmax(residual)] - sensor))),
        "comac_worst_distance_mm": 1e3 * float(np.hypot(*(xy[np.argmax(comac)] - sensor))),
    }


#: The truth's mode is carried to the start model by MAC of the deflection on this grid
#: over the whole plate (finer than any measured grid: the partner, not the test's view).
PARTNER_GRID = 31
#: The 5 x 4 subset of the stored 13 x 11 grid (indices along x and along y).
SUBSET = (np.array([0, 3, 6, 9, 12]), np.array([0, 3, 7, 10]))


def _w_on_grid(solution, length: float, width: float) -> np.ndarray:
    """(PARTNER_GRID^2, modes) deflection of every mode."""
    g = (np.arange(PARTNER_GRID) + 0.5) / PARTNER_GRID
    x, y = np.meshgrid(g * length, g * width)
    return deflection_operator(solution.units, x.ravel(), y.ravel()) @ solution.modes.shapes


def _subset(frame: pd.DataFrame) -> pd.DataFrame:
    xs, ys = np.sort(frame["x_mm"].unique()), np.sort(frame["y_mm"].unique())
    return frame[frame["x_mm"].isin(xs[SUBSET[0]]) & frame["y_mm"].isin(ys[SUBSET[1]])]


def blind_pairing(name: str) -> pd.DataFrame:
    """Per configuration of a held-out blind case: how many measured modes each way of
    pairing at the start gives the start model's mode that carries the truth's (the truth
    model's mode the 3-D one pairs with, ``plate_mode``, carried to the start model by the
    optimal MAC assignment of the deflection over the plate)."""
    case, start, data = blind_diagnosis.case_start(name)
    table = blind_diagnosis.shapes_table(name)
    full = parse_shapes(table, start, data)
    coarse = parse_shapes(_subset(table), start, data)
    truth = blind_diagnosis.truth_model(case)
    solver = solving_model(start, data)
    specimen = start.specimen
    rows = []
    for conf in case["configurations"]:
        name_ = conf["name"]
        measured = data.of(name_)
        ranks, labels = measured["mode"].to_numpy(), measured["label"].tolist()
        start_solution = solver.solve(name_)
        truth_solution = truth.with_options(modes=len(ranks) + 8).solve(name_)
        partners = np.array([m["plate_mode"] - 1 for m in conf["modes"]])
        mac = mac_matrix(
            _w_on_grid(truth_solution, specimen.length, specimen.width)[:, partners],
            _w_on_grid(start_solution, specimen.length, specimen.width),
            sp.identity(PARTNER_GRID**2),
        )
        truth_rows, truth_cols = linear_sum_assignment(-mac)
        expected = truth_cols[np.argsort(truth_rows)]
        ways = {
            "rank": ([""] * len(ranks), None),
            "labels": (labels, None),
            "shapes 13x11": ([""] * len(ranks), [full.of(name_, f) for f in measured["frequency_hz"]]),
            "shapes 5x4": ([""] * len(ranks), [coarse.of(name_, f) for f in measured["frequency_hz"]]),
        }
        row = {
            "case": name,
            "configuration": name_,
            "modes": len(ranks),
            "labelled": sum(bool(label) for label in labels),
        }
        for way, (given, shapes) in ways.items():
            indices = ModePairing.initial(name_, start_solution, ranks, given, shapes).indices
            row[way] = int(np.sum(indices == expected))
        rows.append(row)
    return pd.DataFrame(rows)


def grid_spacing_mm(grid: tuple[int, int] = GRID) -> tuple[float, float]:
    """The grid's spacing along x and y [mm] on the paper's plate."""
    specimen = true_model().specimen
    return tuple(1e3 * 0.9 * size / (n - 1) for size, n in zip((specimen.length, specimen.width), grid))


def write_example_shapes(path: Path) -> Path:
    """The bundled example's shape file: the Table 1 plate's modes (20 x 20 mesh, as its
    measurements) on the 5 x 4 grid, named by the bundled measurements' frequencies."""
    truth = true_model().with_options(divisions=EXAMPLE_DIVISIONS)
    measured = load_measurements(COATED_PLATE_MEASURED, truth)
    made = synthetic_measurements(
        truth,
        modes=int(measured.table["mode"].max()),
        seed=EXAMPLE_SEED,
        also=AlsoMeasured(shape_grid=GRID, shape_noise_rel=SHAPE_NOISE, hammer_std_mm=HAMMER_STD_MM),
    )
    frame = shapes_frame(made.shapes)
    # Name each shape by the bundled peak of its configuration and rank.
    ranks = made.table.set_index(["configuration", "frequency_hz"])["mode"]
    peaks = measured.table.set_index(["configuration", "mode"])["frequency_hz"]
    frame["frequency_hz"] = [
        peaks[c, ranks[c, f]] for c, f in zip(frame["configuration"], frame["frequency_hz"])
    ]
    header = (
        "# Mode shapes of the bundled example's peaks, as a roving-hammer test on a 5 x 4 grid gives them: "
        "the\n"
        "# paper's plate at Table 1 (20 x 20 mesh), 1 % noise, hits 1 mm off their points, scale and sign "
        "per\n"
        "# mode arbitrary (python -m studies.measured_shapes --example).\n"
    )
    write_text(path, header + frame.to_csv(index=False, float_format="%.6g"))
    return path


def main() -> None:
    parser = argparse.ArgumentParser(
        prog="python -m studies.measured_shapes", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--out", help="report folder (default reports/measured_shapes)")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument(
        "--grid",
        type=int,
        nargs=2,
        default=GRID,
        metavar=("NX", "NY"),
        help=f"the roving-hammer grid's points along x and y (default {GRID[0]} {GRID[1]})",
    )
    parser.add_argument(
        "--example", action="store_true", help="write the bundled example's shape file and stop"
    )
    parser.add_argument(
        "--blind", action="store_true", help="the start pairing on the blind study's held-out cases"
    )
    args = parser.parse_args()
    if args.example:
        from identify.examples import COATED_PLATE_SHAPES

        print(write_example_shapes(COATED_PLATE_SHAPES))
        return
    folder = Path(args.out or "reports/measured_shapes")
    folder.mkdir(parents=True, exist_ok=True)
    if args.blind:
        pairing = pd.concat(
            [blind_pairing(n) for n in blind_diagnosis.case_names("heldout")], ignore_index=True
        )
        text = (
            pairing.to_string(index=False)
            + "\n\ntotal\n"
            + pairing.drop(columns=["case", "configuration"]).sum().to_string()
            + "\n"
        )
        write_text(folder / "blind_pairing.csv", pairing.to_csv(index=False))
        write_text(folder / "blind_pairing.txt", text)
        print(text)
        return
    grid = tuple(args.grid)
    rows = pd.DataFrame([hidden_sensor_run(seed, grid) for seed in range(1, args.seeds + 1)])
    spacing = grid_spacing_mm(grid)
    text = (
        rows.to_string(index=False, float_format=lambda x: f"{x:.3g}")
        + f"\n\ngrid spacing {spacing[0]:.1f} x {spacing[1]:.1f} mm\n"
    )
    name = "hidden_sensor" if grid == GRID else f"hidden_sensor_{grid[0]}x{grid[1]}"
    write_text(folder / f"{name}.csv", rows.to_csv(index=False))
    write_text(folder / f"{name}.txt", text)
    print(text)


if __name__ == "__main__":
    main()
