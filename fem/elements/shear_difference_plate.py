"""Locking-free rectangular Reissner-Mindlin (FSDT) laminate element.

Hierarchic "shear-difference" parametrisation (Echter, Oesterle and Bischoff 2013, "A
hierarchic family of isogeometric shell finite elements", CMAME 254:170-180): the
section rotations are the Kirchhoff rotations of a C1 deflection plus independent
transverse shear strains,

    beta_x = -w_x + g_x,   beta_y = -w_y + g_y,   gamma_xz = g_x,   gamma_yz = g_y,

so the curvatures are [-w_xx + g_x,x, -w_yy + g_y,y, -2 w_xy + g_x,y + g_y,x].  The
Kirchhoff limit g = 0 is contained exactly in the discrete space, so a thin plate cannot
lock: as the shear stiffness grows, the solution tends to the Kirchhoff element's
(``HermitePlate``), whose u, v, w interpolation this element shares.  The shear strains
use the same bicubic Hermite basis (C1, Q3 per element), so every strain converges at
the Kirchhoff element's rate and eigenvalues keep O(h^4).
"""

from __future__ import annotations

import numpy as np

from .hermite_plate import HermitePlate, MatrixQuadrature, Quadrature


class ShearDifferencePlate(HermitePlate):
    """Four-node rectangle, 20 DOFs per node (80 per element): u, v, w as in
    ``HermitePlate`` plus the transverse shear strains g_x = gamma_xz, g_y = gamma_yz.

    Unit stiffness matrices: the 18 CLT coefficients (A, B, D) and then the three
    transverse shear coefficients A44, A55, A45 (``laminate_shear.SHEAR_COEFFICIENTS``).
    """

    FIELDS = ("u", "v", "w", "gx", "gy")
    NODE_DOFS = HermitePlate.NODE_DOFS + ("gx", "gx_x", "gx_y", "gx_xy", "gy", "gy_x", "gy_y", "gy_xy")

    def strain_operators(self) -> tuple[np.ndarray, np.ndarray]:
        """Membrane and curvature operators at the quadrature points, each (nq, 3, 80)."""
        membrane, kirchhoff = super().strain_operators()
        shear_part = np.stack(
            [
                self._field("Nx", "gx"),
                self._field("Ny", "gy"),
                self._field("Ny", "gx") + self._field("Nx", "gy"),
            ],
            axis=1,
        )
        return membrane, kirchhoff + shear_part

    def shear_strain_operator(self) -> np.ndarray:
        """[gamma_yz, gamma_xz] at the quadrature points (nq, 2, 80) (Voigt 4, 5)."""
        return np.stack([self._field("N", "gy"), self._field("N", "gx")], axis=1)

    def unit_stiffness(self, pairs, quadrature: Quadrature | None = None) -> np.ndarray:
        """(21, 80, 80): the 18 CLT unit matrices, then A44, A55, A45 (their quadratic
        forms (21, k) with an ``EnergyQuadrature``)."""
        integral = quadrature or MatrixQuadrature(self.weights)
        gamma = integral.operator(self.shear_strain_operator())
        k45 = integral(gamma[:, 0], gamma[:, 1])
        shear = [integral(gamma[:, 0], gamma[:, 0]), integral(gamma[:, 1], gamma[:, 1]), k45 + k45.T]
        return np.concatenate([super().unit_stiffness(pairs, integral), shear])

    def rotations(self) -> tuple[np.ndarray, np.ndarray]:
        """Section rotations (beta_x, beta_y) = -grad w + (g_x, g_y), each (nq, 80)."""
        bx, by = super().rotations()
        return bx + self._field("N", "gx"), by + self._field("N", "gy")
