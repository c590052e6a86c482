#!/usr/bin/env python3
"""The project's plate models against the 3-D elasticity references in this folder.

For every case (``<case>.json`` written by ``generate.py``) and configuration, the first
10 flexural modes of the 3-D solution are paired with the plate model's modes by the MAC
of w on the stored 13 x 11 mid-surface grid (optimal assignment over the plate model's
first ``--modes`` modes, in-plane ones included), and the relative frequency errors
(f_plate - f_3d) / f_3d are tabulated for

- CLT: Kirchhoff (``ModelOptions(modes=N)``),
- FSDT: first-order shear deformation with the laminate shear correction
  (``transverse_shear=True``),
- FSDT+RI: the same with rotary inertia (``transverse_shear=True, rotary_inertia=True``).

The plate mesh (``--divisions`` elements along the longer side) is checked against a
coarser one (``--check-divisions``): the largest change of a paired frequency is printed.

    python tests/data/solid3d/compare_plate_models.py [--case NAME ...] [--json OUT]

Uses the project's API as it is (``fem.spec.parse_spec``, ``fem.model``,
``fem.solver.attachments.point_operators``); the plate models are not modified.
"""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))

from fem.model import ModelOptions, SpecimenModel  # noqa: E402
from fem.solver.attachments import point_operators  # noqa: E402
from fem.spec import parse_spec  # noqa: E402

MODELS = {
    "CLT": dict(transverse_shear=False, rotary_inertia=False),
    "FSDT": dict(transverse_shear=True, rotary_inertia=False),
    "FSDT+RI": dict(transverse_shear=True, rotary_inertia=True),
}
N_COMPARED = 10
#: Pairs with a MAC below this are flagged in the table.
MAC_WARN = 0.9


def grid_w(solution, length: float, width: float, nx: int = 13, ny: int = 11) -> np.ndarray:
    """w of every plate mode on the grid x_i = L i/(nx-1), y_j = W j/(ny-1): (ny*nx, modes),
    rows in the order of the stored shapes ([j][i] flattened)."""
    shapes = solution.modes.shapes
    rows = []
    for y in width * np.arange(ny) / (ny - 1):
        for x in length * np.arange(nx) / (nx - 1):
            dofs, operators = point_operators(solution.units, x, y)
            rows.append(operators["w"] @ shapes[dofs])
    return np.array(rows)


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    num = (a.T @ b) ** 2
    den = np.outer(np.einsum("ij,ij->j", a, a), np.einsum("ij,ij->j", b, b))
    return num / np.maximum(den, 1e-300)


def pair(reference_w: np.ndarray, solution, length, width):
    """Plate-mode index and MAC for each reference mode (optimal assignment)."""
    macs = mac(reference_w, grid_w(solution, length, width))
    rows, cols = linear_sum_assignment(-macs)
    index = np.full(reference_w.shape[1], -1)
    index[rows] = cols
    return index, macs[np.arange(len(index)), index]


def compare_case(data: dict, modes: int, divisions: int, check_divisions: int, log=print) -> list[dict]:
    spec = parse_spec(tomllib.loads(data["spec_toml"]), data["case"])
    specimen = spec.specimen
    out = []
    for configuration in data["configurations"]:
        flexural = [m for m in configuration["modes"] if m["classification"] == "flexural"]
        reference = flexural[:N_COMPARED]
        f3d = np.array([m["frequency_hz"] for m in reference])
        w3d = np.array([np.ravel(m["w"]) for m in reference]).T
        row = dict(
            case=data["case"],
            configuration=configuration["name"],
            f3d=f3d.tolist(),
            labels=[m["label"] for m in reference],
            models={},
        )
        for name, switches in MODELS.items():
            freqs = {}
            for d in (check_divisions, divisions):
                options = ModelOptions(modes=modes, divisions=d, **switches)
                solution = SpecimenModel(specimen, options).solve(configuration["name"])
                index, macs = pair(w3d, solution, specimen.length, specimen.width)
                freqs[d] = (solution.frequencies_hz[index], macs, index)
            f, macs, index = freqs[divisions]
            mesh_change = np.max(np.abs(freqs[check_divisions][0] / f - 1))
            error = f / f3d - 1
            row["models"][name] = dict(
                frequencies_hz=f.tolist(),
                rel_error=error.tolist(),
                mac=macs.tolist(),
                plate_mode=index.tolist(),
                max_abs_error=float(np.max(np.abs(error))),
                rms_error=float(np.sqrt(np.mean(error**2))),
                mesh_change=float(mesh_change),
            )
        out.append(row)
        log(format_configuration(row))
    return out


