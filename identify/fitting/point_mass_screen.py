"""Where a sensor may sit: point-mass starts screened over the whole plate on a
Rayleigh-Ritz model of the fit it is added to.

The residual scan (``patterns``) gives a mass's first-order share at each node; with
other physics still off by a few tenths of a percent, or close modes that a few grams
reorder, its best node can be far from the sensor (a real-like spruce plate: the scan's
starts ended at (57, 56) and (501, 161) mm, the sensor sits at (422, 189) mm).  The
screen instead solves every point of a grid of positions and masses on the fit's own
modes and rigid-body fields (``fem.solver.reduced_basis``: the state's K and M projected
once, the mass added as m V^T V with V their displacements there, one r x r eigenproblem
a point), and lets the
layer properties follow to first order (the residual's part outside the span of the
fit's Jacobian).  A start, not a result: the refit from it is a full solve.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla

from fem.model import MAX_SOLVED_MODES
from fem.solver.attachments import point_operators

from ..engine.objective import solving_model
from ..engine.result import FitResult
from ..engine.statistics import weighted_residuals
from .plausibility import plate_mass

#: Grid of positions: cell centres of this many cells along the plate's length and width.
POSITIONS = (24, 12)
#: Masses tried at each position, as shares of the plate's mass (a miniature sensor on a
#: heavy plate to a general-purpose one with cable on a light one).
MASS_SHARES = np.geomspace(1e-3, 0.08, 12)
#: Basis modes per solved mode (as ``engine.peak_screen``: a mass of a few % of the plate
#: moves its modes' shapes, which the state's own modes alone do not span).
BASIS_PER_MODE = 1.5
#: Two positions closer than this share of the plate's longer side are one start.
DISTINCT = 0.05


def screened_point_mass_starts(state: FitResult, count: int) -> tuple[dict, ...]:
    """The ``count`` best point-mass starts at distinct positions ({"xy", "mass_kg",
    "left"}: left the weighted sum of squares there with the layers followed to first
    order), best first; empty where the screen does not apply (a layerwise model, no
    Jacobian)."""
    data = state.measurements
    if state.jacobian is None or state.pairings is None or len(state.jacobian) != len(data):
        return ()
    solver = solving_model(state.model, data)
    basis = solver.with_options(modes=min(math.ceil(BASIS_PER_MODE * solver.options.modes), MAX_SOLVED_MODES))
    configurations = []
    table = data.table
    for name in data.configurations:
        solution = basis.solve(name)
        reduced = solution.reduced(rigid_body=True)
        if reduced is None:
            return ()
        rigid = solution.units.rigid_body_modes.shape[1]  # their Ritz values lead: zero, or a suspension's
        rows = np.flatnonzero(table["configuration"].to_numpy() == name)
        modes = rigid + state.pairings[name].indices
        k, m = reduced.matrices(basis.specimen.laminate(name))
        fields = np.hstack([solution.units.rigid_body_modes, solution.modes.shapes])
        configurations.append((rows, modes, k, m, solution.units, fields))
    q, _ = np.linalg.qr(state.jacobian)  # the layers (and effects) of the state, followed to first order
    specimen = state.model.specimen
    length, width = specimen.length, specimen.width
    xs = (np.arange(POSITIONS[0]) + 0.5) / POSITIONS[0] * length
    ys = (np.arange(POSITIONS[1]) + 0.5) / POSITIONS[1] * width
    masses = MASS_SHARES * plate_mass(specimen)
    scored = []
    model_hz = np.empty(len(data))
    for x in xs:
        for y in ys:
            displacements = []
            for _, _, _, _, units, shapes in configurations:
                dofs, rows_of = point_operators(units, x, y)
                v = np.stack([rows_of[f] @ shapes[dofs] for f in ("u", "v", "w")])
                displacements.append(v.T @ v)
            for mass in masses:
                for (rows, modes, k, m, _, _), vv in zip(configurations, displacements, strict=True):
                    eigenvalues = sla.eigh(k, m + mass * vv, eigvals_only=True, check_finite=False)
                    model_hz[rows] = np.sqrt(np.clip(eigenvalues[modes], 0.0, None)) / (2 * math.pi)
                r = weighted_residuals(model_hz, data)
                left = r - q @ (q.T @ r)
                scored.append((float(left @ left), x, y, mass))
    scored.sort()
    span = max(length, width)
    out: list[dict] = []
    for left, x, y, mass in scored:
        if all(_apart((x, y), start["xy"], length, width, DISTINCT * span) for start in out):
            out.append({"xy": (x, y), "mass_kg": mass, "left": left})
        if len(out) == count:
            break
    return tuple(out)


def _apart(a, b, length: float, width: float, distance: float) -> bool:
    """Positions further apart than ``distance``, folded by the plate's mirror symmetry."""
    fold = np.array([[abs(a[0] - length / 2), abs(a[1] - width / 2)],
                     [abs(b[0] - length / 2), abs(b[1] - width / 2)]])
    return float(np.hypot(*(fold[0] - fold[1]))) > distance


__all__ = ["screened_point_mass_starts"]
