"""The console entry points (``identify-layers``, ``plan-tests``).  They load their
command line's modules inside the interrupt handling, so that a Ctrl-C while they load
ends in one line, as it does once the command runs."""

from __future__ import annotations

import sys
from importlib import import_module


def _run(module: str) -> int:
    """The command, with BLAS on one thread throughout: its dense products are small
    (mode shapes of a few thousand DOFs by ~60 modes), and where the other core is busy a
    second BLAS thread waits for it: a shape-comparison (MAC) product took 270 ms instead
    of 35 ms on this 2-core machine with one core loaded.  The solves limit themselves as
    well (``fem.solver.threads.one_blas_thread``), for callers of the API.  Not through
    its cached controller: here only numpy's BLAS is loaded yet, and caching that view
    would leave scipy's (loaded with the solver) unlimited in every solve."""
    try:
        main = import_module(module).main
        from threadpoolctl import threadpool_limits
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    with threadpool_limits(limits=1, user_api="blas"):
        return main()


def identify_layers() -> int:
    return _run("identify.cli")


def plan_tests() -> int:
    return _run("designer.cli")
