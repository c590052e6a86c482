"""Layerwise (zig-zag) laminate theory: shear groups, stretching soft layers, generalised
laminate coefficients and their exact derivatives, for ``fem.elements.LayerwisePlate``.

Kinematics (see the element for the references): with one transverse shear strain pair
(gx_k, gy_k) per *shear group* k of layers, and one transverse normal strain e_s per
*stretching* soft layer s,

    U = u - z w_x + sum_k Phi_k(z) gx_k - sum_s Lambda_s(z) e_s,x,
    V = v - z w_y + sum_k Phi_k(z) gy_k - sum_s Lambda_s(z) e_s,y,
    W = w + sum_s Psi_s(z) e_s,

Phi_k = int_0^z (1 in group k's layers), Psi_s = int_0^z (1 in layer s), Lambda_s =
int_0^z Psi_s: displacements are continuous, u, v, w are those of the mid-plane z = 0,
gamma_xz = g_k in group k (the Lambda terms cancel W_x exactly), and eps_z = e_s in layer s.
The in-plane strains are eps0 + z kappa + sum_k Phi_k kappa_k + sum_s Lambda_s chi_s with
kappa_k = grad-sym of g_k and chi_s = -[e_s,xx, e_s,yy, 2 e_s,xy].  Energies are linear in
generalised coefficients: for every pair (a <= b) of the through-thickness functions
f = [1, z, Phi_1..Phi_n, Lambda_1..Lambda_m], int Qbar f_a f_b (six each; the first three
pairs are A, B, D) and int rho f_a f_b; per group S_k = [A44, A55, A45]; per stretching
layer int E3 dz; and int rho Psi_s, int rho Psi_s Psi_t for the transverse inertia.

Shear groups (``layer_groups``).  "layers": one group per layer, the full layerwise
theory (the zig-zag of a cross-ply needs it: on the 3-D reference of a cross-ply bonded to
aluminium on a soft bond line, one group for the whole laminate is 0.11 % off, one per
ply 0.08 %).  "auto" (default): the same, except that adjacent layers of one material
and angle are one group, and that all layers which are not soft (``soft_layers``: much
softer in shear than another layer in the same plane, like a foam core or a bond line) and
carry less than ``RIGID_SHARE`` of the stack's shear compliance each (a sandwich's skins,
a bonded metal plate) share one group: their shear strains are negligible, and every
group costs 6 DOFs per node (a soft one 8, ``soft_groups``).  "blocks": soft layers
alone, each run of adjacent stiff layers one group (cheapest).  A single layer is one
group and never soft, and then the theory *is* the project's first-order shear
deformation theory (``ShearDifferencePlate``).

Stretching layers (``stretching_layers``).  A soft layer that carries most of the stack's
through-thickness compliance (``STRETCH_SHARE`` of int dz / E3: a foam core, not a thin
bond line) gets a transverse normal strain: in an unsymmetric stack (a sandwich with a
plate bonded on one side) the flexural modes squeeze the core, which the 3-D reference
shows lowers the bonded sandwich's modes by up to 0.23 % (a solid model with a 100x stiffer
core through the thickness, run for this check).  The through-thickness modulus is the
layer's E3 (a material attribute ``E3`` when it has one, else E2: exact for isotropic
cores and unidirectional plies; a honeycomb needs its own E3, or ``core_stretch = false``;
the ``layerwise`` effect holds it at an identified E2's start value,
``fem.effects.Layerwise.held_normal_moduli``).
Poisson coupling to the in-plane strains is neglected (the 3-D check: setting the foam's
nu13, nu23 to 0 moves the frequencies by at most 0.034 %), so the in-plane stiffness stays
the plane-stress Qbar.

Pinned structure.  The rules above are thresholds on the layers' moduli, which a fit
moves: blind33's fabric skins (G13 = 3.98 GPa at the start) became "soft" against the
bonded aluminium (26.3 GPa) once a fit took their G13 below 2.63 GPa, and its bonded
configurations went from 3 shear groups to 5 in mid-fit; the misfit jumped there and no
Ritz basis of the old structure could follow (every alternative of its final pairing
check left the basis: 99 full layerwise solves, 42 with the structure pinned).  A model
therefore fixes each stack's groups and stretching layers when it is made
(``fem.model.ModelOptions.layerwise_structure``, keyed by ``layout``), as it fixes its
mesh; a fit then moves one theory.

Shear correction.  A constant shear strain per group over-stiffens a thick layer (a
homogeneous plate would get k = 1).  Each group's shear stiffness is therefore made
energy-equivalent to the equilibrium (Jourawski) shear stress of the whole stack in
cylindrical bending, the distribution Whitney's laminate correction uses
(``fem.laminates.laminate_shear``; Whitney 1973, J. Appl. Mech. 40:302-304): with
g(z) = int_{-H/2}^z Qb11 (zeta - z_n) dzeta, tau = -(Q / D*) g,

    A55_k = (int_k g dz)^2 / int_k g^2 / Qb55 dz,

likewise A44_k with Qb22, Qb44 (bending along y), and A45_k = sqrt(k44_k k55_k) int_k Qb45.
Under a constant shear force Q (uniform g_k, plane-section bending stress) the theory's
equilibrium gives group k the shear force Q_k = (Q / D*) int_k g (the conjugate of g_k is
dM_k/dx with M_k = int sigma Phi_k dz), so with these stiffnesses its shear energy is the
Jourawski energy for *any* grouping; with one group A55 = D*^2 / int g^2 / Qb55 is
Whitney's (k = 5/6 for a homogeneous plate).  For a sandwich core k -> 1.

Derivatives.  Every coefficient is an analytic function of the layers' thickness, Qbar,
shear moduli, E3 and density; exact derivatives with respect to any parameter (E1, E2,
G12, nu12, G13, G23, density, thickness, angle) are complex-step directional derivatives
along the closed-form per-layer directions (``fem.laminates.laminate``), exact to rounding (Squire
and Trapp 1998, SIAM Review 40:110-112), as ``fem.laminates.laminate_shear`` does.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..elements.layerwise_plate import LayerwisePlate, basis_pairs
from ..errors import ModelError
from ..solver import assembly
from ..solver.assembly import UnitMatrices
from ..solver.mesh import PlateMesh
from .laminate import COEFFICIENTS, Laminate
from .laminate_shear import COMPLEX_STEP, rotated_shear_moduli
from .material import ELASTIC_CONSTANTS, SHEAR_MODULI, Material

#: Grouping rules of the layers into shear groups.
GROUPINGS = ("auto", "blocks", "layers")
#: A layer is "soft" when a transverse shear modulus (Qb44 or Qb55) is below this
#: fraction of the stack's largest in the same plane: a PVC foam (35 MPa) or a flexible
#: bond line (0.36 GPa) next to CFRP (3.5-5 GPa) or aluminium (26 GPa) is; carbon/glass
#: plies (3.2-5 GPa) next to aluminium are not.
SOFT_SHEAR_RATIO = 0.1
#: Stiff layers with less than this share of the stack's shear compliance int dz / G each
#: share one shear group under "auto" (a sandwich's skins: ~1e-3 each).
RIGID_SHARE = 0.05
#: A soft layer stretches through its thickness when it has at least this share of the
#: stack's transverse normal compliance int dz / E3 (a 6 mm foam core: 0.99; a 0.1 mm bond
#: line on a 5 mm laminate: 0.15).
STRETCH_SHARE = 0.25
#: Gauss-Legendre points per layer: exact to degree 7, so for the products of the
#: through-thickness functions (Lambda is cubic within a stretching layer: Lambda^2 is of
#: degree 6) and for g^2, a quartic, of the shear correction.
_GAUSS = np.polynomial.legendre.leggauss(4)


def normal_modulus(material: Material) -> float:
    """The through-thickness Young's modulus used for a stretching layer [Pa]: the
    material's ``E3`` when it has one, else E2 (transverse isotropy)."""
    value = getattr(material, "E3", None)
    return material.E2 if value is None else value


