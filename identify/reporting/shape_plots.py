"""Plots of measured mode shapes against the model's: the MAC matrices, the measured
nodal lines over the model's, and the maps of where on the plate the shapes disagree.
Formats the shape correlations it is handed (``engine.pairing.ShapeCorrelation``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fem.plotting import new_figure, save_figure

from ..engine.pairing import shape_at_points


def shape_lines(correlations: dict) -> list[str]:
    """Text lines: per configuration the paired MACs and where the shapes fail most."""
    lines = []
    for name, c in correlations.items():
        macs = ", ".join(
            f"{f:.6g} Hz {m:.3f}" if np.isfinite(m) else f"{f:.6g} Hz -"
            for f, m in zip(c.measured_hz, c.paired_mac)
        )
        lines.append(f"  {name}: MAC with the paired mode: {macs}")
        if c.worst_point is None:
            lines.append(f"  {name}: no peak with a shape is paired: no map of where the shapes disagree")
            continue
        x, y = 1e3 * c.worst_point
        lines.append(
            f"  {name}: shapes disagree most at ({x:.0f}, {y:.0f}) mm (residual "
            f"{np.nanmax(c.residual):.2f} of the measured amplitude there; COMAC lowest "
            f"{np.nanmin(c.comac):.3f})"
        )
    return lines


def plot_mac_matrices(correlations: dict, path: Path) -> Path:
    """One panel per configuration: MAC of each measured shape (rows, by frequency) with
    each model mode (columns), the pairing used outlined."""
    names = list(correlations)
    fig, axes = new_figure(1, len(names), figsize=(4.2 * len(names), 3.8), squeeze=False)
    for ax, name in zip(axes[0], names):
        c = correlations[name]
        image = ax.imshow(c.mac, vmin=0, vmax=1, cmap="Greys", aspect="auto")
        for row, column in enumerate(c.paired):
            if column >= 0:
                ax.add_patch(_cell(row, column))
        ax.set_xticks(range(len(c.model_hz)))
        ax.set_xticklabels([f"{k + 1}" for k in range(len(c.model_hz))], fontsize=7)
        ax.set_yticks(range(len(c.measured_hz)))
        ax.set_yticklabels([f"{f:.1f}" for f in c.measured_hz], fontsize=7)
        ax.set_xlabel("model mode")
        ax.set_ylabel("measured peak [Hz]")
        ax.set_title(name, fontsize=10)
        fig.colorbar(image, ax=ax, label="MAC")
    return save_figure(fig, path, dpi=100)


def _cell(row: int, column: int):
    from matplotlib.patches import Rectangle

    return Rectangle((column - 0.5, row - 0.5), 1, 1, fill=False, edgecolor="tab:red", linewidth=1.5)


def plot_shape_maps(correlations: dict, length: float, width: float, path: Path) -> Path:
    """Per configuration, where on the plate the measured shapes disagree with the model's:
    the shape residual (``ShapeCorrelation.residual``) and the COMAC at the points
    measured, over the plate's outline, the worst point marked."""
    names = list(correlations)
    aspect = width / length
    fig, axes = new_figure(2, len(names), figsize=(4.0 * len(names), 2 * (3.4 * aspect + 0.9)), squeeze=False)
    for k, name in enumerate(names):
        c = correlations[name]
        for ax, values, title, cmap in (
            (axes[0, k], c.residual, "shape residual", "magma_r"),
            (axes[1, k], c.comac, "COMAC", "viridis"),
        ):
            x, y = 1e3 * c.xy[:, 0], 1e3 * c.xy[:, 1]
            drawn = _filled(ax, x, y, values, cmap)
            ax.plot([0, 1e3 * length, 1e3 * length, 0, 0], [0, 0, 1e3 * width, 1e3 * width, 0], "k-", lw=0.8)
            if c.worst_point is not None:
                ax.plot(*(1e3 * c.worst_point), "r+", ms=14, mew=2)
            ax.set_aspect("equal")
            ax.set_title(f"{name}: {title}", fontsize=9)
            ax.set_xlabel("x [mm]", fontsize=8)
            ax.set_ylabel("y [mm]", fontsize=8)
            fig.colorbar(drawn, ax=ax)
    return save_figure(fig, path, dpi=100)


def plot_shape_point_map(shape_map, correlations: dict, length: float, width: float, path: Path) -> Path:
    """Share of the measured shapes' residual a point mass would explain at each node
    (``fitting.patterns.ShapePointMap``), the points measured and the best node marked."""
    fig, ax = new_figure(figsize=(4.8, 4.2 * width / length + 0.5))
    drawn = _filled(ax, 1e3 * shape_map.xy[:, 0], 1e3 * shape_map.xy[:, 1], 100 * shape_map.share, "viridis")
    fig.colorbar(drawn, ax=ax, label="shape residual explained [%]")
    for c in correlations.values():
        ax.plot(1e3 * c.xy[:, 0], 1e3 * c.xy[:, 1], "w.", ms=3)
    hint = shape_map.hint()
    ax.plot(1e3 * hint["xy"][0], 1e3 * hint["xy"][1], "r+", ms=14, mew=2)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal")
    ax.set_title(
        f"where would a point mass explain the shapes? ({1e3 * hint['mass_kg']:.2g} g at the +)", fontsize=9
    )
    return save_figure(fig, path, dpi=100)


