"""An independent model of a free rectangular plate for checking the test sheet: a
Rayleigh-Ritz solution of the Kirchhoff plate, written for the tests and sharing no code
with the project's finite elements.

w(x, y) = sum_mn a_mn P_m(xi) P_n(eta), Legendre polynomials of degree < ``order`` in
xi = 2x/L - 1, eta = 2y/W - 1: a complete basis with no boundary conditions imposed (the
free edges are natural).  Strain energy 1/2 int kappa^T D kappa dA with kappa = (w_xx,
w_yy, 2 w_xy) and the full 3 x 3 bending stiffness D (D16, D26 included); kinetic energy
1/2 omega^2 I0 int w^2 dA.  Gauss-Legendre quadrature with order + 4 points per direction
integrates both exactly.  The three zero-frequency modes (1, x, y) are dropped.

An unsymmetric (bonded) laminate is modelled with the reduced bending stiffness
D* = D - B A^-1 B, the bending stiffness with the membrane forces relaxed: an
approximation for a free plate (exact when the in-plane forces vanish everywhere).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from numpy.polynomial import legendre as leg
from threadpoolctl import threadpool_limits


def _tables(xi: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """P_m, P_m', P_m'' at xi: three (len(xi), order) arrays."""
    eye = np.eye(order)
    values = np.stack([leg.legval(xi, eye[m]) for m in range(order)], axis=1)
    first = np.stack([leg.legval(xi, leg.legder(eye[m])) for m in range(order)], axis=1)
    second = np.stack([leg.legval(xi, leg.legder(eye[m], 2)) for m in range(order)], axis=1)
    return values, first, second


def reduced_bending_stiffness(A: np.ndarray, B: np.ndarray, D: np.ndarray) -> np.ndarray:
    """D* = D - B A^-1 B (= D when B = 0)."""
    return D - B @ np.linalg.solve(A, B)


class RitzPlate:
    """Free-free Kirchhoff plate L x W [m] of bending stiffness ``D`` (3 x 3, Voigt 1, 2,
    6) [N m] and mass per area ``mass_per_area`` [kg/m^2], with ``point_masses``
    (mass [kg], x, y [m]) moving with w."""

    def __init__(
        self,
        length: float,
        width: float,
        D: np.ndarray,
        mass_per_area: float,
        order: int = 16,
        point_masses=(),
    ):
        self.length, self.width, self.order = length, width, order
        with threadpool_limits(1, "blas"):  # small dense algebra: threads only add overhead on busy cores
            self._solve(D, mass_per_area, point_masses)

    def _solve(self, D: np.ndarray, mass_per_area: float, point_masses) -> None:
        length, width, order = self.length, self.width, self.order
        points, weights = leg.leggauss(order + 4)
        P, dP, ddP = _tables(points, order)
        sx, sy = 2 / length, 2 / width
        q = points.size

        def product(a, b):  # (q x, q y, m, n) -> (q^2, order^2)
            return np.einsum("im,jn->ijmn", a, b).reshape(q * q, order * order)

        phi = product(P, P)
        curvatures = np.stack(
            [product(ddP * sx**2, P), product(P, ddP * sy**2), 2 * product(dP * sx, dP * sy)], axis=1
        )  # (points, 3, dofs)
        area_weight = np.outer(weights, weights).ravel() * length * width / 4
        moments = np.einsum("ij,pjb->pib", D, curvatures)  # D kappa per basis function
        K = (curvatures * area_weight[:, None, None]).reshape(-1, order * order).T @ moments.reshape(
            -1, order * order
        )
        M = mass_per_area * (phi * area_weight[:, None]).T @ phi
        for mass, x, y in point_masses:  # kinetic energy m w(x, y)^2 / 2 (its in-plane motion left out)
            at = np.einsum(
                "m,n->mn",
                _tables(np.array([2 * x / length - 1]), order)[0][0],
                _tables(np.array([2 * y / width - 1]), order)[0][0],
            ).ravel()
            M = M + mass * np.outer(at, at)
        K = (K + K.T) / 2
        eigenvalues, vectors = sla.eigh(K, M)
        self.eigenvalues, self.vectors = eigenvalues[3:], vectors[:, 3:]  # drop the rigid-body modes

    @property
    def frequencies_hz(self) -> np.ndarray:
        return np.sqrt(np.abs(self.eigenvalues)) / (2 * np.pi)

    def field(self, x, y, modes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """w, dw/dx, dw/dy (points, modes) at the points (x, y) [m]."""
        Px, dPx, _ = _tables(2 * np.asarray(x, dtype=float) / self.length - 1, self.order)
        Py, dPy, _ = _tables(2 * np.asarray(y, dtype=float) / self.width - 1, self.order)
        c = self.vectors[:, list(modes)].reshape(self.order, self.order, -1)
        w = np.einsum("pm,pn,mnk->pk", Px, Py, c, optimize=True)
        wx = np.einsum("pm,pn,mnk->pk", dPx * 2 / self.length, Py, c, optimize=True)
        wy = np.einsum("pm,pn,mnk->pk", Px, dPy * 2 / self.width, c, optimize=True)
        return w, wx, wy

    def grid(self, xs: np.ndarray, ys: np.ndarray, modes) -> np.ndarray:
        """w on the grid xs x ys: (len(xs), len(ys), modes)."""
        Px = _tables(2 * np.asarray(xs, dtype=float) / self.length - 1, self.order)[0]
        Py = _tables(2 * np.asarray(ys, dtype=float) / self.width - 1, self.order)[0]
        c = self.vectors[:, list(modes)].reshape(self.order, self.order, -1)
        return np.einsum("xm,mnk,yn->xyk", Px, c, Py, optimize=True)

    def peaks(self, modes, points: int = 201) -> np.ndarray:
        """Each mode's peak |w| over a ``points`` x ``points`` grid of the plate (edges included)."""
        w = self.grid(np.linspace(0, self.length, points), np.linspace(0, self.width, points), modes)
        return np.abs(w).max(axis=(0, 1))
