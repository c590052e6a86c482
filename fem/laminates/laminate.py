"""Classical lamination theory: ply stiffness, off-axis transformation, A, B, D and
mass terms of a stack, and their exact derivatives (paper eq. 5).

The reference surface is the geometric mid-plane of the whole stack, z from -H/2
(bottom) to +H/2 (top).  Stiffness coefficients are ordered as ``COEFFICIENTS``:
the 18 numbers ``X`` such that the plate stiffness matrix is ``K = sum_c X_c K_c``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import SpecError
from .laminate_shear import (
    rotated_shear_moduli,
    shear_correction_factors,
    shear_stiffness,
    shear_stiffness_derivative,
)
from .material import ELASTIC_CONSTANTS, SHEAR_MODULI, Material

#: Index pairs (in Voigt 1, 2, 6 notation mapped to 0, 1, 2) of the six coefficients per matrix.
VOIGT_PAIRS = ((0, 0), (0, 1), (1, 1), (2, 2), (0, 2), (1, 2))
_PAIR_NAMES = ("11", "12", "22", "66", "16", "26")
#: Names of the 18 laminate stiffness coefficients, in the order used everywhere.
COEFFICIENTS = tuple(f"{m}{p}" for m in "ABD" for p in _PAIR_NAMES)

# Off-axis transformation Qbar6 = T(theta) @ [Q11, Q12, Q22, Q66] written as
# polynomials in m = cos(theta), n = sin(theta): entry -> [(coefficient, power of m, power of n)].
_T_POLY = (
    (((1, 4, 0),), ((2, 2, 2),), ((1, 0, 4),), ((4, 2, 2),)),  # Qb11
    (((1, 2, 2),), ((1, 4, 0), (1, 0, 4)), ((1, 2, 2),), ((-4, 2, 2),)),  # Qb12
    (((1, 0, 4),), ((2, 2, 2),), ((1, 4, 0),), ((4, 2, 2),)),  # Qb22
    (((1, 2, 2),), ((-2, 2, 2),), ((1, 2, 2),), ((1, 4, 0), (-2, 2, 2), (1, 0, 4))),  # Qb66
    (((1, 3, 1),), ((-1, 3, 1), (1, 1, 3)), ((-1, 1, 3),), ((-2, 3, 1), (2, 1, 3))),  # Qb16
    (((1, 1, 3),), ((-1, 1, 3), (1, 3, 1)), ((-1, 3, 1),), ((-2, 1, 3), (2, 3, 1))),  # Qb26
)


def transformation(angle: float, derivative: bool = False) -> np.ndarray:
    """T(theta) (6 x 4) mapping on-axis [Q11, Q12, Q22, Q66] to the six off-axis
    reduced stiffnesses; with ``derivative`` its exact derivative d/dtheta [1/rad]."""
    m, n = math.cos(angle), math.sin(angle)
    out = np.zeros((6, 4))
    for i, row in enumerate(_T_POLY):
        for j, terms in enumerate(row):
            for c, a, b in terms:
                if derivative:  # d(m^a n^b)/dtheta with dm = -n, dn = m
                    da = a * m ** (a - 1) * n ** (b + 1) if a else 0.0
                    db = b * m ** (a + 1) * n ** (b - 1) if b else 0.0
                    out[i, j] += c * (-da + db)
                else:
                    out[i, j] += c * m**a * n**b
    return out


def plane_stress_stiffness(E1, E2, G12, nu12) -> np.ndarray:
    """[Q11, Q12, Q22, Q66] [Pa] of moduli that may be complex (E*(1 + i eta): the complex
    eigenproblem's) with a real Poisson ratio."""
    delta = 1.0 - nu12**2 * E2 / E1
    return np.array([E1 / delta, nu12 * E2 / delta, E2 / delta, G12])


def reduced_stiffness(material: Material) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """On-axis plane-stress stiffness [Q11, Q12, Q22, Q66] [Pa] and its derivatives
    with respect to E1, E2, G12 [1] and nu12 [Pa]."""
    E1, E2, G12, nu = material.E1, material.E2, material.G12, material.nu12
    delta = 1.0 - nu**2 * E2 / E1
    numerator = np.array([E1, nu * E2, E2])
    q = plane_stress_stiffness(E1, E2, G12, nu)
    d_numerator = {"E1": [1.0, 0, 0], "E2": [0, nu, 1.0], "G12": [0, 0, 0], "nu12": [0, E2, 0]}
    d_delta = {"E1": nu**2 * E2 / E1**2, "E2": -(nu**2) / E1, "G12": 0.0, "nu12": -2 * nu * E2 / E1}
    dq = {}
    for p in ELASTIC_CONSTANTS:
        d = np.asarray(d_numerator[p]) / delta - numerator * d_delta[p] / delta**2
        dq[p] = np.append(d, 1.0 if p == "G12" else 0.0)
    return q, dq


@dataclass(frozen=True)
class Layer:
    """One ply: a material, a thickness [m] and a material-axis angle [rad] from x.

    ``label`` names the layer in parameters and reports, e.g. ``"specimen[1]"``.
    """

    material: Material
    thickness: float
    angle: float = 0.0
    label: str = ""

    def __post_init__(self):
        if not (math.isfinite(self.thickness) and self.thickness > 0):
            raise SpecError(
                f"layer '{self.label or self.material.name}': thickness = {self.thickness!r} m "
                "must be positive"
            )

    @cached_property
    def off_axis_stiffness(self) -> np.ndarray:
        """Qbar [Q11, Q12, Q22, Q66, Q16, Q26] in the plate axes [Pa]."""
        q, _ = reduced_stiffness(self.material)
        return transformation(self.angle) @ q

    @cached_property
    def off_axis_derivatives(self) -> dict[str, np.ndarray]:
        """d Qbar / dp in the plate axes for p = E1, E2, G12 [1], nu12 [Pa] and the angle
        [Pa/rad]: computed once per layer, read by every parameter's derivative."""
        q, dq = reduced_stiffness(self.material)
        out = {p: transformation(self.angle) @ dq[p] for p in ELASTIC_CONSTANTS}
        out["angle"] = transformation(self.angle, derivative=True) @ q
        return out

    @cached_property
    def shear_moduli(self) -> np.ndarray:
        """Transverse shear stiffness [Qb44, Qb55, Qb45] in the plate axes [Pa] (G13, G23
        defaulted to G12 when not given: ``Material.transverse_shear_moduli``)."""
        return rotated_shear_moduli(*self.material.transverse_shear_moduli, self.angle)


@dataclass(frozen=True)
class Laminate:
    """A stack of layers, bottom to top."""

    layers: tuple[Layer, ...]

    def __post_init__(self):
        if not self.layers:
            raise SpecError("laminate: the layer list is empty; give at least one layer")

    @cached_property
    def thickness(self) -> float:
        """Total thickness H [m]."""
        return float(sum(layer.thickness for layer in self.layers))

    @cached_property
    def interfaces(self) -> np.ndarray:
        """z of the N+1 layer interfaces, bottom to top [m]."""
        t = np.array([layer.thickness for layer in self.layers])
        return np.concatenate([[0.0], np.cumsum(t)]) - self.thickness / 2

    @cached_property
    def _moments(self) -> np.ndarray:
        """Per layer the through-thickness integrals of 1, z, z^2: (N, 3) [m, m^2, m^3]."""
        z = self.interfaces
        return np.stack([np.diff(z), np.diff(z**2) / 2, np.diff(z**3) / 3], axis=1)

    @cached_property
    def stiffness(self) -> np.ndarray:
        """The 18 coefficients X (A [N/m], B [N], D [N m]) in ``COEFFICIENTS`` order."""
        qbar = np.array([layer.off_axis_stiffness for layer in self.layers])  # (N, 6)
        return np.einsum("kq,km->mq", qbar, self._moments).ravel()

    @cached_property
    def inertia(self) -> np.ndarray:
        """[I0, I1, I2]: integrals of rho, rho z, rho z^2 over the thickness."""
        rho = np.array([layer.material.density for layer in self.layers])
        return rho @ self._moments

    def matrices(self) -> dict[str, np.ndarray]:
        """A, B, D as symmetric 3x3 arrays (Voigt order 1, 2, 6)."""
        out = {}
        for block, name in enumerate("ABD"):
            mat = np.zeros((3, 3))
            for (i, j), value in zip(VOIGT_PAIRS, self.stiffness[6 * block : 6 * block + 6]):
                mat[i, j] = mat[j, i] = value
            out[name] = mat
        return out

    def derivative(self, kind: str, target: str) -> tuple[np.ndarray, np.ndarray]:
        """Exact derivatives (dX/dp, dI/dp) of stiffness coefficients and inertia terms.

        kind: one of E1, E2, G12, nu12, density (``target`` = material name) or
        thickness [per m], angle [per rad] (``target`` = layer label).  Returns
        zeros when the target is not in this stack.
        """
        n_layers = len(self.layers)
        d_qbar = np.zeros((n_layers, 6))
        d_moments = np.zeros((n_layers, 3))
        d_rho = np.zeros(n_layers)
        for k, layer in enumerate(self.layers):
            if kind in ELASTIC_CONSTANTS and layer.material.name == target:
                d_qbar[k] = layer.off_axis_derivatives[kind]
            elif kind == "density" and layer.material.name == target:
                d_rho[k] = 1.0
            elif kind == "angle" and layer.label == target:
                d_qbar[k] = layer.off_axis_derivatives["angle"]
        if kind == "thickness":
            hit = [k for k, layer in enumerate(self.layers) if layer.label == target]
            if hit:
                # z_i = -H/2 + sum_{k<i} t_k, so dz_i/dt_j = [j < i] - 1/2.
                j = hit[0]
                dz = (np.arange(n_layers + 1) > j).astype(float) - 0.5
                z = self.interfaces
                d_moments = np.stack([np.diff(dz), np.diff(z * dz), np.diff(z**2 * dz)], axis=1)
        elif kind not in ELASTIC_CONSTANTS + SHEAR_MODULI + ("density", "angle"):
            raise ValueError(f"unknown parameter kind {kind!r}")
        qbar = np.array([layer.off_axis_stiffness for layer in self.layers])
        rho = np.array([layer.material.density for layer in self.layers])
        dX = np.einsum("kq,km->mq", d_qbar, self._moments) + np.einsum("kq,km->mq", qbar, d_moments)
        dI = d_rho @ self._moments + rho @ d_moments
        return dX.ravel(), dI

    @property
    def _shear_inputs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per-layer thickness, Qb11, Qb22 and [Qb44, Qb55, Qb45]: the arguments of
        ``laminate_shear.shear_stiffness``."""
        qbar = np.array([layer.off_axis_stiffness for layer in self.layers])
        t = np.array([layer.thickness for layer in self.layers])
        return t, qbar[:, 0], qbar[:, 2], np.array([layer.shear_moduli for layer in self.layers])

    @cached_property
    def shear_stiffness(self) -> np.ndarray:
        """Transverse shear coefficients [A44, A55, A45] [N/m] with the laminate shear
        correction (``laminate_shear``), in ``SHEAR_COEFFICIENTS`` order."""
        return shear_stiffness(*self._shear_inputs)

    @property
    def shear_correction(self) -> tuple[float, float]:
        """The laminate's shear correction factors (k44, k55) [-]; 5/6 when homogeneous."""
        return shear_correction_factors(*self._shear_inputs)

    @property
    def defaulted_shear_moduli(self) -> dict[str, tuple[str, ...]]:
        """Material name -> the transverse shear moduli it lacks, set to its G12, for
        every material of the stack that lacks any (for reports)."""
        out = {}
        for layer in self.layers:
            if layer.material.defaulted_shear_moduli:
                out[layer.material.name] = layer.material.defaulted_shear_moduli
        return out

    def shear_derivative(self, kind: str, target: str) -> np.ndarray:
        """Exact d[A44, A55, A45]/dp for the parameter kinds of ``derivative`` plus G13, G23.

        A defaulted G13 or G23 follows G12, so it enters the G12 derivative.  Zeros when
        the target is not in this stack or the kind does not act on transverse shear.
        """
        return self.shear_derivatives([(kind, target)])[0]

    def shear_derivatives(self, parameters) -> np.ndarray:
        """``shear_derivative`` of every (kind, target) of ``parameters`` at once (P, 3): one
        complex-step pass whose batch holds every direction."""
        inputs = self._shear_inputs
        directions = [self._shear_direction(kind, target, inputs) for kind, target in parameters]
        return shear_stiffness_derivative(inputs, tuple(np.stack(d) for d in zip(*directions)))

    def _shear_direction(self, kind: str, target: str, inputs) -> tuple[np.ndarray, ...]:
        """d(thickness, Qb11, Qb22, [Qb44, Qb55, Qb45])/dp per layer, closed form."""
        if kind not in ELASTIC_CONSTANTS + SHEAR_MODULI + ("density", "angle", "thickness"):
            raise ValueError(f"unknown parameter kind {kind!r}")
        d_t, d_q11, d_q22, d_shear = (np.zeros_like(x) for x in inputs)
        for k, layer in enumerate(self.layers):
            material = layer.material
            if kind in ELASTIC_CONSTANTS + SHEAR_MODULI and material.name == target:
                if kind in ELASTIC_CONSTANTS:
                    d_qbar = layer.off_axis_derivatives[kind]
                    d_q11[k], d_q22[k] = d_qbar[0], d_qbar[2]
                follows = [
                    kind == name or (kind == "G12" and name in material.defaulted_shear_moduli)
                    for name in SHEAR_MODULI
                ]
                d_shear[k] = rotated_shear_moduli(*map(float, follows), layer.angle)
            elif kind == "angle" and layer.label == target:
                d_qbar = layer.off_axis_derivatives["angle"]
                d_q11[k], d_q22[k] = d_qbar[0], d_qbar[2]
                d_shear[k] = rotated_shear_moduli(
                    *material.transverse_shear_moduli, layer.angle, derivative=True
                )
            elif kind == "thickness" and layer.label == target:
                d_t[k] = 1.0
        return d_t, d_q11, d_q22, d_shear
