"""The byte-bounded cache of modal solves: eviction by size, least recently used first."""
import numpy as np

from fem.model import SOLUTION_OVERHEAD_BYTES, solve_laminate
from fem.solver.solve_cache import bytes_bounded_cache
from studies.common import true_model


def test_values_are_evicted_by_bytes_least_recently_used_first():
    calls = []

    @bytes_bounded_cache(3000, lambda value: value.nbytes)
    def array(n):
        calls.append(n)
        return np.zeros(n)  # 8 n bytes

    array(100), array(150)             # 800 + 1200 bytes
    array(100)                         # a hit: 100 is now the most recent
    array(120)                         # 960 more: 2960 in all, within the budget
    assert array.cache_info().entries == 3 and array.cache_info().bytes == 2960
    array(50)                          # 400 more: 150, the least recently used, goes
    info = array.cache_info()
    assert info.bytes == 2160 and info.entries == 3 and info.hits == 1
    array(150)
    assert calls == [100, 150, 120, 50, 150]
    array(1000)                        # 8000 bytes: more than the budget, returned but not kept
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
    assert info.bytes == solution.modes.shapes.nbytes + solution.modes.eigenvalues.nbytes + SOLUTION_OVERHEAD_BYTES
    assert model.solve("original") is solution and solve_laminate.cache_info().hits == 1
