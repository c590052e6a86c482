"""Mode shapes read the way a lab reads them: nodal-line patterns that do not depend on
the mesh or the plate theory.

A free plate's deflection w(x, y) is projected onto products of free-free beam functions
phi_i(x) psi_j(y) (Warburton's and Leissa's basis for free plates): phi_0 = 1 is the
translation, phi_1 the rotation, phi_k (k >= 2) the (k-1)-th bending mode of a free-free
beam, which has k nodes.  The coefficients are computed by Gauss quadrature of the FE
field, so they converge with the field, whatever the mesh, and w is the same with and
without transverse shear.

A mode's label names its dominant product by the nodal lines crossed along x and along
y, "(i,j)", as before; a mode that mixes two products about equally (the square plate's
ring and X modes, (2,0) + (0,2) and (2,0) - (0,2)) is labelled with both and the sign
that tells them apart.  Beam functions are signed so that phi_k(0) > 0.

A lab labels a mode the other way, by counting on the plate the nodal lines its
deflection crosses along x and along y (``nodal_line_counts``).  The two readings agree on
clean modes and part where a mode's lines bend: a skewed or curved line is one crossing
to the lab but spreads over several beam-function products.
"""

from __future__ import annotations

import math
import re
import weakref
from functools import lru_cache

import numpy as np
import scipy.sparse as sp

from ..elements.hermite_plate import _hermite_1d
from .assembly import UnitMatrices

#: Beam functions per direction (0 .. ORDER - 1 nodes): enough for modes with up to 9
#: nodal lines each way, i.e. the first 40 or so modes of a plate.
ORDER = 10
#: Gauss points per direction for the projection (exact for the beam functions'
#: polynomial part; the field is bicubic per element).
POINTS = 40
#: A second product whose share is at least this fraction of the dominant one's makes
#: the mode "mixed": both are named.
MIXED = 0.35
#: A labelled pattern is part of a mode when it holds at least this share of the mode's
#: shape: the share of a mixed label's second term (``MIXED`` of the first), so that both
#: members of a mixed pair carry the label of either term.
LABEL_SHARE = MIXED / (1 + MIXED)
#: Nodal lines are counted where the deflection is clear of them: signs are read where
#: |w| exceeds this fraction of the mode's largest (nearer a line, the interpolation and
#: a measurement's noise flip them).
NODAL_CLEAR = 0.05
#: Free-free beam eigenvalues beta L of the first bending modes (then (2n + 1) pi / 2).
_BETA = (4.730040745, 7.853204624, 10.995607838, 14.137165491, 17.278759657)


def _beta(n: int) -> float:
    """beta L of the n-th (1-based) free-free beam bending mode."""
    return _BETA[n - 1] if n <= len(_BETA) else (2 * n + 1) * math.pi / 2


def beam_functions(xi: np.ndarray, order: int = ORDER) -> np.ndarray:
    """Free-free beam functions at xi in [0, 1]: (order, len(xi)), L2-normalised on [0, 1],
    phi_k(0) > 0; phi_k has k nodes."""
    out = np.empty((order, xi.size))
    out[0] = 1.0
    out[1] = math.sqrt(3.0) * (1 - 2 * xi)
    for k in range(2, order):
        b = _beta(k - 1)
        # cosh + cos - s (sinh + sin), with cosh - s sinh written without cancellation:
        # ((1 - s) e^{b xi} + (1 + s) e^{-b xi}) / 2, 1 - s = (cos b - sin b - e^{-b}) / (sinh b - sin b).
        one_minus_s = (math.cos(b) - math.sin(b) - math.exp(-b)) / (math.sinh(b) - math.sin(b))
        s = 1.0 - one_minus_s
        out[k] = (
            one_minus_s * np.exp(b * xi) / 2
            + (1 + s) * np.exp(-b * xi) / 2
            + np.cos(b * xi)
            - s * np.sin(b * xi)
        )
    return out


