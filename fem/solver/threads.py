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
    where the work happens, whatever the caller's environment."""

    @wraps(function)
    def limited(*args, **kwargs):
        with _blas().limit(limits=1, user_api="blas"):
            return function(*args, **kwargs)

    return limited
