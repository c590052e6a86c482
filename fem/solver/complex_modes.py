"""Modal loss factors from the complex eigenproblem of the same FE model.

Every modulus p is complex, p (1 + i eta_p); the laminate's coefficients follow from
classical lamination theory with complex ply stiffnesses (and, with transverse shear,
the shear correction of complex moduli), so K* = sum_c X*_c K_c with real unit matrices
and real M.  The complex eigenvalues lambda*_i = omega_i^2 (1 + i eta_i) of
K* phi = lambda* M phi give each mode's loss factor eta_i = Im(lambda*_i) / Re(lambda*_i)
with no light-damping approximation.  This is the reference the first-order estimate
(``fem.solver.damping``) is checked against, and the model of a refit when some layer's loss
factor is large.

The solve: one sparse LU factor of K* - sigma M at the real solve's shift (below the
first elastic mode), the rigid-body fields deflated as in ``fem.solver.modal``, ARPACK's
shift-invert for the lowest modes; each complex mode is paired with a real mode by
the mass-weighted MAC, so the loss factors come in the real modes' order.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla
from scipy.optimize import linear_sum_assignment

from ..errors import ModelError
from ..laminates.laminate import Laminate, plane_stress_stiffness, transformation
from ..laminates.laminate_shear import rotated_shear_moduli, shear_stiffness
from ..model import LaminateSolution, SpecimenModel, one_blas_thread, system_data

#: A complex mode is the damped version of a real one when their MAC exceeds this.
PAIRING_MAC = 0.9
#: Real modes whose eigenvalues differ by less than this (relative) are one group in the
#: pairing: damping mixes close modes (a square plate's symmetric pairs are equal to
#: rounding, a near-isotropic one's 0.1 % apart), and within a group the complex modes go
#: to the real ones by Re(lambda).
CLOSE = 1e-2


def complex_coefficients(laminate: Laminate, transverse_shear: bool = False) -> np.ndarray:
    """The 18 CLT coefficients (then A44, A55, A45 with ``transverse_shear``) of the
    laminate with every modulus complex, p (1 + i eta_p) (materials' loss factors; not
    given = 0).  Real parts are the elastic coefficients exactly."""
    qbar, shear = [], []
    for layer in laminate.layers:
        m = layer.material
        e1, e2, g12 = (m.value(p) * (1 + 1j * m.loss_factor(f"eta_{p}")) for p in ("E1", "E2", "G12"))
        q = plane_stress_stiffness(e1, e2, g12, m.nu12)
        qbar.append(transformation(layer.angle) @ q)
        g13, g23 = (g * (1 + 1j * m.loss_factor("eta_G12")) for g in m.transverse_shear_moduli)
        shear.append(rotated_shear_moduli(g13, g23, layer.angle))
    qbar = np.array(qbar)
    x = np.einsum("kq,km->mq", qbar, laminate._moments).ravel()
    if not transverse_shear:
        return x
    t = np.array([layer.thickness for layer in laminate.layers], dtype=complex)
    return np.concatenate([x, shear_stiffness(t, qbar[:, 0], qbar[:, 2], np.array(shear))])


@one_blas_thread
def complex_loss_factors(model: SpecimenModel, configuration: str) -> np.ndarray:
    """The modal loss factors eta_i = Im(lambda*) / Re(lambda*) [-] of a configuration's
    elastic modes, in the order of the real modes (``model.solve``).  Within a group of
    close modes (``CLOSE``) damping mixes the real shapes: the group's loss factors come in
    the order of their Re(lambda), and only their lambda-weighted sum is comparable with
    the first-order estimate mode by mode."""
    if model.options.theory != "single_layer":
        raise ModelError(
            f"the complex eigenproblem is built for the single-layer plate theories, not "
            f"{model.options.theory!r}; use the first-order loss factors (fem.solver.damping)"
        )
    real = model.solve(configuration)
    return _solve(real, complex_coefficients(real.laminate, real.transverse_shear))


def _solve(real: LaminateSolution, coefficients: np.ndarray) -> np.ndarray:
    units, modes = real.units, real.modes
    n_modes = len(modes.eigenvalues)
    inertia = real.laminate.inertia * np.array(real.inertia_terms)
    stiffness, mass = system_data(units, coefficients, inertia, real.attachments)
    k_matrix, m_matrix = units.matrix(stiffness), units.matrix(mass)
    rigid = units.rigid_body_modes
    m_rigid = m_matrix @ rigid
    gram = rigid.T @ m_rigid
    suspended = any(getattr(a, "stiffness", 0) > 0 for a in real.attachments)

    def deflate(x):
        return x if suspended else x - rigid @ np.linalg.solve(gram, m_rigid.T @ x)

    sigma = -0.1 * modes.eigenvalues[0]
    lu = spla.splu((k_matrix - sigma * m_matrix).tocsc())
    n_dofs = units.n_dofs
    operator = spla.LinearOperator(
        (n_dofs, n_dofs), matvec=lambda x: deflate(lu.solve(x.astype(complex))), dtype=complex
    )
    extra = 6 if suspended else 0
    k = min(n_modes + 4 + extra, n_dofs - 2)
    start = deflate(np.random.default_rng(0).standard_normal(n_dofs).astype(complex))
    try:
        lam, phi = spla.eigs(
            k_matrix, k=k, M=m_matrix, sigma=sigma, which="LM", v0=start, tol=1e-10, OPinv=operator
        )
    except spla.ArpackNoConvergence as exc:
        raise ModelError(f"the complex eigen-solver did not converge for {k} modes: {exc}") from exc
    # Pair with the real modes by the mass-weighted MAC (|a^T M b|^2, a real and
    # mass-normalised), summed over each group of close real modes (``CLOSE``).
    cross = modes.shapes.T @ (m_matrix @ phi)
    norms = np.real(np.einsum("ij,ij->j", phi.conj(), m_matrix @ phi))
    mac = np.abs(cross) ** 2 / norms[None, :]
    group = np.concatenate([[0], np.cumsum(np.diff(modes.eigenvalues) > CLOSE * modes.eigenvalues[1:])])
    grouped = np.array([mac[group == g].sum(axis=0) for g in group])
    rows, cols = linear_sum_assignment(-grouped)
    order = cols[np.argsort(rows)]
    for g in np.unique(group):
        members = np.flatnonzero(group == g)
        order[members] = sorted(order[members], key=lambda j: lam[j].real)
    worst = grouped[np.arange(n_modes), order].min()
    if worst < PAIRING_MAC:
        raise ModelError(
            f"a damped mode could not be paired with its elastic one (MAC {worst:.2f}): the damping "
            "changes the mode shapes too much for modal loss factors"
        )
    lam = lam[order]
    return lam.imag / lam.real
