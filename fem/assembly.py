"""Unit stiffness and mass matrices of a mesh, assembled once.

Every element of a structured mesh is the same rectangle, so one set of element
unit matrices serves them all.  Assembly maps the 48 x 48 local entries onto one
global CSR pattern through a sparse aggregation matrix; a global matrix for any
laminate is then a weighted sum of data arrays: ``K.data = X @ stiffness_data``.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
import scipy.sparse as sp

from .elements import HermitePlate
from .laminate import VOIGT_PAIRS
from .mesh import PlateMesh

DOFS_PER_NODE = len(HermitePlate.NODE_DOFS)


@dataclass(frozen=True)
class UnitMatrices:
    """Assembled unit matrices of one mesh (shared by every configuration on it)."""

    mesh: PlateMesh

    @cached_property
    def element(self) -> HermitePlate:
        return HermitePlate(*self.mesh.element_size)

    @cached_property
    def element_dofs(self) -> np.ndarray:
        """Global DOF numbers per element (n_elements, 48)."""
        nodes = self.mesh.element_nodes
        return (nodes[:, :, None] * DOFS_PER_NODE + np.arange(DOFS_PER_NODE)).reshape(len(nodes), -1)

    @property
    def n_dofs(self) -> int:
        return self.mesh.n_nodes * DOFS_PER_NODE

    @cached_property
    def element_stiffness(self) -> np.ndarray:
        """(18, 48, 48) element unit stiffness matrices."""
        return self.element.unit_stiffness(VOIGT_PAIRS)

    @cached_property
    def element_mass(self) -> np.ndarray:
        """(3, 48, 48) element unit mass matrices (I0, I1, I2)."""
        return self.element.unit_mass()

    @cached_property
    def _pattern(self) -> tuple[np.ndarray, np.ndarray, sp.csr_matrix]:
        """CSR indices/indptr of the global pattern and the aggregation matrix
        (nnz x 2304) summing local entries into global ones."""
        dofs = self.element_dofs
        rows = np.repeat(dofs, 48, axis=1).ravel()
        cols = np.tile(dofs, (1, 48)).ravel()
        local = np.tile(np.arange(48 * 48), len(dofs))
        # Number the distinct (row, col) pairs in CSR order.
        key = rows.astype(np.int64) * self.n_dofs + cols
        unique, slot = np.unique(key, return_inverse=True)
        g_rows, g_cols = np.divmod(unique, self.n_dofs)
        indptr = np.searchsorted(g_rows, np.arange(self.n_dofs + 1))
        aggregate = sp.csr_matrix(
            (np.ones(slot.size), (slot, local)), shape=(unique.size, 48 * 48)
        )
        return g_cols.astype(np.int32), indptr.astype(np.int32), aggregate

    @cached_property
    def stiffness_data(self) -> np.ndarray:
        """(18, nnz) CSR data of the global unit stiffness matrices."""
        aggregate = self._pattern[2]
        return (aggregate @ self.element_stiffness.reshape(18, -1).T).T

    @cached_property
    def mass_data(self) -> np.ndarray:
        """(3, nnz) CSR data of the global unit mass matrices."""
        aggregate = self._pattern[2]
        return (aggregate @ self.element_mass.reshape(3, -1).T).T

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """A global CSR matrix on the shared pattern from its data array."""
        indices, indptr, _ = self._pattern
        return sp.csr_matrix((data, indices, indptr), shape=(self.n_dofs, self.n_dofs))

    def stiffness(self, coefficients: np.ndarray) -> sp.csr_matrix:
        """K = sum_c X_c K_c for the 18 laminate coefficients X."""
        return self.matrix(coefficients @ self.stiffness_data)

    def mass(self, inertia: np.ndarray) -> sp.csr_matrix:
        """M = sum_j I_j M_j for the inertia terms [I0, I1, I2]."""
        return self.matrix(inertia @ self.mass_data)

    @cached_property
    def bandwidth(self) -> int:
        """Upper semi-bandwidth of the global pattern (row-by-row node numbering keeps it
        at about 12 (nx + 2))."""
        indices, indptr, _ = self._pattern
        rows = np.repeat(np.arange(self.n_dofs), np.diff(indptr))
        return int(np.max(indices - rows))

    @cached_property
    def _banded_slots(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions of the upper-triangle CSR entries in LAPACK upper banded storage."""
        indices, indptr, _ = self._pattern
        rows = np.repeat(np.arange(self.n_dofs), np.diff(indptr))
        upper = np.flatnonzero(indices >= rows)
        flat = (self.bandwidth + rows[upper] - indices[upper]) * self.n_dofs + indices[upper]
        return upper, flat

    def banded(self, data: np.ndarray) -> np.ndarray:
        """Upper banded storage (bandwidth + 1, n_dofs) of a symmetric matrix given by CSR data."""
        upper, flat = self._banded_slots
        out = np.zeros((self.bandwidth + 1) * self.n_dofs)
        out[flat] = data[upper]
        return out.reshape(self.bandwidth + 1, self.n_dofs)

    def element_quadratic_forms(self, modes: np.ndarray, matrices: np.ndarray) -> np.ndarray:
        """phi_i^T K_c phi_i summed over elements, for every unit matrix c and mode i.

        modes: (n_dofs, m); matrices: (n_c, 48, 48) element matrices.  Returns (n_c, m).
        Works per element, so it costs O(n_elements * 48^2 * m), not a sparse product per c.
        """
        local = modes[self.element_dofs]  # (ne, 48, m)
        second_moment = np.einsum("eam,ebm->mab", local, local).reshape(modes.shape[1], -1)
        return matrices.reshape(len(matrices), -1) @ second_moment.T

    @cached_property
    def rigid_body_modes(self) -> np.ndarray:
        """The six rigid-body displacement fields (n_dofs, 6): u, v, w translations,
        rotations w = y and w = x, and the in-plane rotation u = -y, v = x."""
        x, y = self.mesh.node_xy.T
        r = np.zeros((self.mesh.n_nodes, DOFS_PER_NODE, 6))
        names = HermitePlate.NODE_DOFS
        r[:, names.index("u"), 0] = 1
        r[:, names.index("v"), 1] = 1
        r[:, names.index("w"), 2] = 1
        r[:, names.index("w"), 3] = y
        r[:, names.index("w_y"), 3] = 1
        r[:, names.index("w"), 4] = x
        r[:, names.index("w_x"), 4] = 1
        r[:, names.index("u"), 5] = -y
        r[:, names.index("u_y"), 5] = -1
        r[:, names.index("v"), 5] = x
        r[:, names.index("v_x"), 5] = 1
        return r.reshape(-1, 6)


@lru_cache(maxsize=16)
def unit_matrices(mesh: PlateMesh) -> UnitMatrices:
    """The (cached) unit matrices of a mesh."""
    return UnitMatrices(mesh)
