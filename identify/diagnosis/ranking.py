"""Candidates in the order the forward selection considers them: by criterion, an
implausible estimate behind the plausible rivals that fit about as well (the limits are
``fitting.plausibility``'s)."""

from __future__ import annotations


def plausible_first(
    candidates,
    chi2_unit: float,
    margin: float,
    key=lambda c: c.bic,
    judged=lambda c: c.plausible,
    related=lambda a, b: False,
):
    """``candidates`` ordered by criterion (lower first), an implausible one moved behind
    the plausible rivals whose criterion is within ``margin`` x ``chi2_unit`` of it.  A
    rival is another explanation: not one ``related`` to it (e.g. the same physics with or
    without a part, which estimates the same parameters)."""

    def penalty(c):
        if judged(c):
            return 0.0
        rivals = [
            r
            for r in candidates
            if r is not c and judged(r) and not related(r, c) and abs(key(r) - key(c)) < margin * chi2_unit
        ]
        return margin * chi2_unit if rivals else 0.0

    return sorted(candidates, key=lambda c: key(c) + penalty(c))


__all__ = ["plausible_first"]
