"""The prior parameter points of a robust score: the unknown properties over their
plausible range.

``[design] prior_range_rel`` = r gives the range: every identified E1, E2, G12, nu12
times a factor between 1/(1 + r) and 1 + r, log-uniform (a modulus 30 % high is as
plausible as one 23 % low).  A fixed, seeded Latin hypercube of ``prior_samples`` points
(16 by default: each property's range is covered in 16 equal steps) spreads over that
box, nu12 kept inside the positive-definite range (nu12^2 < E1/E2).  Duck-typed on the
design problem (``problem.Problem``: ``parameters``, ``values``, ``space``, ``at``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

#: Seed of the prior sample: the same points every run, so rankings are reproducible.
SEED = 20240611
#: A sampled nu12 is kept below this fraction of its positive-definite limit sqrt(E1/E2).
NU_MARGIN = 0.95


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


def physical(problem, values: np.ndarray) -> np.ndarray:
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
    problems: tuple

    @classmethod
    def of(cls, problem) -> Prior:
        space = problem.space
        values = physical(
            problem,
            problem.values * prior_factors(len(problem.parameters), space.prior_samples, space.prior_range),
        )
        # a sample is a point, not scored over a prior of its own
        point_space = replace(space, prior_range=0.0)
        problems = tuple(
            replace(problem.at(dict(zip(problem.parameters, v))), space=point_space) for v in values
        )
        return cls(space.prior_range, values / problem.values, (problem,) + problems)

    @property
    def samples(self) -> int:
        return len(self.problems) - 1


__all__ = ["Prior", "latin_hypercube", "prior_factors", "physical", "SEED", "NU_MARGIN"]