def soft_layers(laminate: Laminate) -> tuple[bool, ...]:
    """Per layer: much softer in transverse shear than the stiffest layer in the same
    plane, yz or xz (``SOFT_SHEAR_RATIO``).  Plane by plane, so a layer is never soft
    against itself: a single spruce layer's rolling shear (G23 ~ G13 / 16) made it "soft"
    against its own G13, which gave one homogeneous layer a stretching field (frequencies
    within 1e-5 of the first-order shear plate's, against the 3-D reference of
    ``tests/data/solid3d/spruce_plate``) and switched the model's structure wherever a fit
    moved G23 / G13 across the ratio."""
    moduli = np.array([layer.shear_moduli[:2] for layer in laminate.layers])  # Qb44, Qb55
    return tuple(bool(x) for x in (moduli < SOFT_SHEAR_RATIO * moduli.max(axis=0)).any(axis=1))


def stretching_layers(laminate: Laminate) -> tuple[int, ...]:
    """Indices of the soft layers with a transverse normal strain (``STRETCH_SHARE``)."""
    compliance = np.array([layer.thickness / normal_modulus(layer.material) for layer in laminate.layers])
    share = compliance / compliance.sum()
    return tuple(k for k, soft in enumerate(soft_layers(laminate)) if soft and share[k] >= STRETCH_SHARE)


