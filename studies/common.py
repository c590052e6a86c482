"""Shared pieces of the studies: the paper's plate, report folders, small plots."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from fem.io import write_text
from fem.model import SpecimenModel
from fem.plotting import new_figure, save_figure
from fem.spec import load_spec
from fem.specimen import Parameter
from identify.examples import COATED_PLATE

GPA = 1e9
#: The paper's Table 1 (true layer properties), keyed by the example's material names.
TABLE1 = {
    "top_coating": (73.0, 70.0, 25.0, 0.34),
    "steel": (201.0, 200.0, 78.0, 0.29),
    "bottom_coating": (68.0, 71.0, 24.0, 0.32),
}
#: The paper's Table 2 (equivalent plate): layer 1 = top coating, layer 3 = bottom (fixed).
TABLE2 = {
    "top_coating": (52.10, 97.83, 32.00, 0.313),
    "steel": (261.50, 95.92, 57.84, 0.324),
    "bottom_coating": (47.00, 98.00, 31.00, 0.300),
}


def material_values(table: dict) -> dict[Parameter, float]:
    out = {}
    for material, (E1, E2, G12, nu12) in table.items():
        out.update(
            {
                Parameter("E1", material): E1 * GPA,
                Parameter("E2", material): E2 * GPA,
                Parameter("G12", material): G12 * GPA,
                Parameter("nu12", material): nu12,
            }
        )
    return out


def start_model() -> SpecimenModel:
    """The bundled example: the paper's plate at Table 6's start values."""
    return load_spec(COATED_PLATE)


def true_model() -> SpecimenModel:
    """The paper's plate with Table 1's properties."""
    return start_model().with_values(material_values(TABLE1))


def report_folder(name: str, out: str | Path | None) -> Path:
    folder = Path(out) if out else Path("reports") / name
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def parse_args(name: str, description: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog=f"python -m studies.{name}", description=description)
    parser.add_argument("--out", help=f"report folder (default reports/{name})")
    return parser.parse_args()


def dependency_plot(sensitivity: np.ndarray, path: Path, title: str) -> float:
    """Paper Fig. 10: the first column of the sensitivity matrix against its best linear
    combination of the others.  Returns the relative residual of that fit (0 = dependent)."""
    first, others = sensitivity[:, 0], sensitivity[:, 1:]
    combination = others @ np.linalg.lstsq(others, first, rcond=None)[0]
    residual = float(np.linalg.norm(first - combination) / np.linalg.norm(first))
    fig, ax = new_figure(figsize=(4.2, 4))
    ax.plot(first, combination, "o")
    lims = [min(first.min(), combination.min()), max(first.max(), combination.max())]
    ax.plot(lims, lims, "k--", lw=0.8)
    ax.set_xlabel("column 1 of S")
    ax.set_ylabel("best combination of columns 2..n")
    ax.set_title(f"{title}\nrelative misfit {residual:.2e}", fontsize=9)
    ax.grid(alpha=0.3)
    save_figure(fig, path)
    return residual


__all__ = ["write_text"]
