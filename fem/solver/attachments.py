"""Things attached to the plate at points: a sensor or glue mass, suspension springs.

A point mass m at (x, y) moves with the reference surface: it adds m (u^2 + v^2 + w^2) / 2
to the kinetic energy.  A sensor glued over a base (``PointMass.base``, the side of a
square footprint) spreads m evenly over it: the same energy integrated over the square
(Gauss points in each part of it that one element holds, exact for the cubic fields).  On a
shear-soft plate a mass at one point is singular (the deflection under a point load grows
without bound as the mesh refines, so the frequencies depend on the mesh); over a base it
is not.  A suspension is a set of equal springs k acting on w at given
points; it adds k w^2 / 2 each to the strain energy, so the three out-of-plane rigid-body
motions become low "suspension modes" (the in-plane ones stay free).

Exact eigenvalue derivatives for mass-normalised modes (over a base: weighted sums over
the footprint's points):
    d(lambda)/dm = -lambda |phi(x, y)|^2,  d(lambda)/dx = -lambda m d|phi|^2/dx,
    d(lambda)/dk = sum over points w(x_p, y_p)^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..elements.hermite_plate import _acm, _hermite_1d
from ..errors import SpecError
from .assembly import UnitMatrices

ATTACHMENT_PARAMETERS = ("mass", "x", "y", "stiffness")


#: Gauss points per direction in each part of a footprint that one element holds: the
#: fields are cubic in each direction, their squares of degree 6, which 4 points integrate
#: exactly (degree 7).
FOOTPRINT_GAUSS = 4


@dataclass(frozen=True)
class PointMass:
    """A mass [kg] at (x, y) [m] from the plate corner at the origin; ``base`` [m]: the side
    of the square it is spread over, centred there (0: a point)."""

    mass: float
    x: float
    y: float
    label: str = "point_mass"
    base: float = 0.0


@dataclass(frozen=True)
class Suspension:
    """Equal out-of-plane springs [N/m each] at the given points [m]."""

    stiffness: float
    points: tuple[tuple[float, float], ...]
    label: str = "suspension"


def check_attachment(attachment, length: float, width: float) -> None:
    """Reject negative masses or stiffnesses and points off the plate."""
    if isinstance(attachment, PointMass):
        if not (np.isfinite(attachment.mass) and attachment.mass >= 0):
            raise SpecError(
                f"point mass '{attachment.label}': mass = {attachment.mass!r} kg must not be negative"
            )
        if not (np.isfinite(attachment.base) and 0 <= attachment.base <= 0.5 * min(length, width)):
            raise SpecError(
                f"point mass '{attachment.label}': base = {1e3 * attachment.base:g} mm must be 0 (a point) "
                f"up to half the plate's shorter side ({500 * min(length, width):g} mm); it is the side "
                "of the sensor's square footprint in mm"
            )
        points = [(attachment.x, attachment.y)]
    else:
        if not (np.isfinite(attachment.stiffness) and attachment.stiffness >= 0):
            raise SpecError(
                f"suspension '{attachment.label}': stiffness = {attachment.stiffness!r} N/m "
                "must not be negative"
            )
        points = attachment.points
    for x, y in points:
        if not (0 <= x <= length and 0 <= y <= width):
            raise SpecError(
                f"'{attachment.label}': point ({1e3 * x:g}, {1e3 * y:g}) mm is outside the plate "
                f"(0..{1e3 * length:g} x 0..{1e3 * width:g} mm); coordinates are from the corner at the "
                "origin"
            )


def point_operators(units: UnitMatrices, x: float, y: float) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Global DOFs of the element holding (x, y) and the rows that evaluate each field and
    its x-, y-derivatives there: {"u": (n_local,), "u_x": ..., "w_y": ...}."""
    mesh = units.mesh
    ex, ey, s, t, hx, hy = (float(v) for v in mesh.cells(x, y))
    element = int(ey) * mesh.nx + int(ex)
    vx, dx, _ = (a[:, 0] for a in _hermite_1d(np.array([s]), hx))
    vy, dy, _ = (a[:, 0] for a in _hermite_1d(np.array([t]), hy))
    corners = units.element_type.CORNERS
    scalar = {"": [], "_x": [], "_y": []}
    for i, j in corners:
        for ax, ay in ((0, 0), (1, 0), (0, 1), (1, 1)):
            a, b = 2 * i + ax, 2 * j + ay
            scalar[""].append(vx[a] * vy[b])
            scalar["_x"].append(dx[a] * vy[b])
            scalar["_y"].append(vx[a] * dy[b])
    c0_fields = units.element_type.C0_FIELDS
    c0 = (
        dict(zip(scalar, (a[:, 0] for a in _acm(np.array([s]), np.array([t]), hx, hy)), strict=True))
        if c0_fields
        else {}
    )
    names = units.element_type.NODE_DOFS
    rows = {}
    for field in ("u", "v", "w"):
        first = names.index(field)
        on_c0 = field in c0_fields
        for suffix, values in (c0 if on_c0 else scalar).items():
            row = np.zeros((4, len(names)))
            row[:, first : first + (3 if on_c0 else 4)] = np.reshape(values, (4, -1))
            rows[field + suffix] = row.ravel()
    return units.element_dofs[element], rows


