"""Small numeric helpers shared by every package (one place, one meaning)."""

from __future__ import annotations

import math


def finite_or_none(value: float | None) -> float | None:
    """``value`` as a float, or None when it is None, infinite or NaN: JSON has neither
    infinity nor NaN, so an undefined number (a rank-deficient score, a std without
    redundancy) is written as null."""
    return float(value) if value is not None and math.isfinite(value) else None


__all__ = ["finite_or_none"]
