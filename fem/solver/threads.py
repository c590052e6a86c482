"""BLAS threads for small dense work: one.  Light to import (only threadpoolctl), so that
a command that solves nothing (``peaks``) does not load the solver to get it."""

from __future__ import annotations

from functools import lru_cache, wraps

from threadpoolctl import ThreadpoolController


@lru_cache(maxsize=1)
def _blas() -> ThreadpoolController:
    """The BLAS libraries loaded (inspected once, after scipy's are in memory)."""
    return ThreadpoolController()


def one_blas_thread(function):
    """``function`` run with BLAS on one thread.  The systems here are small (a few
    thousand DOFs): BLAS threads only add overhead, and where cores are busy their
    spinning made the assembly, the solve and the sensitivities 3-40x slower.  Limited
    where the work happens, whatever the caller's environment: the solves, and the whole
    of ``identify.fit`` and ``identify.diagnose`` (their shape comparisons, screens and
    reduced bases too: two diagnoses side by side on two cores took 148 s each with
    BLAS's default two threads, 121 s with one)."""

    @wraps(function)
    def limited(*args, **kwargs):
        with _blas().limit(limits=1, user_api="blas"):
            return function(*args, **kwargs)

    return limited


def one_blas_thread_process() -> None:
    """BLAS on one thread for the rest of this process: the initializer of the worker
    processes that run refits (``identify.fitting.driver.worker_pool``).  It loads scipy's
    BLAS first (a spawned worker has loaded nothing yet), so that both are limited."""
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
