"""The byte-bounded caches: modal solves evicted by size, least recently used first; unit
matrices shared, bounded by what they hold, let go with the solves that hold them."""

import gc
import weakref

import numpy as np

from fem.model import SOLUTION_OVERHEAD_BYTES, solve_laminate
from fem.solver.assembly import UNIT_CACHE, unit_matrices
from fem.solver.mesh import PlateMesh
from fem.solver.solve_cache import SharedCache, bytes_bounded_cache
from studies.common import true_model


def test_values_are_evicted_by_bytes_least_recently_used_first():
    calls = []

    @bytes_bounded_cache(3000, lambda value: value.nbytes)
    def array(n):
        calls.append(n)
        return np.zeros(n)  # 8 n bytes

    array(100), array(150)  # 800 + 1200 bytes
    array(100)  # a hit: 100 is now the most recent
    array(120)  # 960 more: 2960 in all, within the budget
    assert array.cache_info().entries == 3 and array.cache_info().bytes == 2960
    array(50)  # 400 more: 150, the least recently used, goes
    info = array.cache_info()
    assert info.bytes == 2160 and info.entries == 3 and info.hits == 1
    array(150)
    assert calls == [100, 150, 120, 50, 150]
    array(1000)  # 8000 bytes: more than the budget, returned but not kept
    assert array.cache_info().bytes <= 3000
    array.cache_clear()
    assert array.cache_info().entries == 0 and array.cache_info().bytes == 0


def test_the_solve_cache_counts_a_solves_shapes():
    """A solve is counted at its mode shapes and frequencies plus the fixed allowance, and
    the same laminate solved again is a hit."""
    solve_laminate.cache_clear()
    model = true_model()
    solution = model.solve("original")
    info = solve_laminate.cache_info()
    assert info.entries == 1 and info.misses == 1
    assert (
        info.bytes
        == solution.modes.shapes.nbytes + solution.modes.eigenvalues.nbytes + SOLUTION_OVERHEAD_BYTES
    )
    assert model.solve("original") is solution and solve_laminate.cache_info().hits == 1


def test_shared_values_are_kept_by_bytes_and_found_again_while_held():
    """The unit-matrix cache's rule: the most recent values within the budget (measured at
    every use: values grow), never fewer than the latest; a value let go but still held
    elsewhere is returned again, not made twice; each value let go is announced once."""
    made, dropped = [], []

    class Grows:
        def __init__(self, n):
            self.n = n

    def make(n):
        made.append(n)
        return Grows(n)

    cache = SharedCache(1000, lambda value: value.n)
    cache.on_drop.append(lambda value: dropped.append(value.n))
    a = cache.get("a", lambda: make(400))
    cache.get("b", lambda: make(400))
    assert dropped == [] and cache.info().bytes == 800
    a.n = 700  # "a" grew after it was made: 1100 > 1000
    cache.get("b", lambda: make(1))  # measured again: "a", the least recent, goes
    assert cache.get("c", lambda: make(100)) is not None
    assert dropped == [700] and cache.info().entries == 2
    assert cache.get("a", lambda: make(1)) is a and made == [400, 400, 100]
    assert dropped == [700, 400]  # held here: found, not made
    cache.get("huge", lambda: make(5000))  # more than the budget: kept alone, as the latest
    assert cache.info().entries == 1 and made[-1] == 5000
    del a
    gc.collect()
    cache.get("a", lambda: make(2))  # no longer held anywhere: made again
    assert made[-1] == 2


def test_a_unit_set_let_go_takes_its_solves_with_it(monkeypatch):
    """With a budget below two meshes' unit sets, solving on a second mesh lets the first
    mesh's units go and, with them, the cached solves that hold them, so what the process
    keeps is what the two budgets allow; solving on the first mesh again builds its
    units once more and gives the same frequencies."""
    solve_laminate.cache_clear()
    UNIT_CACHE.clear()
    model = true_model()
    laminate, mesh = model.specimen.laminate("original"), model.mesh
    coarse = PlateMesh(mesh.length, mesh.width, 8, 8)
    first = solve_laminate(laminate, coarse, 8)
    monkeypatch.setattr(UNIT_CACHE, "budget", first.units.nbytes)
    held = weakref.ref(first.units)
    frequencies = first.frequencies_hz
    del first
    solve_laminate(laminate, mesh, 8)  # another mesh: its units grow as it is solved,
    unit_matrices(mesh)  # measured at the next use: the coarse units and their solve go
    gc.collect()
    assert held() is None
    assert solve_laminate.cache_info().entries == 1
    np.testing.assert_array_equal(solve_laminate(laminate, coarse, 8).frequencies_hz, frequencies)
