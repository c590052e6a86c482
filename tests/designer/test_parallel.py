"""The same solves on worker processes and on a local Dask cluster give the same
numbers as in this process."""

import numpy as np
import pytest

from designer import problem as problem_module
from designer.candidates import candidates
from designer.parallel import chunked, executor
from designer.problem import Problem
from fem.errors import DesignError

from .conftest import paper_data, problem_of


@pytest.fixture(scope="module")
def small():
    """Four candidates (brass, aluminium x 0.5 mm x top/bottom) and their solutions here."""
    problem = problem_of(paper_data(), materials=["brass", "aluminium"], thicknesses_mm=[0.5])
    configurations = candidates(problem.space, problem.specimen).configurations
    return problem, configurations, problem.solve(configurations)


def solve_elsewhere(problem: Problem, configurations, pool):
    saved = dict(problem_module._CACHE)
    problem_module._CACHE.clear()  # make the pool do the work
    try:
        return problem.solve(configurations, pool=pool)
    finally:
        problem_module._CACHE.update(saved)


def assert_same(a, b):
    """Same frequencies and sensitivities (BLAS threading may change the last bits)."""
    for x, y in zip(a, b):
        assert x.configuration == y.configuration and x.labels == y.labels
        np.testing.assert_allclose(x.frequencies_hz, y.frequencies_hz, rtol=1e-12)
        np.testing.assert_allclose(x.sensitivities, y.sensitivities, rtol=1e-9, atol=1e-12)


def test_process_pool_matches_serial(small):
    problem, configurations, here = small
    with executor(2) as pool:
        assert_same(solve_elsewhere(problem, configurations, pool), here)


def test_local_dask_cluster_matches_serial(small):
    """Two worker processes of a local Dask cluster, reached by address as a remote one is."""
    distributed = pytest.importorskip("distributed")
    problem, configurations, here = small
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        with executor(scheduler=cluster.scheduler_address) as pool:
            assert_same(solve_elsewhere(problem, configurations, pool), here)


def test_unreachable_scheduler_and_bad_workers():
    pytest.importorskip("distributed")
    with pytest.raises(DesignError, match="cannot reach the Dask scheduler"):
        with executor(scheduler="tcp://127.0.0.1:9", timeout=1.0):
            pass
    with pytest.raises(DesignError, match="--workers -1"):
        with executor(-1):
            pass


def test_chunks_cover_every_item_in_order():
    items = list(range(10))
    for pieces in (1, 3, 10, 50):
        chunks = chunked(items, pieces)
        assert sum(chunks, []) == items and len(chunks) == min(pieces, 10)
        assert max(map(len, chunks)) - min(map(len, chunks)) <= 1
