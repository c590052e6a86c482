"""Plots of an identification and of model against measurement: convergence, residuals,
residuals with mode shapes, the point-mass map, the error per mode before and after an
effect is added.  Drawn with ``fem.plotting`` (never the global matplotlib state)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fem.model import SpecimenModel
from fem.plotting import new_figure, save_figure

from ..engine.objective import solving_model
from ..engine.parameters import UNITS, display
from .residuals import before_after_table, fit_residuals


def _row_names(table, labels=None) -> list[str]:
    """x labels: configuration, mode (label), frequency."""
    out = []
    for k, (c, m, f) in enumerate(zip(table["configuration"], table["mode"], table["measured_hz"])):
        mode = "-" if m is None or m != m else int(m)
        label = f" {labels[k]}" if labels is not None and labels[k] else ""
        out.append(f"{c}\nmode {mode}{label}\n{f:.1f} Hz")
    return out


def plot_convergence(result, path: Path) -> Path:
    """Per material (or effect) its parameters in their units against iteration (paper
    Fig. 9): moduli [GPa] on the left axis, other kinds on the right; and the RMS
    relative error [%] (Fig. 3a)."""
    history = np.array([it.values for it in result.history])
    iterations = [it.number for it in result.history]
    targets = list(dict.fromkeys(p.target for p in result.parameters))
    fig, axes = new_figure(1, len(targets) + 1, figsize=(4.2 * (len(targets) + 1), 3.8), squeeze=False)
    for ax, target in zip(axes[0], targets):
        right = None
        for j, p in enumerate(result.parameters):
            if p.target != target:
                continue
            unit = UNITS[p.kind][0]
            on = ax if unit == "GPa" else (right := right or ax.twinx())
            on.plot(
                iterations,
                [display(p, v) for v in history[:, j]],
                marker="o",
                ms=3,
                linestyle="-" if on is ax else "--",
                label=f"{p.kind}" + (f" [{unit}]" if unit else ""),
            )
        ax.set_title(target, fontsize=10)
        ax.set_xlabel("iteration")
        ax.set_ylabel("modulus [GPa]")
        handles = ax.get_legend_handles_labels()
        if right is not None:
            right.set_ylabel("other parameters (see legend)")
            extra = right.get_legend_handles_labels()
            handles = (handles[0] + extra[0], handles[1] + extra[1])
        ax.legend(*handles, fontsize=8)
        ax.grid(alpha=0.3)
    ax = axes[0, -1]
    ax.semilogy(iterations, [100 * max(it.rms_rel_error, 1e-14) for it in result.history], marker="o", ms=3)
    ax.set_title("frequency misfit", fontsize=10)
    ax.set_xlabel("iteration")
    ax.set_ylabel("RMS relative error [%]")
    ax.grid(alpha=0.3)
    return save_figure(fig, path)


def plot_residuals(result, path: Path) -> Path:
    """Signed error per measured frequency [%] with the measurement std as error bars,
    labelled by configuration, model mode, nodal pattern and frequency; left-out peaks
    as open markers at their nearest mode's error."""
    rows = fit_residuals(result)
    measured = rows["measured_hz"].to_numpy()
    std = None
    if result.measurements.has_std:
        source = result.peaks.measurements.table if result.peaks is not None else result.measurements.table
        std = 100 * source["std_hz"].to_numpy() / measured
    x = np.arange(len(rows))
    fig, ax = new_figure(figsize=(max(7.0, 0.55 * len(rows) + 2), 4.6))
    matched = rows["matched"].to_numpy(dtype=bool)
    colours = {name: f"C{k}" for k, name in enumerate(dict.fromkeys(rows["configuration"]))}
    for name, colour in colours.items():
        mask = (rows["configuration"] == name).to_numpy() & matched
        error = rows["rel_error"].to_numpy(dtype=float, na_value=np.nan)
        ax.errorbar(
            x[mask],
            100 * error[mask],
            yerr=None if std is None else std[mask],
            fmt="o",
            color=colour,
            capsize=3,
            label=name,
        )
    if (~matched).any():  # a left-out peak has no error; it is drawn at its nearest mode's
        nearest = result.peaks.model_hz / measured - 1
        ax.plot(
            x[~matched],
            100 * nearest[~matched],
            "o",
            mfc="none",
            color="grey",
            label="left out (nearest mode)",
        )
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x)
    ax.set_xticklabels(_row_names(rows, rows["label"].tolist()), fontsize=6.5, rotation=90)
    ax.set_ylabel("(model - measured) / measured [%]")
    ax.set_title(f"residuals (RMS {100 * result.rms_rel_error:.3g} %)", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    return save_figure(fig, path)


def plot_mode_shapes(result, path: Path) -> Path:
    """The model's mode paired with each measured one: deflection w over the plate with
    the nodal lines in black, titled by mode, pattern and frequency; one row per
    configuration."""
    rows = fit_residuals(result)
    rows = rows[rows["matched"]]
    configurations = list(dict.fromkeys(rows["configuration"]))
    n = int(rows.groupby("configuration").size().max())
    solver = solving_model(result.model, result.measurements)
    aspect = result.specimen.width / result.specimen.length
    fig, axes = new_figure(
        len(configurations),
        n,
        figsize=(1.9 * n + 0.5, (1.9 * aspect + 0.6) * len(configurations)),
        squeeze=False,
    )
    for r, name in enumerate(configurations):
        solution = solver.solve(name)
        units = solution.units
        w = solution.modes.shapes.reshape(units.mesh.n_nodes, -1, solution.modes.shapes.shape[1])[
            :, units.element_type.NODE_DOFS.index("w"), :
        ]
        grid = (units.mesh.ny + 1, units.mesh.nx + 1)
        group = rows[rows["configuration"] == name]
        for k in range(n):
            ax = axes[r, k]
            ax.axis("off")
            if k >= len(group):
                continue
            mode = int(group["mode"].iloc[k])
            shape = w[:, mode - 1].reshape(grid)
            _draw_shape(ax, units.mesh, shape)
            ax.set_title(
                f"{name if k == 0 else ''}\nmode {mode} {group['label'].iloc[k]}\n"
                f"{group['model_hz'].iloc[k]:.1f} Hz",
                fontsize=7,
            )
    return save_figure(fig, path, dpi=100)


def _draw_shape(ax, mesh, shape: np.ndarray) -> None:
    """A mode's deflection on the mesh nodes (ny + 1, nx + 1), at the nodes' positions (a
    graded mesh's edge rows are narrow), with its nodal lines in black."""
    ax.pcolormesh(mesh.x, mesh.y, shape, cmap="RdBu", shading="gouraud")
    ax.contour(mesh.x, mesh.y, shape, levels=[0], colors="k", linewidths=0.8)
    ax.set_aspect("equal")


def plot_comparison(comparison, model: SpecimenModel, path: Path) -> Path:
    """One row per configuration: relative error per measured mode, and each mode's shape
    (deflection w, nodal lines in black) above its bar."""
    table = comparison.table
    configurations = list(dict.fromkeys(table["configuration"]))
    n_modes = int(table.groupby("configuration").size().max())
    fig, axes = new_figure(
        2 * len(configurations),
        n_modes,
        figsize=(1.6 * n_modes + 1, 3.2 * len(configurations)),
        squeeze=False,
        gridspec_kw={"height_ratios": [1, 1.4] * len(configurations)},
    )
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
            shape = (
                solution.modes.shapes[:, indices[k]].reshape(units.mesh.n_nodes, -1)[:, w_index].reshape(grid)
            )
            _draw_shape(ax_shape, units.mesh, shape)
            ax_shape.set_title(
                f"{name}\nmode {rows['mode'].iloc[k]}" if k == 0 else f"mode {rows['mode'].iloc[k]}",
                fontsize=8,
            )
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
    return save_figure(fig, path, dpi=100)


def plot_point_map(comparison, model: SpecimenModel, path: Path) -> Path:
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
    return save_figure(fig, path, dpi=100)


def plot_before_after(before, after, label: str, path: Path) -> Path:
    """Signed error per measured mode [%] without and with the effect, with the
    measurement std as a band (a peak either fit left out has no bar there)."""
    rows = before_after_table(before, after)
    names = [
        f"{c}\nmode {'-' if m is None else m}"
        for c, m in zip(rows["configuration"], rows["mode"], strict=True)
    ]
    x = np.arange(len(names))
    fig, ax = new_figure(figsize=(max(7.0, 0.5 * len(names) + 2), 4.2))
    for shift, column, text, result in (
        (-0.2, "rel_error_before", "baseline", before),
        (0.2, "rel_error_after", f"with {label}", after),
    ):
        error = rows[column].to_numpy(dtype=float, na_value=np.nan)
        ax.bar(
            x + shift,
            np.nan_to_num(100 * error),
            0.4,
            label=f"{text} (RMS {100 * result.rms_rel_error:.3g} %)",
        )
    if before.measurements.has_std:
        table = before.peaks.measurements.table if before.peaks is not None else before.measurements.table
        std = 100 * table["std_hz"] / table["frequency_hz"]
        ax.errorbar(
            x,
            np.zeros_like(x, dtype=float),
            yerr=std,
            fmt="none",
            ecolor="k",
            capsize=3,
            label="measurement std",
        )
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x)
    ax.set_xticklabels(names, fontsize=7, rotation=90)
    ax.set_ylabel("(model - measured) / measured [%]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    return save_figure(fig, path, dpi=100)
