"""Free-free modal solve: sparse shift-invert Lanczos, rigid-body modes removed."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla
from numpy.lib.stride_tricks import as_strided

from ..errors import ModelError
from .assembly import UnitMatrices
from .work_arrays import work_array

#: Largest relative strain energy |K r| / (|K| |r|) a rigid-body field may carry (round-off level).
RIGID_LEAK = 1e-9
#: The first elastic omega^2 must exceed this fraction of the first-bending estimate.
MECHANISM_GAP = 1e-4


@dataclass(frozen=True)
class Modes:
    """Elastic modes of a free plate, lowest first.

    eigenvalues: omega^2 [rad^2/s^2]; shapes: (n_dofs, m), mass-normalised
    (phi^T M phi = 1).  Their nodal-pattern labels are in ``fem.solver.mode_shapes``.
    """

    eigenvalues: np.ndarray
    shapes: np.ndarray

    @property
    def frequencies_hz(self) -> np.ndarray:
        return np.sqrt(self.eigenvalues) / (2 * math.pi)


def _first_bending_estimate(coefficients: np.ndarray, mass_per_area: float, span: float) -> float:
    """A rough omega^2 of the first bending mode, only to place the shift."""
    d_max = max(coefficients[12], coefficients[14])  # D11, D22
    return (22.0 / span**2) ** 2 * d_max / mass_per_area


def _transposed_solve(factor: np.ndarray, x: np.ndarray) -> np.ndarray:
    """U^-T x for the upper band factor U of K - sigma M = U^T U (Fortran-ordered)."""
    return sla.blas.dtbsv(factor.shape[0] - 1, factor, x, lower=0, trans=1)


def _solve(factor: np.ndarray, x: np.ndarray) -> np.ndarray:
    """U^-1 x: a back substitution on the band factor itself (a factor that fits in the
    cache; a larger one solves forward on its reversed copy, ``_reversed``)."""
    return sla.blas.dtbsv(factor.shape[0] - 1, factor, x, lower=0, trans=0)


def _reversed(factor: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """The band factor U (upper storage, Fortran-ordered) with its DOFs in reverse order:
    J U J is lower triangular, and its lower band storage is U's flat storage read
    backwards, so the copy is one pass over memory (10 ms for 71 MB).

    A factor larger than the cache streams from memory at every one-vector solve, and the
    band kernels stream it faster forwards than backwards: U^-1 x as a forward
    substitution on this copy (``_solve_reversed``) gives the back substitution's numbers
    bit for bit in half the time (measured alone, OpenBLAS 0.3.30, 32 MB cache: 9,720
    DOFs, 48 MB of factor, 1.8 against 3.4 ms; 11,880 DOFs, 71 MB, 2.6 against 5.4 ms;
    5,400 DOFs, 15 MB, 0.29 against 0.30 ms), so a layerwise solve's 40 Lanczos steps
    save 60-110 ms for a copy of 3-10 ms, at the price of the factor's memory again
    while the solve runs.  ``out``: a flat array of the factor's size to copy it into (the
    solve's work array)."""
    flat = factor.ravel(order="F")
    out = np.empty_like(flat) if out is None else out
    np.copyto(out, flat[::-1])
    return out.reshape(factor.shape, order="F")


def _solve_reversed(reversed_factor: np.ndarray, x: np.ndarray) -> np.ndarray:
    """U^-1 x by forward substitution on ``_reversed(U)``: J (J U J)^-1 J x."""
    return sla.blas.dtbsv(reversed_factor.shape[0] - 1, reversed_factor, x[::-1], lower=1, trans=0)[::-1]


