"""Values as a lab report prints them: rounded to their uncertainty.

A value is given to the decimal of the second significant digit of its standard
uncertainty (``67.8287 +- 1.15955`` GPa reads ``67.8 ± 1.2 GPa (1.7 %)``), relative
errors in per cent, and a status once.  Text and HTML reports both use these helpers;
the JSON and CSV outputs keep full precision.
"""

from __future__ import annotations

import math

#: Significant digits of a standard uncertainty in a report (GUM 7.2.6: "at most two").
STD_DIGITS = 2


def _decimals(std: float, digits: int = STD_DIGITS) -> int:
    """Decimals that keep ``digits`` significant digits of ``std`` (negative: tens...)."""
    return digits - 1 - math.floor(math.log10(abs(std)))


def _fixed(x: float, decimals: int) -> str:
    if decimals >= 0:
        return f"{x:.{decimals}f}"
    step = 10.0**-decimals
    return f"{round(x / step) * step:.0f}"


def with_std(value: float, std: float, unit: str = "", digits: int = STD_DIGITS) -> str:
    """``value ± std unit (rel %)`` rounded to the std's ``digits`` significant digits,
    e.g. ``67.8 ± 1.2 GPa (1.7 %)``; without a finite positive std, ``value`` to 4
    significant digits and ``± n/a``.  A value that reads as zero at that precision has no
    relative std (nu12 held at 1e-10 with a std of 0.20 read "(200000000000 %)")."""
    tail = f" {unit}" if unit else ""
    if not math.isfinite(value):
        return "n/a"
    if not (math.isfinite(std) and std > 0):
        return f"{value:.4g} ± n/a{tail}"
    decimals = _decimals(std, digits)
    shown = _fixed(value, decimals)
    rel = f" ({percent(std / abs(value), digits)})" if float(shown) != 0 else ""
    return f"{shown} ± {_fixed(std, decimals)}{tail}{rel}"


def percent(rel: float, digits: int = STD_DIGITS) -> str:
    """A relative quantity in per cent to ``digits`` significant digits: 0.017 -> ``1.7 %``."""
    if not math.isfinite(rel):
        return "n/a"
    if rel == 0:
        return "0 %"
    return f"{_fixed(100 * rel, _decimals(100 * rel, digits))} %"


def status_line(status: str, message: str) -> str:
    """One status line: ``status: message``, without the status twice when the message
    already starts with it (``converged: converged; ...`` reads ``converged: ...``)."""
    words = status.replace("_", " ")
    if message.lower().startswith((words, status)):
        return message
    return f"{words}: {message}" if message else words


__all__ = ["STD_DIGITS", "with_std", "percent", "status_line"]
