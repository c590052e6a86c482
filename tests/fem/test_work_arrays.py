"""The modal solve's kept work arrays: reused by role and thread, within their byte budget,
and a solve on a kept array that still holds another solve's numbers gives the numbers
of a solve on fresh memory, bit for bit."""

import threading

import numpy as np
import pytest

from fem.laminates.laminate import Laminate, Layer
from fem.laminates.material import Material
from fem.model import solve_laminate
from fem.solver import work_arrays
from fem.solver.mesh import PlateMesh
from fem.solver.work_arrays import work_array


@pytest.fixture
def kept_from_any_size(monkeypatch):
    """Every request kept (the threshold would leave the small test meshes' arrays fresh),
    and no array of an earlier test."""
    monkeypatch.setattr(work_arrays, "KEPT_FROM_BYTES", 0)
    work_arrays._KEPT.by_role.clear()
    yield
    work_arrays._KEPT.by_role.clear()


def test_a_role_reuses_its_array_and_roles_do_not_share(kept_from_any_size):
    band = work_array("band", 1000)
    assert np.shares_memory(work_array("band", 800), band)  # smaller: the same memory
    other = work_array("reversed factor", 1000)
    assert not np.shares_memory(other, band)
    larger = work_array("band", 2000)  # larger: a new array, kept in the old one's place
    assert larger.size == 2000 and not np.shares_memory(larger, band)
    assert np.shares_memory(work_array("band", 2000), larger)
    assert work_arrays.kept_bytes() == 8 * (2000 + 1000)


def test_the_budget_bounds_what_is_kept(kept_from_any_size, monkeypatch):
    monkeypatch.setattr(work_arrays, "WORK_ARRAY_BYTES", 8 * 1500)
    first = work_array("band", 1000)
    beyond = work_array("reversed factor", 1000)  # 16,000 bytes would exceed 12,000: not kept
    assert beyond.size == 1000 and work_arrays.kept_bytes() == 8000
    assert not np.shares_memory(work_array("reversed factor", 1000), beyond)
    assert np.shares_memory(work_array("band", 1000), first)


def test_small_arrays_are_not_kept():
    work_arrays._KEPT.by_role.clear()
    small = work_arrays.KEPT_FROM_BYTES // 8 - 1
    assert not np.shares_memory(work_array("band", small), work_array("band", small))
    assert work_arrays.kept_bytes() == 0


def test_each_thread_keeps_its_own(kept_from_any_size):
    here = work_array("band", 100)
    there = {}
    worker = threading.Thread(target=lambda: there.update(array=work_array("band", 100)))
    worker.start()
    worker.join()
    assert not np.shares_memory(here, there["array"])
    assert np.shares_memory(work_array("band", 100), here)


def _plate(thickness_mm: float) -> Laminate:
    steel = Material("steel", 210e9, 210e9, 80.8e9, 0.3, 7850.0, G13=80.8e9, G23=80.8e9)
    return Laminate((Layer(steel, 1e-3 * thickness_mm),))


def test_a_solve_on_kept_arrays_is_the_solve_on_fresh_ones(kept_from_any_size, monkeypatch):
    """Two first-order shear solves in turn (a 3 mm and a 5 mm plate, the second on the
    arrays the first left holding its factor: fill-in where the second's band must be
    zero), against each solved on fresh memory: the same frequencies and shapes bit for
    bit.  The mesh's factor (5,400 DOFs, 15 MB) is above ``modal.BLOCK_SOLVE_BYTES``, so
    the reversed factor is one of the arrays."""
    mesh = PlateMesh(0.25, 0.2, 17, 14)
    plates = [_plate(3.0), _plate(5.0)]
    solve_laminate.cache_clear()
    kept = [solve_laminate(p, mesh, 8, transverse_shear=True).modes for p in plates]
    assert work_arrays.kept_bytes() > 2 * 8 * 2**20  # the band and the reversed factor
    monkeypatch.setattr(work_arrays, "KEPT_FROM_BYTES", 2**62)  # nothing kept: fresh arrays
    fresh = []
    for p in plates:
        solve_laminate.cache_clear()
        fresh.append(solve_laminate(p, mesh, 8, transverse_shear=True).modes)
    solve_laminate.cache_clear()
    for a, b in zip(kept, fresh):
        np.testing.assert_array_equal(a.eigenvalues, b.eigenvalues)
        np.testing.assert_array_equal(a.shapes, b.shapes)
