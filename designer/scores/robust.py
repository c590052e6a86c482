"""Robust scores: a test set scored over the prior range of the unknown properties.

The properties to identify are exactly what is unknown, so a set scored only at their
start (nominal) values may be poor where they really are.  ``[design] prior_range_rel`` = r
gives their plausible range: every identified E1, E2, G12, nu12 times a factor between
1/(1 + r) and 1 + r, log-uniform (a modulus 30 % high is as plausible as one 23 % low).  A
fixed, seeded Latin hypercube of ``prior_samples`` points (16 by default: each property's
range is covered in 16 equal steps) spreads over that box, nu12 kept inside the
positive-definite range (nu12^2 < E1/E2).  Each set is scored at the nominal point and at
every sample; the report gives the worst and the mean, and sets are ranked by the worst
case of the chosen criterion (minimax: a set is as good as its worst plausible outcome).

Each (configuration, parameter point) is one solve, cached by content like every other
(``problem.solve_points``), so a search over m candidates costs (m + 1) x (samples + 1)
solves.  The prior points themselves: ``prior``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fem.numbers import finite_or_none

from .scoring import Scores

#: How sets are ranked over the prior: by the worst case of the criterion.
RANK_BY = "worst"


@dataclass(frozen=True)
class RobustScores:
    """A set's scores at the nominal point and at every prior sample (nominal first)."""

    range_rel: float
    scores: tuple[Scores, ...]

    def losses(self, criterion: str) -> np.ndarray:
        return np.array([s.loss(criterion) for s in self.scores])

    def values(self, criterion: str) -> np.ndarray:
        return np.array([s.value(criterion) for s in self.scores])

    def worst_loss(self, criterion: str) -> float:
        return float(np.max(self.losses(criterion)))

    def worst(self, criterion: str) -> float:
        """The criterion's value at the worst point (largest condition number, smallest
        log det F or smallest eigenvalue)."""
        return float(self.values(criterion)[int(np.argmax(self.losses(criterion)))])

    def mean(self, criterion: str) -> float:
        values = self.values(criterion)
        return (
            float(np.mean(values))
            if np.all(np.isfinite(values))
            else math.inf * (1 if criterion == "condition" else -1)
        )

    @property
    def worst_std_rel(self) -> np.ndarray:
        """Per parameter, its largest predicted relative std over the points."""
        return np.max([s.std_rel for s in self.scores], axis=0)

    def to_dict(self, parameters) -> dict:

        out = {"prior_range_rel": self.range_rel, "points": len(self.scores), "rank_by": RANK_BY}
        for criterion, key in (
            ("condition", "condition_number"),
            ("d", "logdet_fisher"),
            ("e", "min_eigenvalue_fisher"),
        ):
            out[key] = {
                "nominal": finite_or_none(self.scores[0].value(criterion)),
                "worst": finite_or_none(self.worst(criterion)),
                "mean": finite_or_none(self.mean(criterion)),
            }
        worst = {}
        for p, s in zip(parameters, self.worst_std_rel):
            worst.setdefault(p.target, {})[p.kind] = finite_or_none(s)
        out["predicted_std_rel_worst"] = worst
        return out
