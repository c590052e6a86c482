"""Block triangular solves on the modal solve's band factor, against dense solves."""

import numpy as np
import pytest
import scipy.linalg as sla
from hypothesis import given, settings
from hypothesis import strategies as st

from fem.laminates.laminate import Laminate, Layer
from fem.laminates.material import Material
from fem.model import solve_laminate
from fem.solver import modal
from fem.solver.mesh import PlateMesh
from fem.solver.modal import BandBlocks
from tests.conftest import FREE_PLATES


def _band_factor(n: int, b: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random symmetric positive definite matrix of semi-bandwidth b, dense, and its
    upper band Cholesky factor as LAPACK stores it (Fortran-ordered)."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    a = np.triu(np.tril(a + a.T, b), -b)
    a += np.diag(2 * np.abs(a).sum(axis=1) + 1)  # diagonally dominant: positive definite
    band = np.zeros((b + 1, n), order="F")
    for d in range(b + 1):
        band[b - d, d:] = np.diagonal(a, d)
    return a, sla.cholesky_banded(band, lower=False)


@settings(max_examples=40, deadline=None)
@given(
    b=st.integers(1, 12),
    blocks=st.integers(1, 5),
    tail=st.integers(0, 11),
    columns=st.integers(1, 9),
    seed=st.integers(0, 2**16),
)
def test_block_solves_match_dense_triangular_solves(b, blocks, tail, columns, seed):
    """U^-T x and U^-1 y by blocks equal the dense triangular solves for every split of
    the DOFs into full blocks and a tail (tail < b, or none).  Tolerance 1e-10 relative:
    these factors are well conditioned (diagonally dominant), so both ways agree to a few
    hundred ulps; a wrong block or a garbage entry read from outside the band gives O(1)."""
    n = blocks * b + min(tail, b - 1)
    a, factor = _band_factor(n, b, seed)
    u = sla.cholesky(a)  # dense upper factor, the same as the band one
    x = np.random.default_rng(seed + 1).standard_normal((n, columns))
    solver = BandBlocks(factor)
    expected_t = sla.solve_triangular(u, x, trans="T")
    expected = sla.solve_triangular(u, x)
    scale = lambda e: np.abs(e).max()  # noqa: E731
    assert np.abs(solver.solve_transposed(x) - expected_t).max() <= 1e-10 * scale(expected_t)
    assert np.abs(solver.solve(x) - expected).max() <= 1e-10 * scale(expected)


@settings(max_examples=40, deadline=None)
@given(b=st.integers(1, 12), n_extra=st.integers(0, 40), seed=st.integers(0, 2**16))
def test_forward_solve_on_the_reversed_factor_is_the_back_substitution(b, n_extra, seed):
    """U^-1 x as a forward substitution on the reversed copy of the factor (what a factor
    too large for the cache solves with, ``modal._reversed``) gives the back
    substitution's numbers bit for bit (the same operations on the same numbers, in the
    same order), and the dense triangular solve's within 1e-10 (the tolerance above)."""
    n = b + 1 + n_extra
    a, factor = _band_factor(n, b, seed)
    x = np.random.default_rng(seed + 2).standard_normal(n)
    forward = modal._solve_reversed(modal._reversed(factor), x)
    np.testing.assert_array_equal(forward, modal._solve(factor, x))
    np.testing.assert_allclose(forward, sla.solve_triangular(sla.cholesky(a), x), rtol=1e-10, atol=1e-12)


def test_block_solves_need_the_fortran_factor():
    """A C-ordered copy of the band would be read with the wrong strides: refused."""
    _, factor = _band_factor(20, 4, 0)
    with pytest.raises(ValueError, match="Fortran"):
        BandBlocks(np.ascontiguousarray(factor))


@pytest.mark.parametrize("theory", ["thin", "shear"])
def test_modes_by_blocks_equal_modes_by_columns(monkeypatch, theory):
    """The modal solve's two ways back from the Lanczos vectors (blocks for factors above
    BLOCK_SOLVE_BYTES, columns below) give the same modes: omega^2 within 1e-9 relative
    (the Rayleigh quotient phi^T K phi of mass-normalised shapes, whose round-off with
    stiff rotation DOFs is ~1e-10 at 18,240 DOFs) and shapes within 1e-9 of each other
    (a repeated frequency's shapes within 1e-9 of the pair's plane: round-off decides
    which of the two is listed first).
    On the NAFEMS FV12 free plate, thin and first-order shear (thin: the same plate is
    the reference of test_free_plates)."""
    ref = FREE_PLATES["nafems_fv12_free_square_plate"]
    p = ref["plate"]
    material = Material("steel", p["E_Pa"], p["E_Pa"], p["E_Pa"] / (2 * (1 + p["nu"])), p["nu"], p["rho"])
    laminate = Laminate((Layer(material, p["t_m"]),))
    mesh = PlateMesh(p["a_m"], p["a_m"], 16, 16)
    solved = {}
    for name, limit in (("blocks", 0), ("columns", 2**62)):
        monkeypatch.setattr(modal, "BLOCK_SOLVE_BYTES", limit)
        solve_laminate.cache_clear()
        solved[name] = solve_laminate(laminate, mesh, 8, transverse_shear=theory == "shear")
    solve_laminate.cache_clear()
    blocks, columns = solved["blocks"].modes, solved["columns"].modes
    np.testing.assert_allclose(blocks.eigenvalues, columns.eigenvalues, rtol=1e-9)
    lam = columns.eigenvalues
    for i, shape in enumerate(blocks.shapes.T):
        twins = columns.shapes[:, np.abs(lam / lam[i] - 1) < 1e-6]  # the square plate's pairs
        left = shape - twins @ np.linalg.lstsq(twins, shape, rcond=None)[0]
        assert np.linalg.norm(left) <= 1e-9 * np.linalg.norm(shape)
    if theory == "thin":
        np.testing.assert_allclose(solved["blocks"].frequencies_hz, ref["elastic_modes_hz"], rtol=1e-3)
