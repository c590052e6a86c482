"""Robust scores: a test set scored over the prior range of the unknown properties.

The properties to identify are exactly what is unknown, so a set scored only at their
start (nominal) values may be poor where they really are.  ``[design] prior_range_rel``
= r gives their plausible range: every identified E1, E2, G12, nu12 times a factor
between 1/(1 + r) and 1 + r, log-uniform (a modulus 30 % high is as plausible as one
23 % low).  A fixed, seeded Latin hypercube of ``prior_samples`` points (16 by default:
each property's range is covered in 16 equal steps) spreads over that box, nu12 kept inside the positive-definite range
(nu12^2 < E1/E2).  Each set is scored at the nominal point and at every sample; the
report gives the worst and the mean, and sets are ranked by the worst case of the chosen
criterion (minimax: a set is as good as its worst plausible outcome).

Each (configuration, parameter point) is one solve, cached by content like every other
(``problem.solve_points``), so a search over m candidates costs (m + 1) x (samples + 1)
solves.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .problem import Problem
from .scoring import Scores

#: Seed of the prior sample: the same points every run, so rankings are reproducible.
SEED = 20240611
#: A sampled nu12 is kept below this fraction of its positive-definite limit sqrt(E1/E2).
NU_MARGIN = 0.95
#: How sets are ranked over the prior: by the worst case of the criterion.
RANK_BY = "worst"


def latin_hypercube(samples: int, dimensions: int, seed: int = SEED) -> np.ndarray:
    """(samples, dimensions) points in [0, 1): each coordinate takes one value in each
    of ``samples`` equal strata, the strata paired at random (seeded: the same every run)."""
    rng = np.random.default_rng(seed)
    strata = np.argsort(rng.random((dimensions, samples)), axis=1).T  # a permutation per dimension
    return (strata + rng.random((samples, dimensions))) / samples


def prior_factors(n_parameters: int, samples: int, range_rel: float) -> np.ndarray:
    """(samples, n_parameters) log-uniform factors in [1/(1 + r), 1 + r] on a seeded
    Latin hypercube: every parameter's range is covered in ``samples`` equal steps."""
    return (1.0 + range_rel) ** (2.0 * latin_hypercube(samples, n_parameters) - 1.0)


def physical(problem: Problem, values: np.ndarray) -> np.ndarray:
    """``values`` (samples, p) with every nu12 kept below NU_MARGIN sqrt(E1/E2)."""
    values = values.copy()
    index = {(p.target, p.kind): j for j, p in enumerate(problem.parameters)}
    for material in {p.target for p in problem.parameters}:
        j = {kind: index.get((material, kind)) for kind in ("E1", "E2", "nu12")}
        if None in j.values():
            continue
        limit = NU_MARGIN * np.sqrt(values[:, j["E1"]] / values[:, j["E2"]])
        values[:, j["nu12"]] = np.clip(values[:, j["nu12"]], -limit, limit)
    return values


@dataclass(frozen=True)
class Prior:
    """The parameter points a robust score uses: ``problems`` at the nominal values
    first, then one per sample; ``factors`` (samples, p) each sample's values over the
    nominal ones."""

    range_rel: float
    factors: np.ndarray
    problems: tuple[Problem, ...]

    @classmethod
    def of(cls, problem: Problem) -> "Prior":
        space = problem.space
        values = physical(problem, problem.values * prior_factors(len(problem.parameters), space.prior_samples,
                                                                    space.prior_range))
        point_space = replace(space, prior_range=0.0)  # a sample is a point, not scored over a prior of its own
        problems = tuple(replace(problem.at(dict(zip(problem.parameters, v))), space=point_space) for v in values)
        return cls(space.prior_range, values / problem.values, (problem,) + problems)

    @property
    def samples(self) -> int:
        return len(self.problems) - 1


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
        return float(np.mean(values)) if np.all(np.isfinite(values)) else math.inf * (1 if criterion == "condition"
                                                                                       else -1)

    @property
    def worst_std_rel(self) -> np.ndarray:
        """Per parameter, its largest predicted relative std over the points."""
        return np.max([s.std_rel for s in self.scores], axis=0)

    def to_dict(self, parameters) -> dict:
        from .design import finite_or_none

        out = {"prior_range_rel": self.range_rel, "points": len(self.scores), "rank_by": RANK_BY}
        for criterion, key in (("condition", "condition_number"), ("d", "logdet_fisher"),
                               ("e", "min_eigenvalue_fisher")):
            out[key] = {"nominal": finite_or_none(self.scores[0].value(criterion)),
                        "worst": finite_or_none(self.worst(criterion)), "mean": finite_or_none(self.mean(criterion))}
        worst = {}
        for p, s in zip(parameters, self.worst_std_rel):
            worst.setdefault(p.target, {})[p.kind] = finite_or_none(s)
        out["predicted_std_rel_worst"] = worst
        return out
