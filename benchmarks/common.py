"""Shared pieces of the benchmarks: the paper's plate and a best-of timer."""

import time
from pathlib import Path

from fem.spec import load_spec

PAPER_TABLE1 = Path(__file__).parent.parent / "tests" / "data" / "paper_plate_table1.toml"


def paper_spec():
    """The paper's plate with its true (Table 1) properties and three configurations."""
    return load_spec(PAPER_TABLE1)


def best_time(function, repeat: int = 7) -> float:
    """Best wall time of ``repeat`` calls [s] (the least disturbed by other load)."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best