def _data_positions(units: UnitMatrices, dofs: np.ndarray) -> np.ndarray:
    """CSR data positions of the dense block dofs x dofs on the shared pattern."""
    indices, indptr, _ = units._pattern
    out = np.empty((len(dofs), len(dofs)), dtype=np.int64)
    for a, row in enumerate(dofs):
        columns = indices[indptr[row] : indptr[row + 1]]
        out[a] = indptr[row] + np.searchsorted(columns, dofs)
    return out


def base_square(mass: PointMass, length: float, width: float) -> tuple[float, float]:
    """The corner (x0, y0) [m] of a mass's square base of side ``mass.base`` centred on it,
    shifted inside a ``length`` x ``width`` plate where it would overhang an edge."""
    half = 0.5 * mass.base
    return (
        float(np.clip(mass.x - half, 0.0, length - mass.base)),
        float(np.clip(mass.y - half, 0.0, width - mass.base)),
    )


def footprint(units: UnitMatrices, mass: PointMass) -> list[tuple[float, float, float, bool, bool]]:
    """The points (x, y) [m] a mass is spread over and their shares of it (summing to 1):
    the point itself without a base; else ``FOOTPRINT_GAUSS`` x ``FOOTPRINT_GAUSS`` Gauss
    points in each part of the square that one element holds, the square shifted inside
    the plate where it would overhang an edge.  Also whether each point moves with x and
    with y (not where the square rests against an edge)."""
    if mass.base <= 0:
        return [(mass.x, mass.y, 1.0, True, True)]
    mesh, half = units.mesh, 0.5 * mass.base
    x0, y0 = base_square(mass, mesh.length, mesh.width)
    moves = (x0 == mass.x - half, y0 == mass.y - half)
    nodes, weights = np.polynomial.legendre.leggauss(FOOTPRINT_GAUSS)
    per_axis = []
    for start, lines in ((x0, mesh.x), (y0, mesh.y)):
        cuts = np.unique(
            np.concatenate([[start, start + mass.base], lines[(lines > start) & (lines < start + mass.base)]])
        )
        a, b = cuts[:-1, None], cuts[1:, None]
        per_axis.append(
            ((0.5 * (a + b) + 0.5 * (b - a) * nodes).ravel(), (0.5 * (b - a) * weights / mass.base).ravel())
        )
    (xs, wx), (ys, wy) = per_axis
    return [(float(x), float(y), float(a * b), *moves) for x, a in zip(xs, wx) for y, b in zip(ys, wy)]


