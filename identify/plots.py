"""Plots of model against measurement: residuals with mode shapes, point-mass map,
and the error per mode before and after an effect is added."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fem.io import atomic_path
from fem.model import ModelOptions, SpecimenModel
from fem.specimen import Specimen


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    _pyplot().close(fig)


def plot_comparison(comparison, specimen: Specimen, options: ModelOptions, path: Path) -> None:
    """One row per configuration: relative error per measured mode, and each mode's shape
    (deflection w, nodal lines in black) above its bar."""
    plt = _pyplot()
    table = comparison.table
    configurations = list(dict.fromkeys(table["configuration"]))
    n_modes = int(table.groupby("configuration").size().max())
    model = SpecimenModel(specimen, options)
    fig, axes = plt.subplots(2 * len(configurations), n_modes, figsize=(1.6 * n_modes + 1, 3.2 * len(configurations)),
                             squeeze=False, gridspec_kw={"height_ratios": [1, 1.4] * len(configurations)})
    pairings = comparison.fitted.pairings if comparison.fitted is not None else {}
    for row, name in enumerate(configurations):
        rows = table[table["configuration"] == name]
        solution = model.solve(name)
        units = solution.units
        w_index = units.element_type.NODE_DOFS.index("w")
        grid = (units.mesh.ny + 1, units.mesh.nx + 1)
        indices = pairings[name].indices if name in pairings else rows["mode"].to_numpy() - 1
        for k in range(n_modes):
            ax_shape, ax_bar = axes[2 * row, k], axes[2 * row + 1, k]
            ax_shape.axis("off")
            if k >= len(rows):
                ax_bar.axis("off")
                continue
            shape = solution.modes.shapes[:, indices[k]].reshape(units.mesh.n_nodes, -1)[:, w_index].reshape(grid)
            ax_shape.imshow(shape, origin="lower", cmap="RdBu", aspect="equal")
            ax_shape.contour(shape, levels=[0], colors="k", linewidths=0.8)
            ax_shape.set_title(f"{name}\nmode {rows['mode'].iloc[k]}" if k == 0 else f"mode {rows['mode'].iloc[k]}",
                               fontsize=8)
            err = 100 * rows["rel_error"].iloc[k]
            ax_bar.bar([0], [err], color="tab:red" if err > 0 else "tab:blue")
            ax_bar.axhline(0, color="k", lw=0.6)
            ax_bar.set_xticks([])
            lim = 100 * max(np.abs(table["rel_error"]).max(), 1e-6) * 1.1
            ax_bar.set_ylim(-lim, lim)
            if k == 0:
                ax_bar.set_ylabel("error [%]", fontsize=8)
            else:
                ax_bar.set_yticklabels([])
    fig.suptitle(f"model - measured (RMS {100 * comparison.rms_rel_error:.3g} %)", fontsize=10)
    fig.tight_layout()
    _save(fig, path)


def plot_point_map(comparison, specimen: Specimen, path: Path) -> None:
    """Share of the misfit a point mass would explain, at every node of the plate."""
    plt = _pyplot()
    xy = comparison.node_xy
    fig, ax = plt.subplots(figsize=(4.6, 4.2 * specimen.width / specimen.length + 0.4))
    sc = ax.tricontourf(1e3 * xy[:, 0], 1e3 * xy[:, 1], 100 * comparison.point_map, levels=20, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="misfit explained [%]")
    for hint in comparison.point_mass_hints[:1]:
        ax.plot(1e3 * hint["xy"][0], 1e3 * hint["xy"][1], "r+", ms=12)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal")
    ax.set_title("where would a point mass explain the errors?", fontsize=9)
    fig.tight_layout()
    _save(fig, path)


def plot_before_after(before, after, label: str, path: Path) -> None:
    """|relative error| per measured mode without and with the effect."""
    plt = _pyplot()
    table = before.measurements.table
    names = [f"{c}\n{m}" for c, m in zip(table["configuration"], table["mode"])]
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(max(6, 0.45 * len(names) + 1.5), 3.6))
    ax.bar(x - 0.2, 100 * np.abs(before.rel_error), 0.4, label=f"baseline (RMS {100 * before.rms_rel_error:.3g} %)")
    ax.bar(x + 0.2, 100 * np.abs(after.rel_error), 0.4, label=f"with {label} (RMS {100 * after.rms_rel_error:.3g} %)")
    if before.measurements.has_std:
        ax.plot(x, 100 * table["std_hz"] / table["frequency_hz"], "k_", ms=10, label="measurement std")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels(names, fontsize=6)
    ax.set_ylabel("|model - measured| / measured [%]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    _save(fig, path)