def layer_groups(laminate: Laminate, grouping: str = "auto") -> tuple[int, ...]:
    """The shear group of every layer (bottom to top), numbered from 0 bottom up (rules in
    the module doc: "auto", "blocks", "layers")."""
    if grouping not in GROUPINGS:
        raise ModelError(f"layer grouping {grouping!r} is unknown; use one of {', '.join(GROUPINGS)}")
    layers = laminate.layers
    soft = soft_layers(laminate)
    groups = [0]
    for k in range(1, len(layers)):
        if grouping == "layers":
            same = False
        elif grouping == "blocks":
            same = not soft[k] and not soft[k - 1]
        else:
            same = (layers[k].material, layers[k].angle) == (layers[k - 1].material, layers[k - 1].angle)
        groups.append(groups[-1] + (0 if same else 1))
    if grouping == "auto":
        compliance = np.array([layer.thickness / min(layer.shear_moduli[:2]) for layer in layers])
        share = np.bincount(groups, compliance) / compliance.sum()
        rigid = {g for g, is_soft in zip(groups, soft) if not is_soft and share[g] < RIGID_SHARE}
        if len(rigid) > 1:
            groups = [min(rigid) if g in rigid else g for g in groups]
    order = {g: i for i, g in enumerate(dict.fromkeys(groups))}
    return tuple(order[g] for g in groups)


def soft_groups(laminate: Laminate, groups: tuple[int, ...]) -> tuple[int, ...]:
    """The shear groups that hold a soft layer (``soft_layers``).  Their shear strains keep
    the bicubic basis; the other groups' (and u, v) take the cheaper C0 one
    (``fem.elements.layerwise_plate``).  In a soft layer the shear strain follows the
    slope w_x (the section turns little, the core shears), and the skins' membrane strain
    is the difference of the two (c/2)(g_x - w_xx): with g on the C0 basis that difference
    is not in one space and converged at O(h^2) (blind03's foam sandwich, mode 6: 0.113 %
    off a mesh 1.5 x finer, 0.021 % with the core's group bicubic)."""
    soft = soft_layers(laminate)
    return tuple(sorted({g for g, is_soft in zip(groups, soft, strict=True) if is_soft}))


