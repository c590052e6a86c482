"""A least-recently-used cache bounded by the bytes its values hold, not by their count.

The modal solves of a fit are cached by content (the same laminate on the same mesh is
solved once), but a solve's size spans orders of magnitude: the paper's thin plate keeps
about 0.1 MB of mode shapes, a long spruce plate with first-order shear 5.4 MB (37 modes
of 18,240 DOFs), a layerwise sandwich more.  A count of 512 solves lets 2.8 GB of the
spruce plate's accumulate; a byte budget keeps any model within what a lab laptop has.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from functools import wraps

#: The budget of the modal-solve cache [bytes]: about 50 solves of a long plate with
#: shear, thousands of a thin one.  What a fit reuses is recent (a trial's sensitivities,
#: the next refit's start): a thick-plate refit of a long spruce plate's peak list hits the
#: cache as often at 256 MiB as at 1 GiB (259 hits, 128 misses, the same 151 s), and its
#: process peaks at 1.56 GB instead of 1.78 GB; the plate's diagnosis at 2.29 GB instead
#: of 2.98 GB, with the same answer (391 s alone).
SOLVE_CACHE_BYTES = 1 << 28


@dataclass(frozen=True)
class CacheInfo:
    hits: int
    misses: int
    entries: int
    bytes: int
    budget: int


def bytes_bounded_cache(budget: int, size_of: Callable[[object], int]):
    """Decorator: cache a function of hashable arguments, evicting the least recently
    used values once their ``size_of`` sum exceeds ``budget`` bytes (a value larger than
    the budget is returned but not kept).  The wrapper has ``cache_clear()`` and
    ``cache_info()`` like ``functools.lru_cache``'s."""

    def decorate(function):
        entries: OrderedDict = OrderedDict()
        lock = threading.Lock()
        state = {"hits": 0, "misses": 0, "bytes": 0}

        @wraps(function)
        def wrapper(*args, **kwargs):
            key = (args, tuple(sorted(kwargs.items())))
            with lock:
                if key in entries:
                    entries.move_to_end(key)
                    state["hits"] += 1
                    return entries[key][0]
                state["misses"] += 1
            value = function(*args, **kwargs)
            size = int(size_of(value))
            if size > budget:
                return value
            with lock:
                if key not in entries:
                    entries[key] = (value, size)
                    state["bytes"] += size
                while state["bytes"] > budget:
                    _, (_, dropped) = entries.popitem(last=False)
                    state["bytes"] -= dropped
            return value

        def cache_clear() -> None:
            with lock:
                entries.clear()
                state.update(hits=0, misses=0, bytes=0)

        def cache_info() -> CacheInfo:
            with lock:
                return CacheInfo(state["hits"], state["misses"], len(entries), state["bytes"], budget)

        wrapper.cache_clear = cache_clear
        wrapper.cache_info = cache_info
        return wrapper

    return decorate


__all__ = ["CacheInfo", "SOLVE_CACHE_BYTES", "bytes_bounded_cache"]
