"""Virtual experiments: measurements computed by the model itself (paper section 2.2)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from fem.model import SpecimenModel, with_bending_modes
from fem.solver.complex_modes import complex_loss_factors
from fem.solver.damping import ratio_from_loss
from fem.solver.mode_shapes import deflection_operator

from ..measurements import MeasuredShapes, Measurements, ModeShape, parse_measurements

#: A roving-hammer grid keeps this fraction of the plate's size clear of each edge (the
#: hammer cannot hit the very edge squarely).
GRID_MARGIN = 0.05


def grid_points(length: float, width: float, grid: tuple[int, int]) -> np.ndarray:
    """(nx * ny, 2) points [m] of an evenly spaced roving-hammer grid, ``GRID_MARGIN`` in
    from the edges, x fastest."""
    x = np.linspace(GRID_MARGIN * length, (1 - GRID_MARGIN) * length, grid[0])
    y = np.linspace(GRID_MARGIN * width, (1 - GRID_MARGIN) * width, grid[1])
    xx, yy = np.meshgrid(x, y)
    return np.column_stack([xx.ravel(), yy.ravel()])


def _measured_shape(
    solution, mode: int, xy: np.ndarray, rng, noise_rel: float, hammer_std: float
) -> np.ndarray:
    """A mode's deflection at the grid as a roving-hammer test gives it: each hit lands
    ``hammer_std`` [m] (std per direction) off its grid point, the response carries noise
    of ``noise_rel`` of the largest amplitude (real and imaginary part each), and the
    scale and sign are arbitrary."""
    hit = xy + hammer_std * rng.standard_normal(xy.shape)
    hit = np.clip(hit, 0.0, [solution.units.mesh.length, solution.units.mesh.width])
    w = deflection_operator(solution.units, hit[:, 0], hit[:, 1]) @ solution.modes.shapes[:, mode]
    noise = noise_rel * np.abs(w).max() * (rng.standard_normal(len(w)) + 1j * rng.standard_normal(len(w)))
    return rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2.0) * (w + noise)


@dataclass(frozen=True)
class AlsoMeasured:
    """What a virtual experiment measures besides the frequencies (by default nothing).

    damping_std_rel: when given, each mode's damping ratio from the complex eigenproblem of
    the materials' loss factors (``fem.solver.complex_modes``), with Gaussian noise of this
    relative std [-] (also written as ``damping_std`` when > 0).
    shape_grid: when given (nx, ny), every mode's shape measured on that roving-hammer
    grid (``grid_points``, ``_measured_shape``), with noise of ``shape_noise_rel`` [-] of
    the largest amplitude, each hit landing ``hammer_std_mm`` [mm] (std per direction)
    off its grid point.
    """

    damping_std_rel: float | None = None
    shape_grid: tuple[int, int] | None = None
    shape_noise_rel: float = 0.0
    hammer_std_mm: float = 0.0


def synthetic_measurements(
    truth: SpecimenModel,
    modes: int = 5,
    noise_rel: float = 0.0,
    seed: int = 0,
    labels: str = "none",
    also: AlsoMeasured = AlsoMeasured(),
) -> Measurements:
    """The first ``modes`` elastic bending frequencies of every configuration of ``truth``
    (the model that generates the data: its specimen, mesh and effects; for some
    configurations only, ``truth.with_configurations(...)``), and what ``also`` says.  A
    test that measures the deflection does not see a mode that moves in the plate's plane
    (a thick sandwich's membrane modes): such modes are passed over, as the updating's
    pairing passes them over (``ModePairing.initial``).

    noise_rel: relative std of Gaussian noise added (also written as ``std_hz`` when > 0).
    labels: "none", "close" (nodal-line labels of modes within 1 % of a neighbour, as a lab
    would identify close modes by their shapes) or "all".
    """
    solver = truth.with_options(modes=max(modes, truth.options.modes))
    specimen = truth.specimen
    rng = np.random.default_rng(seed)
    # its own stream: shapes leave the frequencies' noise as it was
    shape_rng = np.random.default_rng([seed, 1])
    rows, shapes = [], []
    xy = None if also.shape_grid is None else grid_points(specimen.length, specimen.width, also.shape_grid)
    for c in specimen.configurations:
        solving = with_bending_modes(solver, [c.name], solver.options.modes)
        solution = solving.solve(c.name)
        seen = np.flatnonzero(~solution.moves_in_plane)[:modes]
        f = solution.frequencies_hz[seen]
        close = np.zeros(modes, dtype=bool)
        gaps = np.diff(f) / f[:-1] < 0.01
        close[:-1] |= gaps
        close[1:] |= gaps
        noisy = f * (1 + noise_rel * rng.standard_normal(modes))
        for i in range(modes):
            row = {"configuration": c.name, "mode": i + 1, "frequency_hz": noisy[i]}
            if noise_rel > 0:
                row["std_hz"] = noise_rel * f[i]
            if labels == "all" or (labels == "close" and close[i]):
                row["label"] = solution.labels[seen[i]]
            rows.append(row)
            if xy is not None:
                shapes.append(
                    ModeShape(
                        c.name,
                        float(noisy[i]),
                        xy,
                        _measured_shape(
                            solution, seen[i], xy, shape_rng, also.shape_noise_rel, 1e-3 * also.hammer_std_mm
                        ),
                    )
                )
        if also.damping_std_rel is not None:
            zeta = ratio_from_loss(complex_loss_factors(solving, c.name)[seen])
            noisy_zeta = zeta * (1 + also.damping_std_rel * rng.standard_normal(modes))
            for row, z, z_noisy in zip(rows[-modes:], zeta, noisy_zeta):
                row["damping_ratio"] = z_noisy
                if also.damping_std_rel > 0:
                    row["damping_std"] = also.damping_std_rel * z
    frame = pd.DataFrame(rows)
    if labels != "none" and "label" not in frame:
        frame["label"] = ""
    # Noise can reorder two close modes; ranks follow the measured order.
    frame = frame.sort_values(["configuration", "frequency_hz"], kind="stable")
    frame["mode"] = frame.groupby("configuration").cumcount() + 1
    measurements = parse_measurements(frame, truth, "<synthetic>")
    return (
        replace(measurements, shapes=MeasuredShapes(tuple(shapes), "<synthetic>")) if shapes else measurements
    )