def _point_terms(units: UnitMatrices, attachments):
    """Every point the attachments act at: (a mass or a spring, the DOFs of the element that
    holds it, the rows (k, n_local) that evaluate there the fields it acts on, its weight
    [kg or N/m]); each adds weight |rows @ field[dofs]|^2 / 2 to the kinetic or the strain
    energy (a mass over a base: one term per footprint point, weighted by its share)."""
    for attachment in attachments:
        if isinstance(attachment, PointMass):
            for x, y, share, _, _ in footprint(units, attachment):
                dofs, n = point_operators(units, x, y)
                yield True, dofs, np.stack([n[f] for f in ("u", "v", "w")]), share * attachment.mass
        else:
            for x, y in attachment.points:
                dofs, n = point_operators(units, x, y)
                yield False, dofs, n["w"][None, :], attachment.stiffness


def add_attachment_data(units: UnitMatrices, attachments, stiffness: np.ndarray, mass: np.ndarray) -> None:
    """Add the attachments' stiffness and mass to the CSR data ``stiffness`` and ``mass``
    (on the shared pattern, arrays the caller owns) in place, on their few entries only:
    two temporaries of the pattern's size and two sums over it made the data of a bonded
    layerwise cross-ply (19,380 DOFs, 9.7 M entries) 66 ms instead of 44.  Each entry gets
    the sum of its terms, in the order they come, added once: the same numbers as adding
    whole arrays of those sums."""
    terms = {True: ([], []), False: ([], [])}
    for is_mass, dofs, rows, weight in _point_terms(units, attachments):
        positions, values = terms[is_mass]
        positions.append(_data_positions(units, dofs).ravel())
        values.append((weight * sum(np.outer(row, row) for row in rows)).ravel())
    for target, (positions, values) in ((mass, terms[True]), (stiffness, terms[False])):
        if positions:
            entries, where = np.unique(np.concatenate(positions), return_inverse=True)
            sums = np.zeros(len(entries))
            np.add.at(sums, where, np.concatenate(values))
            target[entries] += sums


def projected_attachments(
    units: UnitMatrices, basis: np.ndarray, attachments
) -> tuple[np.ndarray, np.ndarray]:
    """The stiffness and mass the attachments add, projected on a basis V (n_dofs, r):
    (r, r) each, from the basis's values at their points (the terms of
    ``add_attachment_data``, on the few DOFs of the elements that hold them)."""
    rank = basis.shape[1]
    stiffness, mass = np.zeros((rank, rank)), np.zeros((rank, rank))
    for is_mass, dofs, rows, weight in _point_terms(units, attachments):
        values = rows @ basis[dofs]
        target = mass if is_mass else stiffness
        target += weight * (values.T @ values)
    return stiffness, mass


def eigenvalue_derivative(
    units: UnitMatrices, attachment, kind: str, shapes: np.ndarray, eigenvalues: np.ndarray
) -> np.ndarray:
    """d(omega^2)/dp of every mode for an attachment parameter (mass [kg], x, y [m],
    stiffness [N/m])."""
    if isinstance(attachment, PointMass):
        if kind not in ("mass", "x", "y"):
            raise SpecError(f"point mass '{attachment.label}' has no parameter {kind!r}; it has: mass, x, y")
        total = np.zeros(shapes.shape[1])
        for x, y, share, moves_x, moves_y in footprint(units, attachment):
            dofs, n = point_operators(units, x, y)
            local = shapes[dofs]
            if kind == "mass":
                total += share * sum((n[f] @ local) ** 2 for f in ("u", "v", "w"))
            elif moves_x if kind == "x" else moves_y:
                suffix = "_" + kind
                total += (
                    share
                    * attachment.mass
                    * sum(2 * (n[f] @ local) * (n[f + suffix] @ local) for f in ("u", "v", "w"))
                )
        return -eigenvalues * total
    if kind != "stiffness":
        raise SpecError(f"suspension '{attachment.label}' has no parameter {kind!r}; it has: stiffness")
    total = np.zeros(shapes.shape[1])
    for x, y in attachment.points:
        dofs, n = point_operators(units, x, y)
        total += (n["w"] @ shapes[dofs]) ** 2
    return total
