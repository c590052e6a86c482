"""Checks of user input at the entry points: unknown keys with "did you mean", names from
a known set, numbers with their range and unit.

One helper for the spec, the measurements, the effects and the design space, so every
error reads alike: one line naming where, the value, what is allowed and a fix.  Each
check raises the caller's member of the exception family (``fem.errors``).
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Iterable

from .errors import LayerIdError, SpecError


def did_you_mean(name, known: Iterable[str]) -> str:
    """ "did you mean 'x'?" for the closest known name, or '' when none is close."""
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1)
    return f"did you mean '{close[0]}'?" if close else ""


def suggestion(name, known: Iterable[str]) -> str:
    """ "did you mean 'x'?" for the closest known name, else the list of known names."""
    known = [str(k) for k in known]
    return did_you_mean(name, known) or f"allowed: {', '.join(known) or 'none'}"


def check_keys(
    table: dict, allowed: Iterable[str], where: str, error: type[LayerIdError] = SpecError
) -> None:
    """Reject a key not in ``allowed``: "``where``: unknown key 'k'; did you mean 'K'?"."""
    allowed = list(allowed)
    for key in table:
        if key not in allowed:
            raise error(f"{where}: unknown key {str(key)!r}; {suggestion(key, allowed)}")


def number(
    table: dict,
    key: str,
    where: str,
    *,
    required: bool = True,
    default=None,
    low: float | None = None,
    high: float | None = None,
    low_inclusive: bool = False,
    hint: str = "",
    error: type[LayerIdError] = SpecError,
) -> float | None:
    """A finite number ``table[key]`` within (low, high], or a one-line error naming
    ``where.key``, the value, the range and ``hint`` (e.g. the unit to use)."""
    if key not in table:
        if required:
            raise error(f"{where}: missing field '{key}'")
        return default
    value = table[key]
    fix = f" ({hint})" if hint else ""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise error(f"{where}.{key} = {value!r}: need a finite number{fix}")
    above = low is None or (value >= low if low_inclusive else value > low)
    if not above or (high is not None and value > high):
        if low is not None and low == 0 and high is None and not low_inclusive:
            raise error(f"{where}.{key} = {value:g}: must be positive{fix}")
        relation = "<=" if low_inclusive else "<"
        bounds = (f"{low:g} {relation} {key}" if low is not None else key) + (
            f" <= {high:g}" if high is not None else ""
        )
        raise error(f"{where}.{key} = {value:g}: need {bounds}{fix}")
    return float(value)


def whole(value, where: str, low: int, high: int, what: str, error: type[LayerIdError] = SpecError) -> int:
    """A whole number from ``low`` to ``high``.

    Anything else raises ``error`` ("``where`` = v: need a whole number of ``what`` from ...").
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not low <= value <= high:
        raise error(f"{where} = {value!r}: need a whole number {what}from {low} to {high}")
    return int(value)


__all__ = ["did_you_mean", "suggestion", "check_keys", "number", "whole"]
