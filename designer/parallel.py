"""Running independent tasks serially, on local processes or on a Dask cluster.

All three go through one ``concurrent.futures.Executor`` interface (Dask's
``Client.get_executor()`` provides it), so the planner's code is the same on a laptop
and on a cluster.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import os
from contextlib import contextmanager

from fem.errors import DesignError

from .progress import Bar, Progress

#: Solves below which one process is faster than starting a pool.
PARALLEL_FROM = 150


@contextmanager
def executor(workers: int = 1, scheduler: str | None = None, tasks: int = 0, timeout: float = 10.0):
    """Yield None (run in this process) for one worker, a process pool for several, or
    the executor of the Dask cluster at ``scheduler`` (e.g. "tcp://10.0.0.5:8786"),
    reached within ``timeout`` [s].  ``workers`` = 0 chooses by the number of ``tasks``
    (``auto_workers``).  Workers are spawned and import the main module: a script that
    starts them needs the ``if __name__ == "__main__":`` guard."""
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise DesignError(
                f"--scheduler {scheduler}: Dask is not installed; "
                "install the extra: pip install 'layer-id[dask]'"
            ) from None
        try:
            client = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as exc:
            raise DesignError(
                f"--scheduler {scheduler}: cannot reach the Dask scheduler ({exc}); "
                "check the address and that the scheduler runs"
            ) from None
        try:
            yield client.get_executor()
        finally:
            client.close()
        return
    if not isinstance(workers, int) or workers < 0:
        raise DesignError(
            f"--workers {workers!r}: need a whole number >= 1, or 0 for automatic "
            f"(this machine has {os.cpu_count()} cores)"
        )
    workers = workers or auto_workers(tasks)
    if workers == 1:
        yield None
        return
    # Spawned (not forked) workers: safe on every platform and with threads in this process.
    with cf.ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn")) as pool:
        yield pool


def auto_workers(tasks: int) -> int:
    """Processes worth starting for ``tasks`` configuration solves (~20 ms each): one
    below ``PARALLEL_FROM`` (starting a worker costs about a second), else every core."""
    return 1 if tasks < PARALLEL_FROM else max(1, os.cpu_count() or 1)


def chunked(items: list, pieces: int) -> list[list]:
    """``items`` split into at most ``pieces`` contiguous chunks of near-equal size."""
    pieces = max(1, min(pieces, len(items)))
    bounds = [round(i * len(items) / pieces) for i in range(pieces + 1)]
    return [items[a:b] for a, b in zip(bounds, bounds[1:])]


def run_chunks(
    function,
    chunks: list[list],
    *args,
    pool: cf.Executor | None = None,
    progress: Progress | None = None,
    label: str = "",
    done=None,
) -> list:
    """``function(*args, chunk)`` for every chunk, results concatenated in chunk order;
    a progress bar counts items as chunks complete; ``done(i, result)`` is called as
    each chunk completes (e.g. to store it, so an interruption loses only chunks in work)."""
    total = sum(len(c) for c in chunks)
    out: list = [None] * len(chunks)
    with Bar(progress, total, label) as bar:
        if pool is None:
            for i, chunk in enumerate(chunks):
                out[i] = function(*args, chunk)
                if done is not None:
                    done(i, out[i])
                bar.update(len(chunk))
        else:
            futures = {pool.submit(function, *args, chunk): i for i, chunk in enumerate(chunks)}
            for future in cf.as_completed(futures):
                i = futures[future]
                out[i] = future.result()
                if done is not None:
                    done(i, out[i])
                bar.update(len(chunks[i]))
    return [item for result in out for item in result]
