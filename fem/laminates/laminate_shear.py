"""Transverse shear stiffness of a laminate for first-order shear deformation theory.

The three coefficients ``SHEAR_COEFFICIENTS`` = A44, A55, A45 [N/m] relate the shear
resultants to the transverse shear strains (Voigt 4 = yz, 5 = xz):
[Q_y, Q_x] = [[A44, A45], [A45, A55]] [gamma_yz, gamma_xz].

Shear correction: energy equivalence with the through-thickness shear stress of
cylindrical bending (Whitney 1973, J. Appl. Mech. 40:302-304; Vlachoutsis 1992,
Int. J. Numer. Meth. Eng. 33:1537-1552).  For bending along x with zero membrane
force, sigma_x = Qb11(z) (z - z_n) M / D*, with z_n = B11 / A11 and
D* = D11 - B11^2 / A11; equilibrium gives tau_xz(z) = -(Q_x / D*) g(z) with
g(z) = int_{-H/2}^{z} Qb11 (zeta - z_n) dzeta.  Equating the shear energy
int tau^2 / Qb55 dz to Q_x^2 / A55 gives

    A55 = D*^2 / int g^2 / Qb55 dz,   k55 = A55 / int Qb55 dz,

likewise A44, k44 with Qb22, Qb44 (bending along y), and A45 = sqrt(k44 k55) int Qb45 dz
(the usual K4 K5 rule of first-order laminate theory, e.g. Reddy, Mechanics of Laminated
Composite Plates and Shells, 2nd ed. 2004).
A homogeneous plate gets k = 5/6 exactly.

The functions here work on per-layer arrays; complex arrays are allowed, which gives
exact derivatives by complex-step (forward-mode) differentiation: Im f(x + i h dx) / h
involves no subtraction, and its truncation error, O(h^2), is nil at h = 1e-30, so it is
exact to rounding (Squire and Trapp 1998, SIAM Review 40:110-112).
"""

from __future__ import annotations

import math

import numpy as np

SHEAR_COEFFICIENTS = ("A44", "A55", "A45")
#: Gauss-Legendre points per layer: exact for g(z)^2, a quartic within a layer.
_GAUSS = np.polynomial.legendre.leggauss(3)
#: Complex step [relative to the inputs' own units]: second-order term (1e-60) is nil.
COMPLEX_STEP = 1e-30


def rotated_shear_moduli(g13: float, g23: float, angle: float, derivative: bool = False) -> np.ndarray:
    """Off-axis transverse shear stiffness [Qb44, Qb55, Qb45] [Pa] of a ply whose axis 1 is
    at ``angle`` [rad] from x; with ``derivative`` its exact d/d(angle) [Pa/rad]."""
    m, n = math.cos(angle), math.sin(angle)
    if derivative:
        return np.array([2 * m * n * (g13 - g23), -2 * m * n * (g13 - g23), (m * m - n * n) * (g13 - g23)])
    return np.array([g23 * m * m + g13 * n * n, g13 * m * m + g23 * n * n, (g13 - g23) * m * n])


def _energy_equivalent(thickness: np.ndarray, axial: np.ndarray, shear: np.ndarray):
    """D*^2 / int g^2 / G dz for one bending direction: axial = Qb11 (or Qb22), shear =
    Qb55 (or Qb44) per layer (last axis; leading axes are stacks evaluated at once).
    Returns the shear stiffness [N/m]."""
    z = (
        np.concatenate([np.zeros_like(thickness[..., :1]), np.cumsum(thickness, axis=-1)], axis=-1)
        - np.sum(thickness, axis=-1, keepdims=True) / 2
    )
    a = np.sum(axial * thickness, axis=-1, keepdims=True)
    b = np.sum(axial * np.diff(z**2, axis=-1), axis=-1, keepdims=True) / 2
    d = np.sum(axial * np.diff(z**3, axis=-1), axis=-1, keepdims=True) / 3
    z_n = b / a
    d_star = (d - b * b / a)[..., 0]
    # g at the bottom of each layer, then inside it at the Gauss points.
    step = axial * np.diff((z - z_n) ** 2, axis=-1) / 2
    g_bottom = np.concatenate([np.zeros_like(step[..., :1]), np.cumsum(step, axis=-1)[..., :-1]], axis=-1)
    points, weights = _GAUSS
    z_q = z[..., :-1, None] + thickness[..., None] * (points + 1) / 2
    z_n = z_n[..., None]
    g = g_bottom[..., None] + axial[..., None] * ((z_q - z_n) ** 2 - (z[..., :-1, None] - z_n) ** 2) / 2
    integral = np.sum((g * g) @ weights * thickness / (2 * shear), axis=-1)
    return d_star * d_star / integral


def shear_stiffness(
    thickness: np.ndarray, q11: np.ndarray, q22: np.ndarray, shear_moduli: np.ndarray
) -> np.ndarray:
    """[A44, A55, A45] [N/m] of a stack: thickness [m], Qb11, Qb22 [Pa] per layer, and
    shear_moduli (N, 3) [Qb44, Qb55, Qb45] per layer [Pa].  Leading axes on every input
    (thickness (B, N), shear_moduli (B, N, 3), ...) are stacks evaluated at once: (B, 3)."""
    raw = np.sum(thickness[..., None] * shear_moduli, axis=-2)  # int Qb44, Qb55, Qb45 dz
    a44 = _energy_equivalent(thickness, q22, shear_moduli[..., 0])
    a55 = _energy_equivalent(thickness, q11, shear_moduli[..., 1])
    a45 = np.sqrt(a44 / raw[..., 0] * a55 / raw[..., 1]) * raw[..., 2]
    return np.stack([a44, a55, a45], axis=-1)


def shear_correction_factors(
    thickness: np.ndarray, q11: np.ndarray, q22: np.ndarray, shear_moduli: np.ndarray
):
    """(k44, k55): the shear correction factors of the stack [-] (5/6 when homogeneous)."""
    a = shear_stiffness(thickness, q11, q22, shear_moduli)
    raw = thickness @ shear_moduli
    return float(a[0] / raw[0]), float(a[1] / raw[1])


def shear_stiffness_derivative(
    inputs: tuple[np.ndarray, ...], directions: tuple[np.ndarray, ...]
) -> np.ndarray:
    """Exact directional derivative of ``shear_stiffness(*inputs)`` along ``directions``
    (the inputs' shapes, or with a leading axis of several directions: one row each), by
    complex step."""
    perturbed = (
        np.asarray(x, dtype=complex) + 1j * COMPLEX_STEP * np.asarray(dx) for x, dx in zip(inputs, directions)
    )
    return shear_stiffness(*perturbed).imag / COMPLEX_STEP
