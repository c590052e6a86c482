"""The 3-D elasticity references of ``tests/data/solid3d`` (CalculiX C3D20R, made by
``generate.py`` there) paired with the project's plate models.

Pairing: the first ``N_COMPARED`` flexural modes of the 3-D solution against the plate
model's modes by the MAC of w on the stored 13 x 11 mid-surface grid (optimal assignment),
as ``tests/data/solid3d/compare_plate_models.py`` does.

    python -m tests.fem.solid3d [CASE ...]     # CLT / FSDT / layerwise error tables
"""

from __future__ import annotations

import json
import sys
import tomllib
from functools import cache
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from fem.model import SpecimenModel
from fem.solver.attachments import point_operators
from fem.spec import parse_spec

FOLDER = Path(__file__).parent.parent / "data" / "solid3d"
CASES = ("foam_sandwich", "laminate_on_adhesive", "thick_laminate", "thick_homogeneous")
N_COMPARED = 10
#: Plate modes solved for the pairing (in-plane ones included): a margin over N_COMPARED.
PLATE_MODES = 14
MODELS = {
    "CLT": {},
    "FSDT": {"transverse_shear": True, "rotary_inertia": True},
    "layerwise": {"theory": "layerwise"},
}


def available(case: str) -> bool:
    return (FOLDER / f"{case}.json").exists()


@cache
def load(case: str) -> dict:
    return json.loads((FOLDER / f"{case}.json").read_text())


def spec_model(case: str) -> SpecimenModel:
    """The case's spec (true properties) as the project loads it."""
    return parse_spec(tomllib.loads(load(case)["spec_toml"]), case)


def reference(case: str, configuration: str, n: int = N_COMPARED) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Frequencies [Hz], w on the grid (143, n) and labels of the first n flexural modes."""
    (conf,) = [c for c in load(case)["configurations"] if c["name"] == configuration]
    flexural = [m for m in conf["modes"] if m["classification"] == "flexural"][:n]
    return (
        np.array([m["frequency_hz"] for m in flexural]),
        np.array([np.ravel(m["w"]) for m in flexural]).T,
        [m["label"] for m in flexural],
    )


def grid_w(solution, length: float, width: float, nx: int = 13, ny: int = 11) -> np.ndarray:
    """w of every plate mode on the grid x_i = L i/(nx-1), y_j = W j/(ny-1), rows [j][i]."""
    rows = []
    for y in width * np.arange(ny) / (ny - 1):
        for x in length * np.arange(nx) / (nx - 1):
            dofs, operators = point_operators(solution.units, x, y)
            rows.append(operators["w"] @ solution.modes.shapes[dofs])
    return np.array(rows)


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a.T @ b) ** 2 / np.outer(np.einsum("ij,ij->j", a, a), np.einsum("ij,ij->j", b, b))


def paired(model: SpecimenModel, configuration: str, w3d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The plate modes (indices) paired with the reference modes, and their MAC."""
    specimen = model.specimen
    solution = model.solve(configuration)
    macs = mac(w3d, grid_w(solution, specimen.length, specimen.width))
    rows, cols = linear_sum_assignment(-macs)
    index = np.full(w3d.shape[1], -1)
    index[rows] = cols
    return index, macs[np.arange(len(index)), index]


def errors(
    case: str, configuration: str, divisions: int | None = None, **options
) -> tuple[np.ndarray, np.ndarray]:
    """Relative frequency errors (plate / 3-D - 1) of the first 10 flexural modes, and MAC."""
    f3d, w3d, _ = reference(case, configuration)
    model = spec_model(case).with_options(modes=PLATE_MODES, divisions=divisions, **options)
    index, macs = paired(model, configuration, w3d)
    return model.solve(configuration).frequencies_hz[index] / f3d - 1, macs


def table(case: str) -> str:
    lines = [f"\n{case}: relative error of the first {N_COMPARED} flexural modes against 3-D [%]"]
    for conf in load(case)["configurations"]:
        f3d, _, labels = reference(case, conf["name"])
        results = {name: errors(case, conf["name"], **options) for name, options in MODELS.items()}
        lines.append(f"  {conf['name']}")
        lines.append(
            f"  {'mode':>4} {'label':>7} {'3-D Hz':>9} " + " ".join(f"{n:>10}" for n in MODELS) + "  min MAC"
        )
        for k in range(len(f3d)):
            lines.append(
                f"  {k + 1:>4} {labels[k]:>7} {f3d[k]:9.2f} "
                + " ".join(f"{100 * results[n][0][k]:+10.3f}" for n in MODELS)
                + f"  {min(results[n][1][k] for n in MODELS):.3f}"
            )
        lines.append(
            f"  {'max':>4} {'':>7} {'':>9} "
            + " ".join(f"{100 * np.abs(results[n][0]).max():10.3f}" for n in MODELS)
        )
        lines.append(
            f"  {'rms':>4} {'':>7} {'':>9} "
            + " ".join(f"{100 * np.sqrt(np.mean(results[n][0] ** 2)):10.3f}" for n in MODELS)
        )
    return "\n".join(lines)


if __name__ == "__main__":
    for name in sys.argv[1:] or [c for c in CASES if available(c)]:
        print(table(name), flush=True)
