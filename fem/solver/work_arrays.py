"""Large work arrays of the modal solve, kept from one solve to the next.

A layerwise solve writes its band matrix (factored in place) and the factor's reversed
copy (``modal._reversed``), 50-120 MB each, into fresh memory every time: the allocator
maps new pages for any block above 32 MB, and the kernel faults, zeroes and (for the huge
pages numpy asks for) compacts them.  With fresh arrays, one solve in three took 1.6-2x
its usual time.  Measured in whole processes, paired in turn on this project's machine,
the same numbers bit for bit: a balsa-core sandwich's layerwise model (blind117, 9,180-
11,220 DOFs), six cold solves 4.0 s fresh against 3.4 s kept (medians of 5 pairs); the
thick 3-D reference's diagnosis (``make bench``) 101.9 s against 97.4 s (2 pairs, system
time 20.8 against 15.0 s), peak memory 954 against 1023 MiB.

An array is reused by the next request of the same ``role`` in the same thread, so its
contents are the caller's only until then: a role's array must not outlive the solve
that took it (``solve_modes`` keeps none in what it returns).
"""

from __future__ import annotations

import threading

import numpy as np

#: The most bytes the kept work arrays of one thread may hold: twice the band of the
#: largest layerwise model measured here (the bench's sandwich with one shear group per
#: layer, 16,200 DOFs, 1,020 rows: 132 MB), with room.  A request beyond it gets a fresh
#: array, not kept.
WORK_ARRAY_BYTES = 1 << 29
#: Arrays below this size are allocated fresh (the size from which the factor is copied
#: reversed, ``modal.BLOCK_SOLVE_BYTES``): a first-order shear model of 5,100 DOFs (12 MB
#: of band) solves in the same time either way (113 ms), a thin plate's band is a few MB.
KEPT_FROM_BYTES = 1 << 23


class _Kept(threading.local):
    """The arrays kept for one thread, by role."""

    def __init__(self):
        self.by_role: dict[str, np.ndarray] = {}


_KEPT = _Kept()


def work_array(role: str, size: int) -> np.ndarray:
    """A float64 array of ``size`` entries, contents undefined, for ``role`` (a name of the
    caller's): the array the last request of that role in this thread got, when large
    enough, else a new one kept in its place within ``WORK_ARRAY_BYTES``."""
    nbytes = 8 * size
    if nbytes < KEPT_FROM_BYTES:
        return np.empty(size)
    kept = _KEPT.by_role
    array = kept.get(role)
    if array is not None and array.size >= size:
        return array[:size]
    kept.pop(role, None)
    array = np.empty(size)
    if nbytes + kept_bytes() <= WORK_ARRAY_BYTES:
        kept[role] = array
    return array


def kept_bytes() -> int:
    """The bytes this thread's work arrays hold."""
    return sum(a.nbytes for a in _KEPT.by_role.values())