@lru_cache(maxsize=1)
def _gauss() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, weights on [0, 1] and the normalised beam functions there."""
    g, w = np.polynomial.legendre.leggauss(POINTS)
    xi, weight = (g + 1) / 2, w / 2
    phi = beam_functions(xi)
    phi /= np.sqrt((phi**2) @ weight)[:, None]
    return xi, weight, phi


def deflection_operator(units: UnitMatrices, x: np.ndarray, y: np.ndarray) -> sp.csr_matrix:
    """Sparse (points, n_dofs) operator giving w at the points (x, y) [m] from a mode's
    DOFs (Hermite interpolation in the element holding each point)."""
    x, y = np.atleast_1d(np.asarray(x, dtype=float)), np.atleast_1d(np.asarray(y, dtype=float))
    mesh = units.mesh
    names = units.element_type.NODE_DOFS
    w_first, per_node = names.index("w"), len(names)
    ex, ey, s, t, hx, hy = mesh.cells(x, y)
    vx = _hermite_1d(s, hx)[0]  # (4, points)
    vy = _hermite_1d(t, hy)[0]
    rows, cols, data = [], [], []
    for i, j in units.element_type.CORNERS:
        node = (ey + j) * (mesh.nx + 1) + ex + i
        for d, (ax, ay) in enumerate(((0, 0), (1, 0), (0, 1), (1, 1))):
            rows.append(np.arange(x.size))
            cols.append(node * per_node + w_first + d)
            data.append(vx[2 * i + ax] * vy[2 * j + ay])
    return sp.csr_matrix(
        (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(x.size, units.n_dofs)
    )


def deflection_sampler(units: UnitMatrices) -> sp.csr_matrix:
    """w at the Gauss grid of the plate (x fastest outer, y inner: (POINTS^2, n_dofs)),
    kept while its unit set lives (a cache keyed strongly would keep the unit set)."""
    sampler = _SAMPLERS.get(units)
    if sampler is None:
        xi, _, _ = _gauss()
        x, y = np.meshgrid(xi * units.mesh.length, xi * units.mesh.width, indexing="ij")
        sampler = _SAMPLERS[units] = deflection_operator(units, x.ravel(), y.ravel())
    return sampler


_SAMPLERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _grid_deflection(units: UnitMatrices, shapes: np.ndarray) -> np.ndarray:
    """Each mode's w on the Gauss grid of the plate: (x, y, mode)."""
    return (deflection_sampler(units) @ shapes).reshape(POINTS, POINTS, -1)


def beam_coefficients(units: UnitMatrices, shapes: np.ndarray) -> np.ndarray:
    """Coefficients c[m, i, j] of each mode's deflection on phi_i(x) psi_j(y), normalised
    to unit length per mode (shares c^2 sum to 1 over the basis)."""
    _, weight, phi = _gauss()
    w = _grid_deflection(units, shapes)
    c = np.einsum("xym,ix,jy->mij", w, phi * weight, phi * weight, optimize=True)
    norm = np.sqrt(np.sum(c**2, axis=(1, 2)))
    return c / np.where(norm > 0, norm, 1.0)[:, None, None]


def _sign_changes(signs: np.ndarray) -> np.ndarray:
    """Sign changes along axis 1 of signs (lines, points, modes) in {-1, 0, 1}, zeros
    skipped: (lines, modes)."""
    n = signs.shape[1]
    at = np.where(signs != 0, np.arange(n)[None, :, None], -1)
    before = np.concatenate([np.full_like(at[:, :1], -1), np.maximum.accumulate(at, axis=1)[:, :-1]], axis=1)
    previous = np.where(before >= 0, np.take_along_axis(signs, np.maximum(before, 0), axis=1), 0)
    return np.sum((signs != 0) & (previous != 0) & (signs != previous), axis=1)