def layout(laminate: Laminate) -> tuple[tuple[str, str], ...]:
    """What a fit never moves in a stack: each layer's label and material name, bottom to
    top.  A layerwise model's shear groups and stretching layers are pinned per layout."""
    return tuple((layer.label, layer.material.name) for layer in laminate.layers)


def _function_names(n: int, m: int) -> list[str]:
    return ["1", "z"] + [f"Phi{k + 1}" for k in range(n)] + [f"Lambda{s + 1}" for s in range(m)]


def stiffness_names(n: int, m: int = 0) -> tuple[str, ...]:
    """Names of the generalised stiffness coefficients (n groups, m normal-strain fields,
    two per stretching layer), in unit-matrix order: A, B, D as ``COEFFICIENTS``, then
    int Qbar f_a f_b as 'Q[f_a,f_b]_ij', then 'S{k}_44', 'S{k}_55', 'S{k}_45', then
    int E3 p_j^2 dz as 'E3[j]' (p = 1 or xi)."""
    f = _function_names(n, m)
    names = list(COEFFICIENTS)
    for a, b in basis_pairs(2 + n + m)[3:]:
        names += [f"Q[{f[a]},{f[b]}]_{p[1:]}" for p in COEFFICIENTS[:6]]
    names += [f"S{k + 1}_{s}" for k in range(n) for s in ("44", "55", "45")]
    return tuple(names + [f"E3[{j + 1}]" for j in range(m)])


def inertia_names(n: int, m: int = 0) -> tuple[str, ...]:
    """Names of the generalised inertia terms, in unit-matrix order: I0, I1, I2, then
    int rho f_a f_b as 'R[f_a,f_b]', then int rho Psi_j and int rho Psi_i Psi_j."""
    f = _function_names(n, m)
    names = ["I0", "I1", "I2"] + [f"R[{f[a]},{f[b]}]" for a, b in basis_pairs(2 + n + m)[3:]]
    g = ["1"] + [f"Psi{j + 1}" for j in range(m)]
    return tuple(names + [f"R[{g[a]},{g[b]}]" for a, b in basis_pairs(1 + m)[1:]])


def _profiles(c0: np.ndarray, c1: np.ndarray, t: np.ndarray, z: np.ndarray, local: np.ndarray):
    """For functions whose slope in layer l is c0[l] + c1[l] h (h above the layer's bottom;
    c0, c1: (B, N, c), t: (B, N), z: (B, N + 1), local: (B, N, q); B points evaluated at
    once): P = int_0^z slope and L = int_0^z P at the Gauss points (B, N, q, c).
    Complex-step safe (the layer holding z = 0 is chosen on the real parts, which every
    point of a complex-step batch shares)."""
    tc = t[:, :, None]
    zeros = np.zeros((len(t), 1, c0.shape[2]), dtype=np.result_type(c0, c1, t))
    p_bottom = np.concatenate([zeros, np.cumsum(c0 * tc + c1 * tc**2 / 2, axis=1)], axis=1)
    l_bottom = np.concatenate(
        [zeros, np.cumsum(p_bottom[:, :-1] * tc + c0 * tc**2 / 2 + c1 * tc**3 / 6, axis=1)], axis=1
    )

    def inside(p_b, l_b, a, b, h):  # P and L at height h above a layer's bottom
        return p_b + a * h + b * h**2 / 2, l_b + p_b * h + a * h**2 / 2 + b * h**3 / 6

    k0 = min(int(np.searchsorted(np.real(z[0]), 0.0, side="right")) - 1, t.shape[1] - 1)
    p0, l0 = inside(p_bottom[:, k0], l_bottom[:, k0], c0[:, k0], c1[:, k0], -z[:, k0, None])
    p, lam = inside(
        p_bottom[:, :-1, None, :],
        l_bottom[:, :-1, None, :],
        c0[:, :, None, :],
        c1[:, :, None, :],
        local[..., None],
    )
    z_q = (z[:, :-1, None] + local)[..., None]
    return p - p0[:, None, None], lam - l0[:, None, None] - p0[:, None, None] * z_q


