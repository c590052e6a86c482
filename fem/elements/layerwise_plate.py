"""Locking-free rectangular layerwise (zig-zag) laminate element.

Kinematics: a layerwise first-order theory with one transverse shear strain per group of
layers and continuous displacements (Reddy's layerwise theory, Mechanics of Laminated
Composite Plates and Shells, 2nd ed. 2004, ch. 12, with one linear in-plane term per
layer group, i.e. the zig-zag field of Di Sciuva 1986, J. Sound Vib. 105:425-442, keeping
the layers' shear strains as the unknowns), and a transverse normal strain in a soft core
(the core compressibility of high-order sandwich theories, e.g. Frostig et al. 1992,
J. Eng. Mech. 118:1026-1043, here constant through the core):

    U(x, y, z) = u - z w_x + sum_k Phi_k(z) gx_k - sum_s Lambda_s(z) e_s,x,
    V(x, y, z) = v - z w_y + sum_k Phi_k(z) gy_k - sum_s Lambda_s(z) e_s,y,
    W(x, y, z) = w + sum_s Psi_s(z) e_s,

with Phi_k piecewise linear (slope 1 in the layers of group k), Psi_s piecewise linear
(slope 1 in stretching layer s), Lambda_s = int_0^z Psi_s, all zero at z = 0 (so u, v, w
are the mid-plane displacements; ``fem.laminates.layerwise``).  The transverse shear strains are
gamma_xz = gx_k, gamma_yz = gy_k in the layers of group k, the normal strain eps_z = e_s in
layer s, and the in-plane strains

    eps = eps0 + z kappa + sum_k Phi_k kappa_k + sum_s Lambda_s chi_s,
    eps0 = [u_x, v_y, u_y + v_x], kappa = [-w_xx, -w_yy, -2 w_xy],
    kappa_k = [gx_k,x, gy_k,y, gx_k,y + gy_k,x], chi_s = [-e_s,xx, -e_s,yy, -2 e_s,xy].

As in ``ShearDifferencePlate`` (the hierarchic shear-difference parametrisation of Echter,
Oesterle and Bischoff 2013, CMAME 254:170-180), w is C1 and the shear strains are
independent fields, so the Kirchhoff limit g = 0 (and e = 0) lies in the discrete space
and the element cannot lock.  w and every e_s are bicubic Hermite (C1, as kappa and
chi_s take second derivatives).  u, v and the shear strains of a stiff group enter the
energy through first derivatives only, so they need C0 fields, and they take the 12-term
Adini-Clough-Melosh basis (``hermite_plate._acm``: f, f_x, f_y at each node, the complete
cubic as the bicubic has, 3 DOFs a node instead of 4).  A soft group's shear strains
(a foam core, a bond line: ``fem.laminates.layerwise.soft_groups``) stay bicubic: there g
follows w_x and the stiff skins strain by their difference.  All strains converge at the
Kirchhoff element's rate and the eigenvalues at O(h^4).  On the ten development cases of
``tests/data/solid3d/layerwise_mesh.py`` the default mesh stays within 0.022 % of the
bicubic element on a mesh 1.5 x finer (0.021 % all bicubic), with 11-23 % fewer DOFs and
solves 0.6-0.9 x as long.  With one group and no stretching layer Phi = z and the element
is ``ShearDifferencePlate`` with those bases (that element keeps u, v and g bicubic).

The energies are linear in generalised laminate coefficients (``fem.laminates.layerwise``): one unit
stiffness matrix per pair (a <= b) of the through-thickness functions f = [1, z, Phi_k,
Lambda_s] and Voigt pair, one per group shear term, one per stretching layer; one unit mass
matrix per pair of f, and per pair of [1, Psi_s] beyond the first.
"""

from __future__ import annotations

import re
from functools import cache

import numpy as np

from .hermite_plate import HermitePlate, MatrixQuadrature, Quadrature


def basis_pairs(n: int) -> list[tuple[int, int]]:
    """Pairs (a <= b) of n through-thickness functions in unit-matrix order: (0, 0),
    (0, 1), (1, 1) first (A, B, D; I0, I1, I2), then the others row by row."""
    head = [(0, 0), (0, 1), (1, 1)][: 1 if n == 1 else 3]
    return head + [(a, b) for a in range(n) for b in range(a, n) if (a, b) not in head]


