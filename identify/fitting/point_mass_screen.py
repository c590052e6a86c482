"""Where a sensor may sit: point-mass starts screened over the whole plate on a
Rayleigh-Ritz model of the fit it is added to.

The residual scan (``patterns``) gives a mass's first-order share at each node; with
other physics still off by a few tenths of a percent, or close modes that a few grams
reorder, its best node can be far from the sensor (a real-like spruce plate: the scan's
starts ended at (57, 56) and (501, 161) mm, the sensor sits at (422, 189) mm).  The
screen instead solves every point of a grid of positions and masses on the fit's own
modes and rigid-body fields (``fem.solver.reduced_basis.Reanalysis``: the state's K and M projected
once, the mass added as m V^T V with V their displacements there, one r x r eigenproblem
a point), and lets the
layer properties follow to first order (the residual's part outside the span of the
fit's Jacobian).  A start, not a result: the refit from it is a full solve.  Any plate
theory: the layerwise reanalysis projects the stack's unit matrices as the single-layer
one does (a layerwise fit had only the residual scan's starts, and blind156's 9.7 g
sensor on a 10.4 mm sandwich refitted to an implausible 10.8 g at 0.42 %; with the
screen 8.3 g at its mirror image, 0.25 %).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla

from fem.solver.attachments import PointMass, projected_attachments
from fem.solver.reduced_basis import Reanalysis

from ..engine.objective import solving_model
from ..engine.peak_screen import ritz_basis
from ..engine.result import FitResult
from ..engine.statistics import weighted_residuals
from .plausibility import plate_mass

#: Grid of positions: cell centres of this many cells along the plate's length and width.
POSITIONS = (24, 12)
#: Masses tried at each position, as shares of the plate's mass (a miniature sensor on a
#: heavy plate to a general-purpose one with cable on a light one).
MASS_SHARES = np.geomspace(1e-3, 0.08, 12)
#: Two positions closer than this share of the plate's longer side are one start.
DISTINCT = 0.05


class PointMassScreen:
    """The Ritz model of ``state`` (every configuration) on which a point mass at any
    position is scored (``score``) and the plate searched (``best``)."""

    def __init__(self, state: FitResult):
        self.data = data = state.measurements
        # The basis of the peak screen (1.5 x the solved modes): a mass of a few % of the
        # plate moves the shapes, which the state's own modes alone do not span.
        basis = ritz_basis(solving_model(state.model, data))
        self.configurations = []
        table = data.table
        for name in data.configurations:
            reduced = Reanalysis.of(basis, name)
            rows = np.flatnonzero(table["configuration"].to_numpy() == name)
            k, m = reduced.matrices(basis.specimen)
            # The rigid-body Ritz values lead (zero, or a suspension's): the paired modes follow them.
            modes = reduced.rigid + state.pairings[name].indices
            self.configurations.append((rows, modes, k, m, reduced.base.units, reduced.basis))
        self.q, _ = np.linalg.qr(state.jacobian)  # the state's parameters, followed to first order
        self.specimen = state.model.specimen

    @classmethod
    def of(cls, state: FitResult) -> PointMassScreen | None:
        """The screen of ``state`` (any plate theory, the layerwise one included); None
        where it does not apply (no Jacobian or pairing)."""
        if state.jacobian is None or state.pairings is None or len(state.jacobian) != len(state.measurements):
            return None
        return cls(state)

    def _squares(self, x: float, y: float) -> list[np.ndarray]:
        """Per configuration, V^T V of the basis displacements at (x, y) [m]: the projected
        mass of 1 kg there."""
        unit = (PointMass(1.0, x, y),)
        return [
            projected_attachments(units, fields, unit)[1] for _, _, _, _, units, fields in self.configurations
        ]

    def _left(self, squares, mass: float) -> float:
        model_hz = np.empty(len(self.data))
        for (rows, modes, k, m, _, _), vv in zip(self.configurations, squares, strict=True):
            eigenvalues = sla.eigh(k, m + mass * vv, eigvals_only=True, check_finite=False)
            model_hz[rows] = np.sqrt(np.clip(eigenvalues[modes], 0.0, None)) / (2 * math.pi)
        r = weighted_residuals(model_hz, self.data)
        left = r - self.q @ (self.q.T @ r)
        return float(left @ left)

    def score(self, x: float, y: float, mass: float) -> float:
        """The weighted sum of squares with a ``mass`` [kg] at (x, y) [m], the state's
        parameters followed to first order (the residual's part outside the span of its
        Jacobian)."""
        return self._left(self._squares(x, y), mass)

    def best(self, count: int) -> tuple[dict, ...]:
        """The ``count`` best starts ({"xy", "mass_kg", "left"}) at distinct positions
        over the ``POSITIONS`` grid and ``MASS_SHARES``, best first."""
        length, width = self.specimen.length, self.specimen.width
        masses = MASS_SHARES * plate_mass(self.specimen)
        scored = []
        for x in (np.arange(POSITIONS[0]) + 0.5) / POSITIONS[0] * length:
            for y in (np.arange(POSITIONS[1]) + 0.5) / POSITIONS[1] * width:
                squares = self._squares(x, y)
                scored += [(self._left(squares, mass), x, y, mass) for mass in masses]
        scored.sort()
        out: list[dict] = []
        for left, x, y, mass in scored:
            if all(
                _apart((x, y), start["xy"], length, width, DISTINCT * max(length, width)) for start in out
            ):
                out.append({"xy": (float(x), float(y)), "mass_kg": float(mass), "left": left})
            if len(out) == count:
                break
        return tuple(out)


def _apart(a, b, length: float, width: float, distance: float) -> bool:
    """Positions further apart than ``distance``, folded by the plate's mirror symmetry."""
    fold = np.array(
        [[abs(a[0] - length / 2), abs(a[1] - width / 2)], [abs(b[0] - length / 2), abs(b[1] - width / 2)]]
    )
    return float(np.hypot(*(fold[0] - fold[1]))) > distance


__all__ = ["PointMassScreen"]
