"""Unit stiffness and mass matrices of a mesh, assembled once.

Elements of a structured mesh come in few sizes (one on an equal mesh, a few more
where it is graded towards the edges), so one set of element unit matrices per size
serves them all.  Assembly sums each element's n x n local entries of its size's
matrices onto one global CSR pattern, node-pair block by block (``PairBlocks``); a
global matrix for any laminate is then a weighted sum of data arrays:
``K.data = X @ stiffness_data``, or, cheaper in memory for elements with many DOFs, the
aggregation of the weighted sum of element matrices (``combined_data``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from ..elements import HermitePlate
from ..elements.hermite_plate import EnergyQuadrature, ProjectionQuadrature
from ..laminates.laminate import VOIGT_PAIRS
from .mesh import PlateMesh
from .solve_cache import UNIT_CACHE_BYTES, SharedCache

#: Columns (elements x fields) integrated at once: the strains at the quadrature points of
#: a chunk take (quadrature points x strains x columns) floats, ~40 MB for a shear mesh.
GATHERED_COLUMNS = 20_000
#: Element unit matrices are kept sparse above this [bytes] of dense storage (the
#: layerwise element's 90-170 MB; the thin and shear elements' are a few MB).
SPARSE_UNITS_ABOVE = 32 << 20
#: Global entries summed at once (``PairBlocks``): 8 MB of a vector's sums, the same
#: again as element entries by pair, where all at once a second copy of every global entry
#: is a temporary (64 MB at 16,200 layerwise DOFs, several times that for a block).
CHUNK_ENTRIES = 1 << 20
#: Kept-entry patterns of the mass matrix remembered per unit set
#: (``UnitMatrices.mass_matrix``): the configurations that share a mesh in one fit (a
#: plate bonded on top, one below, one more), 16 MB each at 11,880 layerwise DOFs.
MASS_PATTERNS = 3


@dataclass(frozen=True)
class UnitMatrices:
    """Assembled unit matrices of one mesh and element type (shared by every
    configuration on it)."""

    mesh: PlateMesh
    element_type: type = HermitePlate

    @cached_property
    def elements(self) -> list[HermitePlate]:
        """One element per distinct element size of the mesh (``PlateMesh.size_groups``)."""
        return [self.element_type(hx, hy) for hx, hy in self.mesh.size_groups[0]]

    @property
    def dofs_per_node(self) -> int:
        return len(self.element_type.NODE_DOFS)

    @cached_property
    def element_dofs(self) -> np.ndarray:
        """Global DOF numbers per element (n_elements, n_local)."""
        nodes = self.mesh.element_nodes
        per_node = self.dofs_per_node
        return (nodes[:, :, None] * per_node + np.arange(per_node)).reshape(len(nodes), -1)

    @property
    def n_dofs(self) -> int:
        return self.mesh.n_nodes * self.dofs_per_node

    @cached_property
    def element_stiffness(self) -> np.ndarray | sp.csr_matrix:
        """(n_c, G n_local^2) element unit stiffness matrices (18 CLT coefficients, then any
        the element adds, e.g. transverse shear) of the G element sizes, each flattened,
        the sizes side by side, dense or sparse (``_per_size``)."""
        return self._per_size(lambda e: e.unit_stiffness(VOIGT_PAIRS))

    @cached_property
    def element_mass(self) -> np.ndarray | sp.csr_matrix:
        """(n_inertia, G n_local^2) element unit mass matrices (I0, I1, I2, ...) of the G
        sizes, laid out as ``element_stiffness``."""
        return self._per_size(lambda e: e.unit_mass())

    def _per_size(self, matrices) -> np.ndarray | sp.csr_matrix:
        """matrices(element) (n_c, n, n) of every element size as one (n_c, G n^2) array,
        sparse where the dense one would hold more than ``SPARSE_UNITS_ABOVE`` bytes: a
        unit matrix couples few of an element's fields (2.4 % of the layerwise element's
        entries are non-zero), so a graded layerwise sandwich's 169 MB of stiffness units
        are 7 MB.  The thin and first-order shear elements' (a few MB) stay dense, their
        sums to the last bit as before (a sparse sum's order changes round-off, which a
        fit along an undetermined direction can follow elsewhere)."""
        first = matrices(self.elements[0]).reshape(-1, self.element_dofs.shape[1] ** 2)
        if first.nbytes * len(self.elements) <= SPARSE_UNITS_ABOVE:
            out = np.empty((first.shape[0], len(self.elements) * first.shape[1]))
            out[:, : first.shape[1]] = first
            for g, element in enumerate(self.elements[1:], start=1):
                out[:, g * first.shape[1] : (g + 1) * first.shape[1]] = matrices(element).reshape(first.shape)
            return out
        rest = (sp.csr_matrix(matrices(e).reshape(first.shape)) for e in self.elements[1:])
        return sp.hstack([sp.csr_matrix(first), *rest], format="csr")

    @cached_property
    def _pattern(self) -> tuple[np.ndarray, np.ndarray, PairBlocks]:
        """CSR indices/indptr of the global pattern and its node-pair blocks (``PairBlocks``),
        which sum each element's local entries, those of its size's matrices, into global
        ones and lay a matrix out as a band.

        Every DOF belongs to a node (global DOF = node x dofs_per_node + field) and an
        element couples all DOFs of its nodes, so the pattern is dense node-pair blocks:
        the distinct pairs of nodes that share an element (16 per element, sorted once),
        each a dofs_per_node^2 block.  In CSR order the rows of node a follow those of the
        nodes before it (dofs_per_node^2 x their neighbour counts), each row of node a holds
        its neighbours' blocks in node order, so an entry's column is arithmetic on its
        pair's rank; the same arrays as sorting every element entry, 4-6x faster on a
        layerwise mesh (``tests/fem/test_assembly_pattern.py``)."""
        nodes = self.mesh.element_nodes
        per_node, n_nodes = self.dofs_per_node, self.mesh.n_nodes
        corners = nodes.shape[1]
        key = np.repeat(nodes, corners, axis=1).astype(np.int64) * n_nodes + np.tile(nodes, (1, corners))
        pairs, pair_of_entry = np.unique(key, return_inverse=True)
        row_node, column_node = np.divmod(pairs, n_nodes)
        neighbours = np.bincount(row_node, minlength=n_nodes)
        first_pair = np.searchsorted(row_node, np.arange(n_nodes))
        nnz = int(per_node * per_node * neighbours.sum())
        lengths = np.repeat(neighbours * per_node, per_node)
        indptr = np.concatenate([[0], np.cumsum(lengths)])
        field = np.arange(per_node)
        node_columns = (column_node[:, None] * per_node + field).ravel()
        rows_node = np.repeat(np.arange(self.n_dofs) // per_node, lengths)
        within = np.arange(nnz) - np.repeat(indptr[:-1], lengths)
        columns = node_columns[first_pair[rows_node] * per_node + within].astype(np.int32)
        del rows_node, within
        # each element's (corner a, corner b) entries, as a column (size g, a, b) of the pair
        # they fall on; sorted per row, so each pair's block sums them in that order
        size = self.mesh.size_groups[1]
        local = size[:, None] * corners * corners + np.arange(corners * corners)
        blocks = sp.csr_matrix(
            (np.ones(key.size), (pair_of_entry.ravel(), local.ravel())),
            shape=(pairs.size, len(self.elements) * corners * corners),
        )
        blocks.sort_indices()
        # runs of consecutive nodes with as many neighbours: (first pair, nodes, neighbours)
        starts = np.flatnonzero(np.diff(neighbours, prepend=-1))
        counts = np.diff(np.append(starts, n_nodes))
        runs = np.column_stack([first_pair[starts], counts, neighbours[starts]])
        pair_nodes = np.stack([row_node, column_node]).astype(np.int32)
        return columns, indptr.astype(np.int32), PairBlocks(blocks, pair_nodes, runs, per_node, corners)

    @cached_property
    def stiffness_data(self) -> np.ndarray:
        """(n_c, nnz) CSR data of the global unit stiffness matrices."""
        return (self._pattern[2] @ _dense(self.element_stiffness).T).T

    @cached_property
    def mass_data(self) -> np.ndarray:
        """(n_inertia, nnz) CSR data of the global unit mass matrices (I0, I1, I2, and more
        for elements with more inertia terms)."""
        return (self._pattern[2] @ _dense(self.element_mass).T).T

    @cached_property
    def first_unit_mass(self) -> sp.csr_matrix:
        """The first unit mass matrix (the I0 term) alone: a mass weight for comparing mode
        shapes, without assembling every inertia term (the layerwise element has ~100).
        Its structural zeros are dropped (``nonzeros``):
        the translational inertia couples only u-u, v-v and w-w, and the shape
        comparisons' products take 2.6x less time without the rest of the pattern (63
        modes of the paper's plate: 1.7 M stored entries to 0.57 M, 26 ms to 10 ms)."""
        return nonzeros(self.matrix(self._pattern[2] @ _dense(self.element_mass[:1])[0]))

    def combined_data(self, weights: np.ndarray, element_matrices: np.ndarray | sp.csr_matrix) -> np.ndarray:
        """CSR data of sum_c weights_c (assembled element_matrices_c), summed per element
        first: one aggregation instead of n_c unit data arrays in memory."""
        combined = (
            element_matrices.T @ weights if sp.issparse(element_matrices) else weights @ element_matrices
        )
        return self._pattern[2] @ combined

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """A global CSR matrix on the shared pattern from its data array."""
        indices, indptr, _ = self._pattern
        return sp.csr_matrix((data, indices, indptr), shape=(self.n_dofs, self.n_dofs))

    def mass_matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """The global matrix of CSR ``data`` without its stored zeros, as ``nonzeros`` gives
        it (the same arrays), the kept entries' index arrays reused where an earlier call
        had the zeros where ``data`` has them: they depend on the mesh and on which inertia
        terms a stack has, not on its values, so a fit builds them once a pattern (20 ms of
        a 0.5 s layerwise solve of 11,880 DOFs).  The last ``MASS_PATTERNS`` are kept: a
        plate bonded on top and one bonded below share a mesh but not their zeros (one
        sign of I1 cancels entries the other keeps), and a fit solves them in turn.  The
        memory is counted in ``nbytes``."""
        kept = data != 0
        known = self.__dict__.get("kept_mass", ())
        found = next((pattern for pattern in known if np.array_equal(kept, pattern[0])), None)
        if found is None:
            indices, indptr, _ = self._pattern
            found = (kept, *_kept_pattern(kept, indices, indptr))
        self.__dict__["kept_mass"] = (found, *(p for p in known if p is not found))[:MASS_PATTERNS]
        return sp.csr_matrix((data[kept], found[1], found[2]), shape=(self.n_dofs, self.n_dofs))

    def stiffness(self, coefficients: np.ndarray) -> sp.csr_matrix:
        """K = sum_c X_c K_c for the 18 laminate coefficients X."""
        return self.matrix(coefficients @ self.stiffness_data)

    def mass(self, inertia: np.ndarray) -> sp.csr_matrix:
        """M = sum_j I_j M_j for the inertia terms [I0, I1, I2]."""
        return self.matrix(inertia @ self.mass_data)

    @cached_property
    def band_order(self) -> np.ndarray:
        """The DOF order of the banded factor: nodes numbered across the mesh's shorter side,
        so the semi-bandwidth is about dofs_per_node (nodes across + 1); the global
        numbering runs along x whatever the plate's shape.  ``rank`` is its inverse."""
        nodes = np.arange(self.mesh.n_nodes).reshape(self.mesh.ny + 1, self.mesh.nx + 1)
        across = nodes.T.ravel() if self.mesh.ny < self.mesh.nx else nodes.ravel()
        return (across[:, None] * self.dofs_per_node + np.arange(self.dofs_per_node)).ravel()

    @cached_property
    def rank(self) -> np.ndarray:
        """Position of each global DOF in ``band_order``."""
        return np.argsort(self.band_order)

    @cached_property
    def _node_rank(self) -> np.ndarray:
        """Position of each node in ``band_order`` (its fields follow one another there)."""
        return self.rank[:: self.dofs_per_node] // self.dofs_per_node

    @cached_property
    def bandwidth(self) -> int:
        """Upper semi-bandwidth of the global pattern in ``band_order``."""
        rows, columns = self._pattern[2].pair_nodes
        farthest = int(np.max(self._node_rank[columns] - self._node_rank[rows]))
        return (farthest + 1) * self.dofs_per_node - 1

    def banded(self, data: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Upper banded storage (bandwidth + 1, n_dofs), Fortran-ordered as LAPACK takes it,
        of a symmetric matrix given by CSR data, its DOFs in ``band_order``.  ``out``: a
        flat array of ``band_size`` entries to write it into (the solve's work array)."""
        return self._pattern[2].banded(data, self._node_rank, self.bandwidth, out)

    @property
    def band_size(self) -> int:
        """Entries of the band storage (``banded``)."""
        return (self.bandwidth + 1) * self.n_dofs

    def quadratic_forms(self, modes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """phi_i^T K_c phi_i and phi_i^T M_j phi_i for every unit stiffness matrix c, unit
        mass matrix j and mode i: (n_c, m) and (n_inertia, m).

        modes: (n_dofs, m).  Integrated element by element from the modes' strains and
        displacements at the quadrature points (``EnergyQuadrature``), one element size at a
        time, so it costs O(n_elements * n_local * m) per operator and never reads the
        element matrices (a graded layerwise mesh's are ~400 MB).
        """
        stiffness, inertia = 0.0, 0.0
        for element, x in self._gathered(modes):
            integral = EnergyQuadrature(element.weights, x)
            shape = (-1, x.shape[1] // modes.shape[1], modes.shape[1])
            stiffness = stiffness + element.unit_stiffness(VOIGT_PAIRS, integral).reshape(shape).sum(axis=1)
            inertia = inertia + element.unit_mass(integral).reshape(shape).sum(axis=1)
        return stiffness, inertia

    def projections(self, basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """V^T K_c V and V^T M_j V for every unit stiffness matrix c and unit mass matrix j:
        (n_c, r, r) and (n_inertia, r, r), for a basis V (n_dofs, r).  Integrated like
        ``quadratic_forms`` (``ProjectionQuadrature``), so the global unit matrices of a
        layerwise mesh (~180 of them) are never assembled."""
        rank = basis.shape[1]
        stiffness, inertia = 0.0, 0.0
        for element, x in self._gathered(basis):
            integral = ProjectionQuadrature(element.weights, x, rank)
            stiffness = stiffness + element.unit_stiffness(VOIGT_PAIRS, integral)
            inertia = inertia + element.unit_mass(integral)
        return stiffness, inertia

    def _gathered(self, fields: np.ndarray):
        """Per element size, in chunks of at most ``GATHERED_COLUMNS`` columns: the element
        and ``fields`` (n_dofs, m) gathered on its elements, element-major (n_local, k m)."""
        local = fields[self.element_dofs]  # (ne, n_local, m)
        group = self.mesh.size_groups[1]
        chunk = max(1, GATHERED_COLUMNS // fields.shape[1])
        for g, element in enumerate(self.elements):
            x = local if len(self.elements) == 1 else local[group == g]
            for start in range(0, len(x), chunk):
                part = x[start : start + chunk]
                yield element, part.transpose(1, 0, 2).reshape(part.shape[1], -1)

    @cached_property
    def rigid_body_modes(self) -> np.ndarray:
        """The element type's six rigid-body displacement fields on this mesh (n_dofs, 6)."""
        return self.element_type.rigid_body_modes(self.mesh.node_xy)

    @property
    def nbytes(self) -> int:
        """What the unit set holds so far [bytes] (its parts are made when first used)."""
        return sum(_nbytes(value) for value in self.__dict__.values())


@dataclass(frozen=True)
class PairBlocks:
    """A mesh's global pattern as node-pair blocks: the pairs of nodes that share an
    element, each a pn x pn block, in CSR order (by row node, then column node).

    Its index arrays hold an entry per element and corner pair, or per pair, none per
    stored entry (a layerwise mesh of 16,200 DOFs: kB instead of the 119 MB of an
    aggregation matrix with one column per element entry and of the band's slots).

    ``blocks`` (pairs x G corners^2, ones): row p holds the (size g, corner a, corner b)
    of every element whose corners a and b are pair p's nodes, in that order; summing the
    elements' (a, b) blocks along a row gives the pair's block (``@``).  ``pair_nodes``
    (2 x pairs): each pair's row and column node.  CSR stores node a's rows one after
    another, each through all its pairs' blocks, so a run of nodes with as many neighbours
    (``runs``: first pair, nodes, neighbours) is one span of data, a block's entries
    ``nodes x pn x neighbours x pn`` apart."""

    blocks: sp.csr_matrix
    pair_nodes: np.ndarray
    runs: np.ndarray
    per_node: int
    corners: int

    def __matmul__(self, local: np.ndarray) -> np.ndarray:
        """Global CSR data (nnz, ...) of element matrices ``local`` (G n_local^2, ...),
        each of the G sizes' flattened in the element's local order; about
        ``CHUNK_ENTRIES`` values summed at a time.  Every global entry is the sum of its
        element entries in the order (g, a, b), the order of an aggregation matrix with
        one column per element entry, bit for bit."""
        pn, c = self.per_node, self.corners
        tail = local.shape[1:]
        width = int(np.prod(tail, dtype=np.int64))
        by_pair = (
            local.reshape(-1, c, pn, c, pn, width).transpose(0, 1, 3, 2, 4, 5).reshape(-1, pn * pn * width)
        )
        out = np.empty(
            (self.blocks.shape[0] * pn * pn, *tail), dtype=np.result_type(self.blocks.dtype, local)
        )
        batch = max(1, CHUNK_ENTRIES // (pn * pn * width))  # pairs summed at a time
        runs, ends = self.runs, self.runs[:, 0] + self.runs[:, 1] * self.runs[:, 2]
        start = 0
        while start < len(runs):  # consecutive runs of at most ``batch`` pairs (one at least)
            first, stop = runs[start, 0], start + 1
            while stop < len(runs) and ends[stop] - first <= batch:
                stop += 1
            summed = (self.blocks[first : ends[stop - 1]] @ by_pair).reshape(-1, pn, pn, *tail)
            for run in runs[start:stop]:
                offset, nodes, neighbours = run[0] - first, run[1], run[2]
                part = summed[offset : offset + nodes * neighbours].reshape(nodes, neighbours, pn, pn, *tail)
                self._run_blocks(out, run)[...] = part.swapaxes(1, 2)
            start = stop
        return out

    def _run_blocks(self, data: np.ndarray, run) -> np.ndarray:
        """A run's span of CSR ``data`` (nnz, ...) as its blocks, a view: [n, i, q, j] is row
        field i of the run's n-th node against column field j of its q-th neighbour."""
        first, nodes, neighbours = run
        pn = self.per_node
        span = data[first * pn * pn : (first + nodes * neighbours) * pn * pn]
        return span.reshape(nodes, pn, neighbours, pn, *data.shape[1:])

    def banded(
        self, data: np.ndarray, node_rank: np.ndarray, bandwidth: int, out: np.ndarray | None = None
    ) -> np.ndarray:
        """Upper banded storage (bandwidth + 1, n_dofs), Fortran-ordered as LAPACK takes it,
        of a symmetric matrix given by CSR ``data``, its nodes in the order ``node_rank``:
        entry (row, column) at column (bandwidth + 1) + bandwidth + row - column.  Each
        pair of a run whose column node comes later is copied whole, one on the diagonal
        its upper triangle; the band positions are worked out per run and neighbour.
        ``out``: a flat array of (bandwidth + 1) x n_dofs entries to write it into."""
        pn, b = self.per_node, bandwidth
        size = (b + 1) * len(node_rank) * pn
        if out is None:
            out = np.zeros(size)
        else:
            out[:] = 0.0
        field = np.arange(pn)
        within = field[:, None] + b * field[None, :]  # of entry (i, j) from its block's (0, 0)
        upper = field[:, None] <= field[None, :]
        rows, columns = node_rank[self.pair_nodes].astype(np.int64)
        later = columns - rows
        corner = columns * pn * b + b + rows * pn  # block (0, 0): column pn c, row pn r
        for run in self.runs:
            first, nodes, neighbours = run
            pairs = slice(first, first + nodes * neighbours)
            shape = (nodes, neighbours)
            ahead, start = later[pairs].reshape(shape), corner[pairs].reshape(shape)
            blocks = self._run_blocks(data, run)
            for q in range(neighbours):
                whole = ahead[:, q] > 0
                if whole.any():
                    out[start[whole, q][:, None, None] + within] = blocks[whole, :, q, :]
                diagonal = ahead[:, q] == 0
                if diagonal.any():
                    positions = start[diagonal, q][:, None, None] + within
                    out[positions[:, upper]] = blocks[diagonal, :, q, :][:, upper]
        return out.reshape(len(node_rank) * pn, b + 1).T

    @property
    def nbytes(self) -> int:
        blocks = self.blocks
        arrays = (blocks.data, blocks.indices, blocks.indptr, self.pair_nodes, self.runs)
        return sum(a.nbytes for a in arrays)


def nonzeros(matrix: sp.csr_matrix) -> sp.csr_matrix:
    """``matrix`` without its stored zeros, as ``copy()`` then ``eliminate_zeros()`` give it
    (the same arrays), built from the kept entries only: the pattern's index arrays,
    shared by every matrix of the mesh, are neither changed nor copied whole (a layerwise
    mesh's are tens of MB)."""
    kept = matrix.data != 0
    return sp.csr_matrix(
        (matrix.data[kept], *_kept_pattern(kept, matrix.indices, matrix.indptr)), shape=matrix.shape
    )


def _kept_pattern(kept: np.ndarray, indices: np.ndarray, indptr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The CSR (indices, indptr) of the entries ``kept`` (a mask over ``indices``) alone."""
    counts = np.concatenate([[0], np.cumsum(kept, dtype=indptr.dtype)])
    return indices[kept], counts[indptr]


def _nbytes(part) -> int:
    """The bytes ``part`` (an array, a sparse matrix or node-pair blocks) holds of its own."""
    if isinstance(part, tuple):
        return sum(_nbytes(p) for p in part)
    if isinstance(part, (np.ndarray, PairBlocks)):
        return part.nbytes
    if sp.issparse(part):
        return sum(
            _nbytes(getattr(part, name)) for name in ("data", "indices", "indptr") if hasattr(part, name)
        )
    return 0


def _dense(units: np.ndarray | sp.csr_matrix) -> np.ndarray:
    return units.toarray() if sp.issparse(units) else units


#: Every unit set in use, within ``UNIT_CACHE_BYTES`` (``solve_cache.SharedCache``).
UNIT_CACHE = SharedCache(UNIT_CACHE_BYTES, lambda units: units.nbytes)


def unit_matrices(mesh: PlateMesh, element_type: type = HermitePlate) -> UnitMatrices:
    """The (cached) unit matrices of a mesh for an element type (default: Kirchhoff)."""
    return UNIT_CACHE.get((mesh, element_type), lambda: UnitMatrices(mesh, element_type))