def node_dofs(fields: tuple[str, ...], c0_fields: tuple[str, ...]) -> tuple[str, ...]:
    """Per-node DOF names: (f, f_x, f_y) of a C0 field, (f, f_x, f_y, f_xy) of a bicubic one."""
    return tuple(
        f + d for f in fields for d in (("", "_x", "_y") if f in c0_fields else ("", "_x", "_y", "_xy"))
    )


class LayerwisePlate(HermitePlate):
    """Four-node rectangle, 10 + 6 n + 2 s + 4 m DOFs per node for n shear groups (s of
    them soft) and m normal-strain fields: u, v and the shear strains gx_k = gamma_xz,
    gy_k = gamma_yz of a stiff group k on the C0 basis (``_acm``: only their first
    derivatives enter the energy); w, every e_s = eps_z (C1: the curvatures and chi_s take
    second derivatives) and a soft group's shear strains bicubic
    (``fem.laminates.layerwise.soft_groups``: why).

    Use ``LayerwisePlate.with_groups(n, m, soft)``: one (cached) class per (n, m, soft), so
    that the assembly caches see one element type per structure.
    """

    GROUPS = 1
    STRETCH = 0
    FIELDS = ("u", "v", "w", "gx1", "gy1")
    C0_FIELDS = ("u", "v", "gx1", "gy1")
    NODE_DOFS = node_dofs(FIELDS, C0_FIELDS)

    @staticmethod
    def with_groups(n: int, m: int = 0, soft: tuple[int, ...] = ()) -> type:
        """The element class for n shear groups, m normal-strain fields and the soft groups
        ``soft`` (0-based; the same class object for equal arguments)."""
        if n < 1 or m < 0 or any(not 0 <= k < n for k in soft):
            raise ValueError(
                f"a layerwise element needs at least one shear group and soft groups among them; got {n} "
                f"groups, {m} stretching, soft {soft}"
            )
        return _element_class(n, m, tuple(sorted(soft)))

    def zigzag_curvature(self, k: int) -> np.ndarray:
        """kappa_k = [gx_k,x, gy_k,y, gx_k,y + gy_k,x] at the quadrature points (nq, 3, N)."""
        gx, gy = f"gx{k + 1}", f"gy{k + 1}"
        return np.stack(
            [self._field("Nx", gx), self._field("Ny", gy), self._field("Ny", gx) + self._field("Nx", gy)],
            axis=1,
        )

    def stretch_curvature(self, s: int) -> np.ndarray:
        """chi_s = -[e_s,xx, e_s,yy, 2 e_s,xy] at the quadrature points (nq, 3, N)."""
        e = f"e{s + 1}"
        return -np.stack([self._field("Nxx", e), self._field("Nyy", e), 2 * self._field("Nxy", e)], axis=1)

    def shear_strain_operator(self, k: int) -> np.ndarray:
        """[gamma_yz, gamma_xz] of group k at the quadrature points (nq, 2, N) (Voigt 4, 5)."""
        return np.stack([self._field("N", f"gy{k + 1}"), self._field("N", f"gx{k + 1}")], axis=1)

    def in_plane_strains(self) -> list[np.ndarray]:
        """The in-plane strain operators of the functions [1, z, Phi_k, Lambda_s], each (nq, 3, N)."""
        membrane, curvature = self.strain_operators()
        return (
            [membrane, curvature]
            + [self.zigzag_curvature(k) for k in range(self.GROUPS)]
            + [self.stretch_curvature(s) for s in range(self.STRETCH)]
        )

    def in_plane_displacements(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The (x, y) in-plane displacement operators of the functions [1, z, Phi_k, Lambda_s]."""
        bx, by = HermitePlate.rotations(self)  # the Kirchhoff rotation -grad w
        out = [(self._field("N", "u"), self._field("N", "v")), (bx, by)]
        out += [(self._field("N", f"gx{k + 1}"), self._field("N", f"gy{k + 1}")) for k in range(self.GROUPS)]
        out += [
            (-self._field("Nx", f"e{s + 1}"), -self._field("Ny", f"e{s + 1}")) for s in range(self.STRETCH)
        ]
        return out

    def unit_stiffness(self, pairs, quadrature: Quadrature | None = None) -> np.ndarray:
        """Unit stiffness matrices (n_c, N, N) in ``fem.laminates.layerwise.stiffness_names``
        order (their quadratic forms (n_c, k) with an ``EnergyQuadrature``)."""
        integral = quadrature or MatrixQuadrature(self.weights)
        strains = [integral.operator(e) for e in self.in_plane_strains()]
        out = []
        for a, b in basis_pairs(len(strains)):
            out += self._coupling(integral, strains[a], strains[b], pairs, a != b)
        for k in range(self.GROUPS):
            gamma = integral.operator(self.shear_strain_operator(k))
            k45 = integral(gamma[:, 0], gamma[:, 1])
            out += [integral(gamma[:, 0], gamma[:, 0]), integral(gamma[:, 1], gamma[:, 1]), k45 + k45.T]
        for s in range(self.STRETCH):
            e = integral.operator(self._field("N", f"e{s + 1}"))
            out.append(integral(e, e))
        return np.array(out)

    def unit_mass(self, quadrature: Quadrature | None = None) -> np.ndarray:
        """Unit mass matrices (n_i, N, N) in ``fem.laminates.layerwise.inertia_names`` order: the
        in-plane pairs (the first, I0, also carries w^2), then the transverse pairs of
        [w, e_s] beyond (w, w) (their quadratic forms (n_i, k) with an ``EnergyQuadrature``)."""
        integral = quadrature or MatrixQuadrature(self.weights)
        displacements = [tuple(map(integral.operator, d)) for d in self.in_plane_displacements()]
        out = []
        for a, b in basis_pairs(len(displacements)):
            (ax, ay), (bx, by) = displacements[a], displacements[b]
            m = integral(ax, bx) + integral(ay, by)
            out.append(m if a == b else m + m.T)
        transverse = [self._field("N", "w")] + [self._field("N", f"e{s + 1}") for s in range(self.STRETCH)]
        transverse = [integral.operator(t) for t in transverse]
        out[0] = out[0] + integral(transverse[0], transverse[0])
        for a, b in basis_pairs(len(transverse))[1:]:
            m = integral(transverse[a], transverse[b])
            out.append(m if a == b else m + m.T)
        return np.array(out)


@cache
def _element_class(n: int, m: int, soft: tuple[int, ...]) -> type:
    """``LayerwisePlate.with_groups``'s class, made once per (n, m, soft)."""
    shear = tuple(f"{c}{k + 1}" for k in range(n) for c in ("gx", "gy"))
    fields = HermitePlate.FIELDS + shear + tuple(f"e{s + 1}" for s in range(m))
    c0_fields = ("u", "v") + tuple(f"{c}{k + 1}" for k in range(n) if k not in soft for c in ("gx", "gy"))
    dofs = node_dofs(fields, c0_fields)
    name = f"LayerwisePlate{n}" + (f"_{m}" if m or soft else "") + "".join(f"_s{k}" for k in soft)
    cls = type(
        name,
        (LayerwisePlate,),
        {
            "GROUPS": n,
            "STRETCH": m,
            "FIELDS": fields,
            "C0_FIELDS": c0_fields,
            "NODE_DOFS": dofs,
            "__doc__": f"Layerwise plate element: {n} shear group(s) ({len(soft)} soft), {m} "
            f"normal-strain field(s), {len(dofs)} DOFs per node.",
            "__module__": __name__,
        },
    )
    globals()[name] = cls  # found by name, so solutions holding it pickle to worker processes
    return cls


def __getattr__(name: str):
    """``LayerwisePlateN``, ``LayerwisePlateN_M`` or ``LayerwisePlateN_M_sK..`` made on first
    use (PEP 562), e.g. when a worker process unpickles a solution that refers to one."""
    match = re.fullmatch(r"LayerwisePlate(\d+)(?:_(\d+))?((?:_s\d+)*)", name)
    if match:
        n, m, soft = match.groups()
        return LayerwisePlate.with_groups(
            int(n), int(m or 0), tuple(int(k) for k in re.findall(r"\d+", soft))
        )
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
