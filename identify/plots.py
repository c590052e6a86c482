"""Plots of an identification and of model against measurement: convergence, residuals,
residuals with mode shapes, the point-mass map, the error per mode before and after an
effect is added.  Drawn with ``fem.plotting`` (never the global matplotlib state)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fem.model import SpecimenModel
from fem.plotting import new_figure, save_figure

from .report import residual_table


def plot_convergence(result, path: Path) -> None:
    """Parameters per material against iteration (paper Fig. 9) and RMS error (Fig. 3a)."""
    history = np.array([it.values for it in result.history])
    targets = list(dict.fromkeys(p.target for p in result.parameters))
    fig, axes = new_figure(1, len(targets) + 1, figsize=(4 * (len(targets) + 1), 3.6), squeeze=False)
    for ax, target in zip(axes[0], targets):
        for j, p in enumerate(result.parameters):
            if p.target == target:
                ax.plot(history[:, j] / result.values[j], marker="o", label=p.kind)
        ax.set_title(target)
        ax.set_xlabel("iteration")
        ax.set_ylabel("value / identified value")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    ax = axes[0, -1]
    ax.semilogy([max(it.rms_rel_error, 1e-16) for it in result.history], marker="o")
    ax.set_title("frequency misfit")
    ax.set_xlabel("iteration")
    ax.set_ylabel("RMS relative error")
    ax.grid(alpha=0.3)
    save_figure(fig, path)


def plot_residuals(result, path: Path) -> None:
    """Relative error per mode, grouped by configuration; error bars = 1 std when given."""
    table = residual_table(result.measurements, result.model_hz)
    configurations = list(dict.fromkeys(table["configuration"]))
    fig, ax = new_figure(figsize=(max(6, 0.5 * len(table) + 2), 3.6))
    width = 0.8 / len(configurations)
    for k, name in enumerate(configurations):
        rows = table[table["configuration"] == name]
        x = rows["mode"].to_numpy() + (k - (len(configurations) - 1) / 2) * width
        err = None
        if result.measurements.has_std:
            err = 100 * result.measurements.of(name)["std_hz"].to_numpy() / rows["measured_hz"].to_numpy()
        ax.bar(x, 100 * rows["rel_error"], width, yerr=err, label=name, capsize=2)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("mode")
    ax.set_ylabel("(model - measured) / measured [%]")
    ax.set_title(f"residuals (RMS {100 * result.rms_rel_error:.3g} %)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    save_figure(fig, path)


def plot_comparison(comparison, model: SpecimenModel, path: Path) -> None:
    """One row per configuration: relative error per measured mode, and each mode's shape
    (deflection w, nodal lines in black) above its bar."""
    table = comparison.table
    configurations = list(dict.fromkeys(table["configuration"]))
    n_modes = int(table.groupby("configuration").size().max())
    fig, axes = new_figure(2 * len(configurations), n_modes, figsize=(1.6 * n_modes + 1, 3.2 * len(configurations)),
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
    save_figure(fig, path, dpi=100)


def plot_point_map(comparison, model: SpecimenModel, path: Path) -> None:
    """Share of the misfit a point mass would explain, at every node of the plate."""
    specimen = model.specimen
    xy = comparison.node_xy
    fig, ax = new_figure(figsize=(4.6, 4.2 * specimen.width / specimen.length + 0.4))
    sc = ax.tricontourf(1e3 * xy[:, 0], 1e3 * xy[:, 1], 100 * comparison.point_map, levels=20, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="misfit explained [%]")
    for hint in comparison.point_mass_hints[:1]:
        ax.plot(1e3 * hint["xy"][0], 1e3 * hint["xy"][1], "r+", ms=12)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal")
    ax.set_title("where would a point mass explain the errors?", fontsize=9)
    save_figure(fig, path, dpi=100)


def plot_before_after(before, after, label: str, path: Path) -> None:
    """|relative error| per measured mode without and with the effect."""
    table = before.measurements.table
    names = [f"{c}\n{m}" for c, m in zip(table["configuration"], table["mode"])]
    x = np.arange(len(names))
    fig, ax = new_figure(figsize=(max(6, 0.45 * len(names) + 1.5), 3.6))
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
    save_figure(fig, path, dpi=100)
