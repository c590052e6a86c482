"""The global CSR pattern and aggregation of a mesh (``UnitMatrices._pattern``), built
from the node-pair blocks, against the direct construction: every element entry's (row,
column) sorted and numbered, and an aggregation matrix with a column per element entry,
the way the pattern was built before."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from fem.elements import HermitePlate, LayerwisePlate, ShearDifferencePlate
from fem.laminates.laminate import VOIGT_PAIRS
from fem.solver import assembly
from fem.solver.assembly import UnitMatrices
from fem.solver.mesh import PlateMesh


def sorted_pattern(units: UnitMatrices):
    """Indices, indptr and aggregation by sorting every element entry's global (row,
    column): the reference (``np.unique`` over n_elements x n_local^2 keys)."""
    dofs = units.element_dofs
    n_local = dofs.shape[1]
    rows = np.repeat(dofs, n_local, axis=1).ravel()
    cols = np.tile(dofs, (1, n_local)).ravel()
    group = units.mesh.size_groups[1]
    local = (group[:, None] * n_local * n_local + np.arange(n_local * n_local)).ravel()
    key = rows.astype(np.int64) * units.n_dofs + cols
    unique, slot = np.unique(key, return_inverse=True)
    g_rows, g_cols = np.divmod(unique, units.n_dofs)
    indptr = np.searchsorted(g_rows, np.arange(units.n_dofs + 1))
    aggregate = sp.csr_matrix(
        (np.ones(slot.size), (slot, local)), shape=(unique.size, len(units.elements) * n_local * n_local)
    )
    return g_cols.astype(np.int32), indptr.astype(np.int32), aggregate


MESHES = {
    "equal": PlateMesh(0.30, 0.20, 6, 4),
    # graded towards the edges and with a sensor's footprint: several element sizes
    "graded": PlateMesh.with_element_size(0.25, 0.16, 8, 0.004, bases=((0.10, 0.11, 0.05, 0.06),)),
    "one element across": PlateMesh(0.10, 0.02, 5, 1),
    "tall": PlateMesh(0.12, 0.20, 3, 7),  # the band order runs across its columns
}
ELEMENTS = [HermitePlate, ShearDifferencePlate, LayerwisePlate.with_groups(3, 1)]


@pytest.mark.parametrize("mesh", MESHES.values(), ids=MESHES.keys())
@pytest.mark.parametrize("kind", ELEMENTS, ids=lambda k: k.__name__)
@pytest.mark.parametrize("chunk", [1, 997, 1 << 22])
def test_node_block_pattern_is_the_sorted_one(monkeypatch, mesh, kind, chunk):
    """The same indices and indptr (as int32), entry for entry, on equal, graded and
    one-element-wide meshes for each element type; and the aggregation's sums are the
    reference matrix's bit for bit (each global entry's element entries added in the same
    order), for real vectors spanning 16 decades, complex ones (damping's complex weights)
    and a block of them (``stiffness_data``), summed a pair at a time, in chunks that
    split the runs of nodes unevenly, and all at once (``CHUNK_ENTRIES``)."""
    monkeypatch.setattr(assembly, "CHUNK_ENTRIES", chunk)
    units = UnitMatrices(mesh, kind)
    assert len(units.elements) > 1 or mesh is not MESHES["graded"]
    indices, indptr, aggregation = units._pattern
    ref_indices, ref_indptr, ref_aggregate = sorted_pattern(units)
    assert indices.dtype == ref_indices.dtype and indptr.dtype == ref_indptr.dtype
    np.testing.assert_array_equal(indices, ref_indices)
    np.testing.assert_array_equal(indptr, ref_indptr)
    rng = np.random.default_rng(7)
    n = ref_aggregate.shape[1]
    real = rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8, n)
    block = rng.standard_normal((n, 3)) * 10.0 ** rng.integers(-8, 8, (n, 1))
    for operand in (real, real - 1j * rng.standard_normal(n), block, block.T.copy().T):
        product, reference = aggregation @ operand, ref_aggregate @ operand
        assert product.dtype == reference.dtype and product.shape == reference.shape
        np.testing.assert_array_equal(product.view(np.uint8), reference.view(np.uint8))


def test_aggregation_holds_no_array_per_element_entry():
    """The node-pair blocks' index arrays grow with the elements, not with their entries:
    on a layerwise mesh (3,136 entries an element) they hold under 1 % of the bytes of an
    aggregation matrix with one entry per element entry (8 bytes of index a column of
    it; the one they replaced also held its ones), and the band needs no slots either."""
    units = UnitMatrices(MESHES["graded"], LayerwisePlate.with_groups(3, 1))
    indices, _, pairs = units._pattern
    units.banded(np.zeros(indices.size))
    entries = units.element_dofs.size * units.element_dofs.shape[1]
    assert 0 < pairs.nbytes < 0.01 * 8 * entries
    # beside the CSR columns, a set laid out as a band holds arrays per DOF, none per entry
    assert units.nbytes - indices.nbytes - pairs.nbytes <= 8 * 8 * units.n_dofs


def test_pattern_assembles_the_scattered_element_matrices():
    """A unit stiffness matrix through the pattern equals the element matrices added into
    a dense global matrix one element at a time, to round-off (each global entry is a sum
    of at most four element entries, added in another order: 1e-12 of the largest)."""
    units = UnitMatrices(MESHES["graded"], ShearDifferencePlate)
    unit = 12  # D11's unit matrix
    stiffness = [element.unit_stiffness(VOIGT_PAIRS)[unit] for element in units.elements]
    dense = np.zeros((units.n_dofs, units.n_dofs))
    group = units.mesh.size_groups[1]
    for e, dofs in enumerate(units.element_dofs):
        dense[np.ix_(dofs, dofs)] += stiffness[group[e]]
    assembled = units.matrix(units.stiffness_data[unit]).toarray()
    np.testing.assert_allclose(assembled, dense, rtol=0, atol=1e-12 * np.abs(dense).max())


@pytest.mark.parametrize("kind", ELEMENTS, ids=lambda e: e.__name__)
@pytest.mark.parametrize("mesh", MESHES.values(), ids=MESHES.keys())
def test_band_from_pair_blocks_is_the_one_of_every_entry(mesh, kind):
    """The semi-bandwidth and the band laid out from the node-pair blocks are those of
    every stored entry's band position worked out at once (the construction they replace),
    bit for bit, whether the band order runs across the mesh's rows or its columns (a
    wide, a tall and a one-element-wide mesh), and the band holds the matrix's upper
    triangle."""
    units = UnitMatrices(mesh, kind)
    indices, indptr, _ = units._pattern
    csr_rows = np.repeat(np.arange(units.n_dofs), np.diff(indptr))
    rows, cols = units.rank[csr_rows], units.rank[indices]
    bandwidth = int(np.max(cols - rows))
    upper = np.flatnonzero(cols >= rows)
    flat = cols[upper] * (bandwidth + 1) + bandwidth + rows[upper] - cols[upper]
    assert units.bandwidth == bandwidth
    data = np.sin(1e-3 * (csr_rows + indices) + 1e-6 * csr_rows * indices.astype(np.int64))  # symmetric
    reference = np.zeros((bandwidth + 1) * units.n_dofs)
    reference[flat] = data[upper]
    band = units.banded(data)
    np.testing.assert_array_equal(band, reference.reshape(units.n_dofs, bandwidth + 1).T)
    assert band.flags.f_contiguous
    dense = units.matrix(data).toarray()[np.ix_(units.band_order, units.band_order)]
    for d in range(bandwidth + 1):
        np.testing.assert_array_equal(band[bandwidth - d, d:], np.diagonal(dense, d))


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 30),
    density=st.floats(0.0, 1.0),
    zeros=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**16),
)
def test_a_matrix_without_stored_zeros_is_the_copy_without_them(n, density, zeros, seed):
    """``assembly.nonzeros`` (the mass matrix the Lanczos products use, the first unit
    mass) holds the same arrays, bit for bit and in the same index types, as ``copy()``
    then ``eliminate_zeros()``, for any share of stored zeros (empty rows, an empty
    matrix), and leaves the matrix it reads as it was."""
    rng = np.random.default_rng(seed)
    matrix = sp.random(n, n, density=density, format="csr", random_state=rng)
    matrix.data[rng.random(matrix.nnz) < zeros] = 0.0
    before = matrix.copy()
    expected = matrix.copy()
    expected.eliminate_zeros()
    kept = assembly.nonzeros(matrix)
    for name in ("data", "indices", "indptr"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(expected, name))
        assert getattr(kept, name).dtype == getattr(expected, name).dtype
        np.testing.assert_array_equal(getattr(matrix, name), getattr(before, name))


def test_mass_matrix_reuses_its_kept_entries_only_while_the_zeros_stay():
    """``UnitMatrices.mass_matrix`` (the solve's mass matrix) is ``nonzeros`` of the
    matrix, bit for bit, on a symmetric lay-up's inertia (I1 = 0: the u-theta couplings are
    stored zeros), then on an unsymmetric one's (I1 != 0: more entries kept) and back, in
    turn: the remembered kept-entry arrays are those of the zeros each call has, never
    another's, at most ``MASS_PATTERNS`` of them, counted in ``nbytes``."""
    units = UnitMatrices(PlateMesh(0.12, 0.1, 3, 2), ShearDifferencePlate)
    symmetric, unsymmetric = np.array([2.0, 0.0, 1e-3]), np.array([2.0, 1e-4, 1e-3])
    before = units.nbytes
    for inertia in (symmetric, symmetric * 3, unsymmetric, symmetric, unsymmetric * 2, symmetric):
        data = inertia @ units.mass_data
        kept, expected = units.mass_matrix(data), assembly.nonzeros(units.matrix(data))
        for name in ("data", "indices", "indptr"):
            np.testing.assert_array_equal(getattr(kept, name), getattr(expected, name))
    assert np.count_nonzero(unsymmetric @ units.mass_data) > np.count_nonzero(symmetric @ units.mass_data)
    assert units.nbytes > before
    # Both patterns are remembered (the configurations a fit solves in turn), no more than
    # MASS_PATTERNS however many the calls bring.
    assert len(units.__dict__["kept_mass"]) == 2
    for zeroed in range(1, 2 * assembly.MASS_PATTERNS):
        data = symmetric @ units.mass_data
        data[:zeroed] = 0.0  # another set of zeros each time
        np.testing.assert_array_equal(
            units.mass_matrix(data).indices, assembly.nonzeros(units.matrix(data)).indices
        )
    assert len(units.__dict__["kept_mass"]) == assembly.MASS_PATTERNS