def nodal_line_counts(units: UnitMatrices, shapes: np.ndarray) -> np.ndarray:
    """The nodal lines each mode's deflection crosses along x and along y, as a lab counts
    them: (modes, 2) ints.  Signs of w on the Gauss grid where |w| > ``NODAL_CLEAR`` of
    the mode's largest, sign changes per grid line, the median (rounded down) over the
    lines."""
    w = _grid_deflection(units, shapes)
    peak = np.abs(w).max(axis=(0, 1))
    signs = np.where(np.abs(w) > NODAL_CLEAR * peak, np.sign(w), 0).astype(np.int8)
    along_x = _sign_changes(np.transpose(signs, (1, 0, 2)))  # lines of constant y
    along_y = _sign_changes(signs)
    return np.floor(np.stack([np.median(along_x, axis=0), np.median(along_y, axis=0)], axis=1)).astype(int)


def in_plane(units: UnitMatrices, shape: np.ndarray) -> bool:
    """True for a mode whose in-plane motion outweighs its deflection."""
    nodal = shape.reshape(units.mesh.n_nodes, -1)
    names = units.element_type.NODE_DOFS
    w = nodal[:, names.index("w")]
    uv = nodal[:, [names.index("u"), names.index("v")]]
    return bool(np.sum(uv**2) > np.sum(w**2))


def label_of(coefficients: np.ndarray) -> str:
    """'(i,j)' of the dominant product, or '(i,j)+(k,l)' / '(i,j)-(k,l)' when a second
    one holds at least ``MIXED`` of its share (the pair ordered by index)."""
    share = coefficients**2
    order = np.argsort(-share, axis=None)
    first, second = (np.unravel_index(k, share.shape) for k in order[:2])
    if share[second] < MIXED * share[first]:
        return f"({first[0]},{first[1]})"
    a, b = sorted([first, second])
    sign = "+" if coefficients[a] * coefficients[b] > 0 else "-"
    return f"({a[0]},{a[1]}){sign}({b[0]},{b[1]})"


_TERM = re.compile(r"\(\s*(\d+)\s*,\s*(\d+)\s*\)")
_LABEL = re.compile(r"^\s*\(\s*\d+\s*,\s*\d+\s*\)\s*(?:([+-])\s*\(\s*\d+\s*,\s*\d+\s*\)\s*)?$")


def pattern(label: str, order: int = ORDER) -> np.ndarray | None:
    """A label as a unit coefficient pattern (order, order), or None when it is not of
    the form '(i,j)' or '(i,j)+(k,l)' / '(i,j)-(k,l)' with indices below ``order``."""
    match = _LABEL.match(label)
    if not match:
        return None
    terms = [(int(i), int(j)) for i, j in _TERM.findall(label)]
    if any(i >= order or j >= order for i, j in terms):
        return None
    out = np.zeros((order, order))
    out[terms[0]] = 1.0
    if len(terms) == 2:
        out[terms[1]] += 1.0 if match.group(1) == "+" else -1.0
    return out / np.linalg.norm(out)


def single_term(label: str) -> tuple[int, int] | None:
    """(i, j) of a label '(i,j)' with one term, None for a mixed or malformed label."""
    match = _LABEL.match(label)
    if not match or match.group(1):
        return None
    ((i, j),) = _TERM.findall(label)
    return int(i), int(j)


def affinity(coefficients: np.ndarray, label_pattern: np.ndarray) -> np.ndarray:
    """How well each mode (coefficients (m, order, order)) shows a labelled pattern: the
    squared cosine between them, 0..1 (a MAC on the beam-function basis)."""
    return np.einsum("mij,ij->m", coefficients, label_pattern) ** 2


def label_shares(coefficients: np.ndarray, mode_labels, label: str) -> np.ndarray:
    """Each mode's share in a label's pattern (``affinity``), 0 for a mode labelled
    'in-plane': the normalised projection of its small deflection can show any pattern (a
    cross-ply's in-plane mode under bonded aluminium is 95 % '(3,1)')."""
    shares = affinity(coefficients, pattern(label))
    return np.where(np.asarray(mode_labels) == "in-plane", 0.0, shares)


__all__ = [
    "beam_functions",
    "beam_coefficients",
    "deflection_operator",
    "in_plane",
    "label_of",
    "pattern",
    "affinity",
    "label_shares",
    "nodal_line_counts",
    "single_term",
    "ORDER",
    "NODAL_CLEAR",
    "LABEL_SHARE",
]