def format_configuration(row: dict) -> str:
    lines = [
        f"\n{row['case']} / {row['configuration']}",
        f"{'mode':>4} {'label':>7} {'3-D Hz':>10} "
        + " ".join(f"{n:>9}" for n in MODELS)
        + "   MAC (CLT/FSDT/+RI)",
    ]
    for k, f in enumerate(row["f3d"]):
        errors = " ".join(f"{100 * row['models'][n]['rel_error'][k]:+8.2f}%" for n in MODELS)
        macs = "/".join(f"{row['models'][n]['mac'][k]:.3f}" for n in MODELS)
        flag = "  <- low MAC" if min(row["models"][n]["mac"][k] for n in MODELS) < MAC_WARN else ""
        lines.append(f"{k + 1:>4} {row['labels'][k]:>7} {f:>10.2f} {errors}   {macs}{flag}")
    lines.append(
        f"{'max':>4} {'':>7} {'':>10} "
        + " ".join(f"{100 * row['models'][n]['max_abs_error']:8.2f}%" for n in MODELS)
    )
    lines.append(
        f"{'rms':>4} {'':>7} {'':>10} "
        + " ".join(f"{100 * row['models'][n]['rms_error']:8.2f}%" for n in MODELS)
    )
    lines.append(
        "plate-mesh check (largest frequency change vs the coarser mesh): "
        + ", ".join(f"{n} {100 * row['models'][n]['mesh_change']:.4f}%" for n in MODELS)
    )
    return "\n".join(lines)


def summary(rows: list[dict]) -> str:
    head = f"{'case':<22} {'configuration':<11} " + " ".join(
        f"{n + ' max':>11} {n + ' rms':>11}" for n in MODELS
    )
    lines = ["\nSummary: relative error of the first 10 flexural modes vs 3-D (max |e|, rms e)", head]
    for r in rows:
        lines.append(
            f"{r['case']:<22} {r['configuration']:<11} "
            + " ".join(
                f"{100 * r['models'][n]['max_abs_error']:10.2f}% {100 * r['models'][n]['rms_error']:10.2f}%"
                for n in MODELS
            )
        )
    return "\n".join(lines)


def reference_tables(data: dict) -> str:
    """Markdown tables of a case's 3-D reference: meshes and run times, convergence and the
    first 10 flexural frequencies of every configuration."""
    made = data["made_with"]
    lines = [
        f"### {data['case']}",
        "",
        "| configuration | level | elements (x, y, through layers) | DOFs (4 quarter models) | wall s |",
        "|---|---|---|---|---|",
    ]
    walls = {(r["configuration"], r["level"]): r["wall_s"] for r in made["runs"]}
    for c in data["configurations"]:
        for m in c["meshes"]:
            wall = walls.get((c["name"], m["level"]), "mirror")
            lines.append(
                f"| {c['name']} | {m['level']} | {m['elements_along_length']} x {m['elements_along_width']} "
                "x "
                f"{m['elements_through_layers']} | {m['dofs_total']} | {wall} |"
            )
    levels = [l["name"] for l in made["levels"]]
    for c in data["configurations"]:
        flex = [m for m in c["modes"] if m["classification"] == "flexural"][:10]
        inplane = [m for m in c["modes"] if m["classification"] != "flexural"]
        conv = c.get("convergence", {})
        lines += [
            "",
            f"{c['name']} (H = {c['total_thickness_mm']:g} mm): max |change| "
            f"{levels[-2] if len(levels) > 1 else ''}"
            f" -> {levels[-1]}: first 10 elastic {_pct(conv.get('max_abs_change_first10_elastic'))}, first "
            "10 "
            f"flexural {_pct(conv.get('max_abs_change_first10_flexural'))}; in-plane modes stored: "
            + (", ".join(f"rank {m['rank']} {m['frequency_hz']:.1f} Hz" for m in inplane) or "none"),
            "",
            "| mode | label | " + " | ".join(f"{l} Hz" for l in levels) + " | change | w share |",
            "|---|---|" + "---|" * len(levels) + "---|---|",
        ]
        for k, m in enumerate(flex):
            per = " | ".join(
                "-" if m["frequencies_by_level"][l] is None else f"{m['frequencies_by_level'][l]:.2f}"
                for l in levels
            )
            lines.append(
                f"| {k + 1} (rank {m['rank']}) | {m['label']} | {per} | "
                f"{_pct(m['relative_change_last_two'])} "
                f"| {m['w_share']:.4f} |"
            )
    return "\n".join(lines)


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:+.4f} %"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", action="append", help="case name(s) (default: every <case>.json here)")
    parser.add_argument(
        "--modes", type=int, default=24, help="plate modes solved for the pairing (default 24)"
    )
    parser.add_argument(
        "--divisions", type=int, default=40, help="plate elements along the longer side (default 40)"
    )
    parser.add_argument(
        "--check-divisions", type=int, default=30, help="coarser plate mesh for the check (30)"
    )
    parser.add_argument("--dir", type=Path, default=HERE, help="folder of the <case>.json files")
    parser.add_argument("--json", type=Path, help="also write the table as JSON")
    parser.add_argument(
        "--reference-tables",
        action="store_true",
        help="print the 3-D references' mesh, convergence and frequency tables (Markdown) and stop",
    )
    args = parser.parse_args(argv)
    names = args.case or sorted(p.stem for p in args.dir.glob("*.json"))
    if args.reference_tables:
        for name in names:
            print(reference_tables(json.loads((args.dir / f"{name}.json").read_text())) + "\n")
        return 0
    rows = []
    for name in names:
        data = json.loads((args.dir / f"{name}.json").read_text())
        rows += compare_case(data, args.modes, args.divisions, args.check_divisions)
    print(summary(rows))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