def _columns(solve, factor: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A one-vector triangular solve applied to each column of x (n_dofs, k)."""
    return np.column_stack([solve(factor, c) for c in x.T])


#: Band factors larger than this solve many vectors at once by dense blocks
#: (``BandBlocks``), smaller ones one column at a time.  A small factor stays in cache,
#: where the band kernel is as fast as the block kernels and has no per-block overhead.
#: Measured on this project's machine (32 MB L3), U^-1 of the modes: 3,468 DOFs (6.3 MB
#: of factor) 3.7 ms by columns against 4.2 ms by blocks; 5,808 DOFs (13 MB) 17 against
#: 10 ms; 18,240 DOFs (61 MB) 193 against 42 ms.
BLOCK_SOLVE_BYTES = 8 * 2**20


class BandBlocks:
    """The upper band factor U (LAPACK storage, Fortran-ordered) seen as dense b x b
    blocks, b its semi-bandwidth, for triangular solves of many right-hand sides at once
    (BLAS level 3: on a factor too large for the cache, where each one-column band solve
    streams the whole factor from memory, 3.7-4.6x faster from 20 columns on at 18,240
    DOFs; see ``BLOCK_SOLVE_BYTES``).

    No copy: in band storage U_ij sits at flat offset b + i + j b, so the block of rows
    i0.. and columns j0.. is a Fortran matrix with leading dimension b.  The diagonal
    blocks D_k are upper triangular (their lower parts are other entries, which the
    triangular kernels never read); the blocks O_k right of them couple block k to k + 1,
    and only their lower triangle lies within the band.  The last n mod b DOFs form a
    small tail block (copied)."""

    def __init__(self, factor: np.ndarray):
        width, n = factor.shape
        b = width - 1
        flat = factor.ravel(order="F")
        if not np.shares_memory(flat, factor):
            raise ValueError("the band factor must be Fortran-ordered")
        self.b, self.n_full = b, n // b

        def view(i0: int, j0: int, rows: int, cols: int) -> np.ndarray:
            return as_strided(flat[b + i0 + j0 * b :], (rows, cols), (flat.itemsize, flat.itemsize * b))

        self.diagonal = [view(k * b, k * b, b, b) for k in range(self.n_full)]
        self.coupling = [view(k * b, (k + 1) * b, b, b) for k in range(self.n_full - 1)]
        start, tail = self.n_full * b, n - self.n_full * b
        self.tail = np.asfortranarray(np.triu(view(start, start, tail, tail)))
        # Rows start - b.. against the tail's columns: within the band where column <= row.
        self.tail_coupling = np.asfortranarray(np.tril(view(start - b, start, b, tail)))

    def solve_transposed(self, x: np.ndarray) -> np.ndarray:
        """U^-T x for x (n_dofs, k): forward substitution by blocks."""
        b, y = self.b, np.array(x, dtype=float, order="F")
        for k, block in enumerate(self.diagonal):
            rows = slice(k * b, (k + 1) * b)
            if k:
                y[rows] -= sla.blas.dtrmm(
                    1.0, self.coupling[k - 1], y[rows.start - b : rows.start], lower=1, trans_a=1
                )
            y[rows] = sla.blas.dtrsm(1.0, block, y[rows], trans_a=1)
        start = self.n_full * b
        if self.tail.size:
            y[start:] -= self.tail_coupling.T @ y[start - b : start]
            y[start:] = sla.blas.dtrsm(1.0, self.tail, y[start:], trans_a=1)
        return y

    def solve(self, y: np.ndarray) -> np.ndarray:
        """U^-1 y for y (n_dofs, k): back substitution by blocks."""
        b, z = self.b, np.array(y, dtype=float, order="F")
        start = self.n_full * b
        if self.tail.size:
            z[start:] = sla.blas.dtrsm(1.0, self.tail, z[start:])
            z[start - b : start] -= self.tail_coupling @ z[start:]
        for k in range(self.n_full - 1, -1, -1):
            rows = slice(k * b, (k + 1) * b)
            if k < self.n_full - 1:
                z[rows] -= sla.blas.dtrmm(1.0, self.coupling[k], z[rows.stop : rows.stop + b], lower=1)
            z[rows] = sla.blas.dtrsm(1.0, self.diagonal[k], z[rows])
        return z


def solve_modes(
    units: UnitMatrices,
    stiffness_data: np.ndarray,
    mass_data: np.ndarray,
    n_modes: int,
    shift_scale: float,
    suspended: bool = False,
) -> Modes:
    """The lowest ``n_modes`` elastic modes of K phi = omega^2 M phi for a free plate.

    stiffness_data, mass_data: CSR data of K and M on the mesh's shared pattern.
    shift_scale: an estimate of the first elastic omega^2; the Lanczos shift sits at
    -0.1 of it, where K - sigma M is positive definite despite the rigid-body modes,
    so its banded Cholesky factor (LAPACK pbtrf) turns the problem into a standard one.

    The six rigid-body modes (the element type's fields) are removed by deflation, not
    by counting: they are checked to be zero-energy fields of K, and the Lanczos
    iteration runs in the complement of their transformed fields, so exactly six are
    dropped whatever the plate's scale.  A seventh near-zero mode (a mechanism) is reported as an error.
    M may be singular (an element's shear-strain DOFs carry no inertia without rotary
    inertia): shift-invert Lanczos needs only K - sigma M definite and M semi-definite.

    suspended: springs hold some rigid-body motions.  Only the zero-energy combinations
    are deflated; the others become low suspension modes, which are solved for and
    dropped by their projection on the rigid-body space (their number is checked).
    """
    n_dofs = units.n_dofs
    stiffness = units.matrix(stiffness_data)
    # M shares K's pattern, but without rotary inertia only u-u, v-v and w-w entries are
    # nonzero: dropping the rest makes the M products Lanczos needs 3x cheaper.
    mass = units.mass_matrix(mass_data)
    all_rigid = units.rigid_body_modes
    # K times the rigid-body fields, once: the suspension's energies or the leak check, and
    # the deflation's fields below (a K product of six vectors is 7 ms of a 0.3 s layerwise solve)
    strained = stiffness @ all_rigid
    n_suspension = 0
    if suspended:
        # Rigid-body combinations by their spring energy (omega^2 of a rigid plate on the springs).
        mu, combos = sla.eigh(all_rigid.T @ strained, all_rigid.T @ (mass @ all_rigid))
        held = mu > RIGID_LEAK * shift_scale
        n_suspension = int(held.sum())
        rigid, strained = all_rigid @ combos[:, ~held], strained @ combos[:, ~held]
    else:
        rigid = all_rigid
        # the largest |K_ij| from the data (abs(stiffness) would copy the whole matrix)
        largest = max(stiffness_data.max(), -stiffness_data.min())
        leak = np.linalg.norm(strained, axis=0) / (largest * np.linalg.norm(rigid, axis=0))
        if leak.max() > RIGID_LEAK:
            raise ModelError(
                f"a rigid-body motion strains the model (relative energy {leak.max():.2g}): it is not a free "
                "plate"
            )
    # One Ritz pair beyond the modes returned: each is converged to ``tol`` whatever k is,
    # and the spare keeps the last one returned off the edge of the wanted set.  Two spares
    # took 2-10 Lanczos steps more (48 instead of 38 for 13 layerwise modes: 6 % of a
    # solve of the foam sandwich, 20 % of its Lanczos steps) for the same frequencies to
    # 7e-15 and shapes to 6e-9 (the residual tolerance's order) on 23 configurations.
    k = n_modes + 1 + n_suspension
    if k >= n_dofs // 2:
        raise ModelError(f"mesh too coarse: {n_dofs} DOFs for {n_modes} elastic modes; refine the mesh")
    sigma = -0.1 * shift_scale
    shifted = mass_data * -sigma  # K - sigma M, one array of temporaries fewer
    shifted += stiffness_data
    # The band (factored in place) and its reversed copy are written into the thread's
    # kept work arrays (``work_arrays``): nothing this function returns holds them.
    band = units.banded(shifted, out=work_array("band", units.band_size))
    # The factor's DOFs are in ``units.band_order`` (x[order] gathers, y[rank] scatters back).
    order, rank = units.band_order, units.rank
    rigid_fields = (strained - sigma * (mass @ rigid))[order]
    del shifted  # not read again: let go before the factor and its reversed copy are made
    try:
        factor = sla.cholesky_banded(band, lower=False, overwrite_ab=True, check_finite=False)
    except sla.LinAlgError as exc:
        raise ModelError(
            "the stiffness matrix is not positive semi-definite: check the material values and units"
        ) from exc
    # Standard form: C = U^-T M U^-1 has the eigenvectors psi = U phi with eigenvalues
    # 1 / (omega^2 - sigma), so one M product and two triangular solves per Lanczos step
    # (the generalised shift-invert mode takes three M products).  A zero-energy field r
    # is an eigenvector of C (M r = -(K - sigma M) r / sigma), so projecting out the
    # orthonormal basis of U r = U^-T (K - sigma M) r deflates the rigid-body modes.
    blocks = BandBlocks(factor) if factor.nbytes > BLOCK_SOLVE_BYTES else None
    # ``_reversed``: the large factors
    backwards = _reversed(factor, work_array("reversed factor", factor.size)) if blocks else None

    def inverse(x: np.ndarray) -> np.ndarray:
        """U^-1 x, forwards in memory."""
        return _solve_reversed(backwards, x) if blocks else _solve(factor, x)

    rigid_basis, _ = np.linalg.qr(
        blocks.solve_transposed(rigid_fields) if blocks else _columns(_transposed_solve, factor, rigid_fields)
    )

    def deflate(x: np.ndarray) -> np.ndarray:
        return x - rigid_basis @ (rigid_basis.T @ x)

    transformed_mass = spla.LinearOperator(
        (n_dofs, n_dofs),
        dtype=float,
        matvec=lambda x: deflate(_transposed_solve(factor, (mass @ inverse(deflate(x))[rank])[order])),
    )
    start = deflate(np.random.default_rng(0).standard_normal(n_dofs))
    try:
        # tol bounds the Ritz vectors' residual; omega^2 comes from their Rayleigh
        # quotients, accurate to its square (~1e-16 relative).
        theta, psi = spla.eigsh(transformed_mass, k=k, which="LA", v0=start, tol=1e-8)
    except spla.ArpackNoConvergence as exc:
        raise ModelError(f"the eigen-solver did not converge for {k} modes: {exc}") from exc
    # The modes and their Rayleigh quotients without a K or an M product (12 vectors
    # through K are 14 ms of a 0.3 s layerwise solve, through M 6 ms): U phi = psi (unit
    # length), so phi^T M phi = psi^T C psi = theta, the Ritz value, and phi^T (K - sigma
    # M) phi = 1; theta's error is the square of the Ritz vector's residual (tol).
    phi = (blocks.solve(psi) if blocks else _columns(_solve, factor, psi))[rank] / np.sqrt(theta)
    lam = 1.0 / theta + sigma
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order]
    if n_suspension:
        m_all = mass @ all_rigid
        coupling = m_all.T @ phi
        share = np.einsum("ik,ik->k", coupling, np.linalg.solve(all_rigid.T @ m_all, coupling))
        suspension = share > 0.5
        if suspension.sum() != n_suspension or not suspension[:n_suspension].all():
            raise ModelError(
                f"the {n_suspension} suspension modes cannot be told from the elastic ones (found "
                f"{int(suspension.sum())} rigid-like among the lowest); the suspension is too stiff for a "
                "free test"
            )
        lam, phi = lam[~suspension], phi[:, ~suspension]
    lam, phi = lam[:n_modes], phi[:, :n_modes]
    if lam[0] < MECHANISM_GAP * shift_scale:
        raise ModelError(
            f"an elastic mode has near-zero frequency (omega^2 = {lam[0]:.3g}): the model has a mechanism; "
            "check for a zero modulus or a disconnected layer"
        )
    return Modes(lam, phi)