def _jourawski(t: np.ndarray, axial: np.ndarray, z: np.ndarray, z_q: np.ndarray) -> np.ndarray:
    """g(z) = int_{-H/2}^z axial (zeta - z_n) dzeta at the Gauss points (B, N, q)."""
    a = np.sum(axial * t, axis=1)
    z_n = (np.sum(axial * np.diff(z**2, axis=1), axis=1) / 2 / a)[:, None]
    step = axial * np.diff((z - z_n) ** 2, axis=1) / 2
    g_bottom = np.concatenate(
        [np.zeros((len(t), 1), dtype=step.dtype), np.cumsum(step, axis=1)[:, :-1]], axis=1
    )
    z_n = z_n[:, :, None]
    return g_bottom[:, :, None] + axial[:, :, None] * ((z_q - z_n) ** 2 - (z[:, :-1, None] - z_n) ** 2) / 2


def coefficients(
    groups: tuple[int, ...],
    stretch: tuple[int, ...],
    t: np.ndarray,
    qbar: np.ndarray,
    shear: np.ndarray,
    e3: np.ndarray,
    rho: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(stiffness, inertia) generalised coefficients (``stiffness_names``, ``inertia_names``
    order) from per-layer thickness t [m], Qbar (N, 6) [Pa], transverse shear moduli
    [Qb44, Qb55, Qb45] (N, 3) [Pa], through-thickness modulus E3 [Pa] and density
    [kg/m^3].  Complex inputs are allowed (complex-step derivatives).  With a leading
    batch axis on every input (t (B, N), Qbar (B, N, 6), ...) B stacks at once: the
    outputs get the same leading axis."""
    if np.ndim(t) == 1:
        stiffness, inertia = coefficients(groups, stretch, *(x[None] for x in (t, qbar, shear, e3, rho)))
        return stiffness[0], inertia[0]
    batch, n_layers, n, m = len(t), len(groups), max(groups) + 1, 2 * len(stretch)
    z = (
        np.concatenate([np.zeros((batch, 1), dtype=t.dtype), np.cumsum(t, axis=1)], axis=1)
        - np.sum(t, axis=1, keepdims=True) / 2
    )
    points, weights = _GAUSS
    local = t[:, :, None] * (points + 1) / 2  # height above each layer's bottom
    z_q = z[:, :-1, None] + local
    w_q = t[:, :, None] * weights / 2
    group_member = np.zeros((n_layers, n))
    group_member[np.arange(n_layers), groups] = 1.0
    member = np.broadcast_to(group_member, (batch, n_layers, n))
    phi, _ = _profiles(member, 0 * member, t, z, local)
    # Per stretching layer two normal strains: eps_z = e (constant) + f xi, xi = 2 h / t - 1.
    c0, c1 = np.zeros((batch, n_layers, m), dtype=t.dtype), np.zeros((batch, n_layers, m), dtype=t.dtype)
    for j, layer in enumerate(stretch):
        c0[:, layer, 2 * j], c0[:, layer, 2 * j + 1], c1[:, layer, 2 * j + 1] = 1.0, -1.0, 2.0 / t[:, layer]
    psi, lam = _profiles(c0, c1, t, z, local)
    in_plane = np.concatenate([np.ones_like(z_q)[..., None], z_q[..., None], phi, lam], axis=3)
    transverse = np.concatenate([np.ones_like(z_q)[..., None], psi], axis=3)
    moments = np.einsum("xlq,xlqa,xlqb->xlab", w_q, in_plane, in_plane)
    stiff = np.einsum("xlc,xlab->xabc", qbar, moments)
    mass = np.einsum("xl,xlab->xab", rho, moments)
    pairs = np.array(basis_pairs(in_plane.shape[3]))
    stiffness = stiff[:, pairs[:, 0], pairs[:, 1]].reshape(batch, -1)
    inertia = [mass[:, pairs[:, 0], pairs[:, 1]]]
    transverse_mass = np.einsum("xl,xlq,xlqa,xlqb->xab", rho, w_q, transverse, transverse)
    normal_pairs = np.array(basis_pairs(1 + m)[1:], dtype=int).reshape(-1, 2)
    inertia.append(transverse_mass[:, normal_pairs[:, 0], normal_pairs[:, 1]])
    # int Qb44, Qb55, Qb45 over each group
    raw = np.einsum("ln,xlc->xnc", group_member, t[:, :, None] * shear)
    corrected = []
    for axial, modulus in ((qbar[:, :, 2], shear[:, :, 0]), (qbar[:, :, 0], shear[:, :, 1])):
        g = _jourawski(t, axial, z, z_q)
        force = np.sum(g * w_q, axis=2) @ group_member  # int_k g dz
        energy = (np.sum(g * g * w_q, axis=2) / modulus) @ group_member  # int_k g^2 / G dz
        corrected.append(force * force / energy)
    a44, a55 = corrected
    a45 = np.sqrt(a44 / raw[:, :, 0] * a55 / raw[:, :, 1]) * raw[:, :, 2]
    index = np.array(stretch, dtype=int)
    normal = np.stack([e3[:, index] * t[:, index], e3[:, index] * t[:, index] / 3], axis=2)
    return (
        np.concatenate(
            [
                stiffness,
                np.stack([a44, a55, a45], axis=2).reshape(batch, -1),
                normal.reshape(batch, 2 * len(stretch)),
            ],
            axis=1,
        ),
        np.concatenate(inertia, axis=1),
    )


def _layer_inputs(laminate: Laminate):
    layers = laminate.layers
    return (
        np.array([l.thickness for l in layers]),
        np.array([l.off_axis_stiffness for l in layers]),
        np.array([l.shear_moduli for l in layers]),
        np.array([normal_modulus(l.material) for l in layers]),
        np.array([l.material.density for l in layers]),
    )


def _layer_directions(laminate: Laminate, kind: str, target: str):
    """d(t, Qbar, shear moduli, E3, rho)/dp per layer, closed form (zeros when p does not act)."""
    t, qbar, shear, e3, rho = (np.zeros_like(x) for x in _layer_inputs(laminate))
    if kind not in ELASTIC_CONSTANTS + SHEAR_MODULI + ("density", "angle", "thickness"):
        raise ValueError(f"unknown parameter kind {kind!r}")
    for k, layer in enumerate(laminate.layers):
        material = layer.material
        if kind in ELASTIC_CONSTANTS + SHEAR_MODULI and material.name == target:
            if kind in ELASTIC_CONSTANTS:
                qbar[k] = layer.off_axis_derivatives[kind]
            # A defaulted G13 or G23 follows G12, a defaulted E3 follows E2.
            follows = [
                kind == name or (kind == "G12" and name in material.defaulted_shear_moduli)
                for name in SHEAR_MODULI
            ]
            shear[k] = rotated_shear_moduli(*map(float, follows), layer.angle)
            e3[k] = float(kind == "E2" and getattr(material, "E3", None) is None)
        elif kind == "density" and material.name == target:
            rho[k] = 1.0
        elif kind == "angle" and layer.label == target:
            qbar[k] = layer.off_axis_derivatives["angle"]
            shear[k] = rotated_shear_moduli(*material.transverse_shear_moduli, layer.angle, derivative=True)
        elif kind == "thickness" and layer.label == target:
            t[k] = 1.0
    return t, qbar, shear, e3, rho


@dataclass(frozen=True)
class LayerwiseLaminate:
    """A laminate with its shear groups (one per layer, bottom to top) and its stretching
    layers: the generalised coefficients of the layerwise theory and their exact
    derivatives."""

    laminate: Laminate
    groups: tuple[int, ...]
    stretch: tuple[int, ...] = ()
    #: The shear groups of soft layers (``soft_groups``): their strains on the bicubic basis.
    soft: tuple[int, ...] = ()

    @classmethod
    def of(
        cls,
        laminate: Laminate,
        grouping: str = "auto",
        core_stretch: bool = True,
        structure: tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]] | None = None,
    ) -> LayerwiseLaminate:
        """The stack of ``laminate``: its shear groups, stretching layers and soft groups by
        the rules (``grouping``, ``core_stretch``), or ``structure`` (groups, stretch, soft)
        as pinned."""
        if structure is not None:
            return cls(laminate, *structure)
        groups = layer_groups(laminate, grouping)
        stretch = stretching_layers(laminate) if core_stretch else ()
        return cls(laminate, groups, stretch, soft_groups(laminate, groups))

    @property
    def structure(self) -> tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]]:
        """What a fit keeps while the moduli move: (groups, stretch, soft)."""
        return self.groups, self.stretch, self.soft

    @property
    def n_groups(self) -> int:
        return max(self.groups) + 1

    @cached_property
    def _coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        return coefficients(self.groups, self.stretch, *_layer_inputs(self.laminate))

    @property
    def stiffness(self) -> np.ndarray:
        """Generalised stiffness coefficients (``stiffness_names`` order) [SI]."""
        return self._coefficients[0]

    @property
    def inertia(self) -> np.ndarray:
        """Generalised inertia terms (``inertia_names`` order) [SI]."""
        return self._coefficients[1]

    @property
    def shear_correction(self) -> np.ndarray:
        """(n_groups, 2): k44, k55 of every group [-] (5/6 for a homogeneous plate alone)."""
        t, _, shear, _, _ = _layer_inputs(self.laminate)
        member = np.zeros((len(self.groups), self.n_groups))
        member[np.arange(len(self.groups)), self.groups] = 1.0
        raw = member.T @ (t[:, None] * shear)
        n, m = self.n_groups, 2 * len(self.stretch)
        s = self.stiffness[len(self.stiffness) - m - 3 * n : len(self.stiffness) - m].reshape(-1, 3)
        return s[:, :2] / raw[:, :2]

    def derivative(self, kind: str, target: str) -> tuple[np.ndarray, np.ndarray]:
        """Exact (d stiffness/dp, d inertia/dp) for a parameter (kinds of
        ``Laminate.derivative`` plus G13, G23); zeros when the target is not in the stack."""
        stiffness, inertia = self.derivatives([(kind, target)])
        return stiffness[0], inertia[0]

    def derivatives(self, parameters) -> tuple[np.ndarray, np.ndarray]:
        """``derivative`` of every (kind, target) of ``parameters`` at once, (P, stiffness)
        and (P, inertia): one complex-step pass whose batch holds every direction."""
        directions = [_layer_directions(self.laminate, kind, target) for kind, target in parameters]
        perturbed = [
            x + 1j * COMPLEX_STEP * np.stack([d[i] for d in directions])
            for i, x in enumerate(_layer_inputs(self.laminate))
        ]
        stiffness, inertia = coefficients(self.groups, self.stretch, *perturbed)
        return stiffness.imag / COMPLEX_STEP, inertia.imag / COMPLEX_STEP


def unit_matrices(
    mesh: PlateMesh, n_groups: int, n_normal: int = 0, soft: tuple[int, ...] = ()
) -> UnitMatrices:
    """The (cached, ``assembly.unit_matrices``) unit matrices of a mesh for the layerwise
    element (n_normal normal-strain fields: two per stretching layer; ``soft``: the groups
    whose shear strains are bicubic)."""
    return assembly.unit_matrices(mesh, LayerwisePlate.with_groups(n_groups, n_normal, soft))