def plot_measured_shapes(estimate, path: Path) -> Path:
    """A roving-hammer test's shapes (``recordings.shapes.ShapeEstimate``, duck-typed):
    per mode the real part of its normalised shape over the points, its nodal lines
    dashed, titled by frequency, MPC and the points that found it."""
    n = len(estimate.modes)
    x, y = estimate.points["x_mm"].to_numpy(), estimate.points["y_mm"].to_numpy()
    aspect = max(np.ptp(y), 1.0) / max(np.ptp(x), 1.0)
    columns = min(n, 5)
    rows = -(-n // columns)
    fig, axes = new_figure(
        rows, columns, figsize=(2.3 * columns + 0.4, (2.3 * aspect + 0.7) * rows), squeeze=False
    )
    for k, ax in enumerate(axes.ravel()):
        ax.axis("off")
        if k >= n:
            continue
        shape = estimate.shapes[k].real
        _filled(ax, x, y, shape, "RdBu")
        try:
            ax.tricontour(x, y, shape, levels=[0], colors="k", linestyles="--", linewidths=0.8)
        except (ValueError, RuntimeError):
            pass  # too few points for a line
        ax.plot(x, y, "k.", ms=2)
        ax.set_aspect("equal")
        mode = estimate.modes.iloc[k]
        ax.set_title(
            f"{mode['frequency_hz']:.1f} Hz\nMPC {mode['mpc']:.3f}, {int(mode['points_found'])} points",
            fontsize=7,
        )
    return save_figure(fig, path, dpi=100)


def _filled(ax, x: np.ndarray, y: np.ndarray, values: np.ndarray, cmap: str):
    """Filled contours over the points where they span an area, else the points coloured."""
    ok = np.isfinite(values)
    try:
        return ax.tricontourf(x[ok], y[ok], values[ok], levels=12, cmap=cmap)
    except (ValueError, RuntimeError):  # too few points, or all on a line
        return ax.scatter(x[ok], y[ok], c=values[ok], cmap=cmap, s=40)


def plot_nodal_lines(correlations: dict, solutions: dict, path: Path) -> Path:
    """Per measured shape: the model's paired mode over the plate (deflection, its nodal
    lines black) and the measured shape's nodal lines (dashed red, from the points
    measured, turned to the model's sign); one row per configuration."""
    names = list(correlations)
    n = max(len(c.measured_hz) for c in correlations.values())
    mesh = next(iter(solutions.values())).units.mesh
    aspect = mesh.width / mesh.length
    fig, axes = new_figure(
        len(names), n, figsize=(1.9 * n + 0.5, (1.9 * aspect + 0.7) * len(names)), squeeze=False
    )
    for r, name in enumerate(names):
        c, solution = correlations[name], solutions[name]
        units = solution.units
        w_index = units.element_type.NODE_DOFS.index("w")
        grid = (units.mesh.ny + 1, units.mesh.nx + 1)
        shapes = c.shapes
        for k in range(n):
            ax = axes[r, k]
            ax.axis("off")
            if k >= len(shapes) or c.paired[k] < 0:
                continue
            j = c.paired[k]
            w = solution.modes.shapes[:, j].reshape(units.mesh.n_nodes, -1)[:, w_index].reshape(grid)
            ax.pcolormesh(units.mesh.x, units.mesh.y, w, cmap="RdBu", shading="gouraud")
            ax.contour(units.mesh.x, units.mesh.y, w, levels=[0], colors="k", linewidths=0.8)
            model = shape_at_points(solution, shapes[k])[:, j]
            measured = shapes[k].amplitude * np.exp(-1j * np.angle(np.vdot(model, shapes[k].amplitude)))
            try:
                ax.tricontour(
                    *shapes[k].xy.T,
                    measured.real,
                    levels=[0],
                    colors="tab:red",
                    linestyles="--",
                    linewidths=1.0,
                )
            except (ValueError, RuntimeError):
                pass  # too few points for a line
            ax.plot(*shapes[k].xy.T, "k.", ms=1.5)
            ax.set_aspect("equal")
            ax.set_title(
                f"{name if k == 0 else ''}\n{c.measured_hz[k]:.1f} Hz: mode {j + 1}\n"
                f"MAC {c.paired_mac[k]:.3f}",
                fontsize=7,
            )
    return save_figure(fig, path, dpi=100)


__all__ = [
    "plot_mac_matrices",
    "plot_measured_shapes",
    "plot_nodal_lines",
    "plot_shape_maps",
    "plot_shape_point_map",
    "shape_lines",
]
