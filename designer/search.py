"""``recommend``: the best sets of k - 1 added plates from the design space.

Candidates are solved once each; a set is scored by stacking the rows of its
configurations under the original plate's.  Few sets: every one is scored (batched
SVD).  Many: the convex relaxation (``relaxation``) picks a set and bounds how far it
can be from optimal, and exchange swaps improve it.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass

import numpy as np

from fem.design_space import CRITERIA
from fem.errors import DesignError
from fem.io import html_pre
from fem.model import SpecimenModel
from fem.specimen import Configuration

from .candidates import candidates
from .design import Design
from .poisson import PoissonPlate, poisson_plate
from .problem import Problem, Solved, unmeasurable
from .progress import Bar, Progress
from .relaxation import information_loss, relax, swap_search
from .scoring import loss, singular_values

#: Sets up to which the search is exhaustive (a few seconds of batched SVDs).
EXHAUSTIVE_LIMIT = 50_000
#: Sets scored per batched SVD (bounds memory to ~20 MB).
BATCH = 4096
METHODS = ("auto", "exhaustive", "relaxation")
ORIGINAL = Configuration("original")


@dataclass(frozen=True)
class Bound:
    """How far the chosen set can be from the best one: the relaxation's optimum of the
    convex ``criterion`` ('d': log det F, 'e': smallest eigenvalue of F) against the
    chosen set's value.  No set of the space exceeds ``relaxed``."""

    criterion: str
    relaxed: float
    chosen: float

    def report(self) -> str:
        if self.criterion == "d":
            gap = max(self.relaxed - self.chosen, 0.0)
            return (f"relaxation bound: log det F <= {self.relaxed:.5g}; chosen {self.chosen:.5g} (gap {gap:.3g}): "
                    f"its confidence ellipsoid is at most {math.exp(gap / 2):.4f} x the volume of the best set's")
        return (f"relaxation bound: smallest eigenvalue of F <= {self.relaxed:.5g}; chosen {self.chosen:.5g} "
                f"({100 * self.chosen / self.relaxed:.3g} % of the bound)")

    def to_dict(self) -> dict:
        return {"criterion": self.criterion, "relaxed": self.relaxed, "chosen": self.chosen}


@dataclass(frozen=True)
class Recommendation:
    """Ranked designs (best first) and how the search got them.

    method: 'exhaustive' or 'relaxation'; candidates: configurations solved; sets:
    sets scored; excluded: candidates left out (name -> reason); bound: the relaxation's
    (None when exhaustive); baseline: the spec's own set scored alike (None without
    added configurations); seconds: wall time.
    """

    designs: tuple[Design, ...]
    criterion: str
    method: str
    candidates: int
    sets: int
    excluded: dict[str, str]
    bound: Bound | None
    baseline: Design | None
    poisson: PoissonPlate
    seconds: float

    @property
    def best(self) -> Design:
        return self.designs[0]

    def to_dict(self) -> dict:
        return {
            "designs": [d.to_dict() for d in self.designs],
            "search": {"criterion": self.criterion, "method": self.method, "candidates": self.candidates,
                       "sets": self.sets, "excluded": self.excluded, "seconds": round(self.seconds, 3),
                       "bound": self.bound.to_dict() if self.bound else None},
            "baseline": self.baseline.to_dict() if self.baseline else None,
            "poisson_plate": self.poisson.to_dict(),
        }

    def _repr_html_(self) -> str:
        return html_pre(self.report())

    def report(self) -> str:
        lines = [f"searched {self.sets} sets of {len(self.best.solved) - 1} added plates from {self.candidates} "
                 f"candidates ({self.method}, {self.seconds:.1f} s), scored at the spec's nominal properties, "
                 f"ranked by {CRITERIA[self.criterion]}"]
        if self.excluded:
            lines.append(f"left out {len(self.excluded)} candidates: " + "; ".join(
                f"{name} ({why})" for name, why in list(self.excluded.items())[:5])
                + (" ..." if len(self.excluded) > 5 else ""))
        if self.bound:
            lines.append(self.bound.report())
        lines += ["", f"{'rank':>4s}  {'condition':>10s}  {'log det F':>10s}  {'verdict':<15s} added plates"]
        for rank, d in enumerate(self.designs, 1):
            lines.append(f"{rank:>4d}  {d.scores.condition_number:>10.4g}  {d.scores.logdet_fisher:>10.5g}  "
                         f"{d.scores.verdict:<15s} {', '.join(d.names[1:])}")
        if self.baseline is not None:
            b = self.baseline.scores
            lines.append(f"{'spec':>4s}  {b.condition_number:>10.4g}  {b.logdet_fisher:>10.5g}  {b.verdict:<15s} "
                         f"{', '.join(self.baseline.names[1:])} (the spec's configurations)")
        lines += ["", "best design", self.best.report(), "", self.poisson.report()]
        return "\n".join(lines)


def stacked_rows(problem: Problem, solved: list[Solved]) -> np.ndarray:
    """(n, modes, p) measured rows per configuration, zero rows where a mode is not
    measured (zero rows change no singular value)."""
    out = np.zeros((len(solved), problem.modes, len(problem.parameters)))
    for block, s in zip(out, solved):
        rows = problem.rows(s)
        block[: len(rows)] = rows
    return out


def exhaustive(problem: Problem, original: np.ndarray, blocks: np.ndarray, n: int, top: int,
               progress: Progress | None = None) -> tuple[list[tuple[int, ...]], int]:
    """Every set of ``n`` of the candidate ``blocks``: the ``top`` best by the criterion
    (ties broken by enumeration order), and the number of sets scored."""
    m, r, p = blocks.shape
    total = math.comb(m, n)
    combos = itertools.combinations(range(m), n)
    best_loss, best_sets = np.empty(0), np.empty((0, n), dtype=int)
    with Bar(progress, total, "scoring sets") as bar:
        while True:
            chunk = np.fromiter(itertools.chain.from_iterable(itertools.islice(combos, BATCH)), dtype=int)
            if chunk.size == 0:
                break
            sets = chunk.reshape(-1, n)
            stacks = np.concatenate([np.broadcast_to(original, (len(sets),) + original.shape),
                                     blocks[sets].reshape(len(sets), n * r, p)], axis=1)
            losses = loss(singular_values(stacks), problem.space.frequency_std_rel, problem.space.criterion)
            best_loss = np.concatenate([best_loss, losses])
            best_sets = np.concatenate([best_sets, sets])
            keep = np.argsort(best_loss, kind="stable")[:top]
            best_loss, best_sets = best_loss[keep], best_sets[keep]
            bar.update(len(sets))
    return [tuple(int(i) for i in s) for s in best_sets], total


def relaxed(problem: Problem, original: np.ndarray, blocks: np.ndarray, n: int,
            top: int) -> tuple[list[tuple[int, ...]], int, Bound]:
    """The convex relaxation, rounded and improved by swaps: the ``top`` best sets seen,
    the number of sets scored, and the relaxation's bound (in Fisher-information units)."""
    space = problem.space
    p = original.shape[1]
    info0 = original.T @ original
    infos = np.einsum("mrp,mrq->mpq", blocks, blocks)
    relaxation = relax(info0, infos, n, space.criterion)
    seen = swap_search(info0, infos, np.argsort(-relaxation.weights, kind="stable")[:n], space.criterion)
    best = sorted(seen, key=seen.get)[:top]
    chosen = float(-information_loss(info0 + infos[list(best[0])].sum(axis=0), relaxation.criterion))
    sigma2 = space.frequency_std_rel**2
    if relaxation.criterion == "d":  # log det (I / sigma^2) = log det I - p log sigma^2
        bound = Bound("d", relaxation.bound - p * math.log(sigma2), chosen - p * math.log(sigma2))
    else:  # lambda_min (I / sigma^2); the loss was -log lambda_min
        bound = Bound("e", relaxation.bound / sigma2, math.exp(chosen) / sigma2)
    return best, len(seen), bound


def recommend(problem: Problem | SpecimenModel, top: int = 5, method: str = "auto", pool=None,
              progress: Progress | None = None) -> Recommendation:
    """The ``top`` best sets of ``space.size - 1`` candidates for the original plate.
    ``problem``: a planning problem, or a model (its ``[design]`` table makes the problem)."""
    problem = Problem.of(problem)
    start = time.perf_counter()
    space = problem.space
    if method not in METHODS:
        raise DesignError(f"method {method!r}: allowed: {', '.join(METHODS)}")
    if not isinstance(top, int) or top < 1:
        raise DesignError(f"--top {top!r}: need a whole number >= 1")
    n, p = space.size - 1, len(problem.parameters)
    if space.size * problem.modes < p:
        raise DesignError(f"[design].configurations = {space.size} x [model].modes = {problem.modes} gives "
                          f"{space.size * problem.modes} frequencies for {p} parameters: every set is singular; "
                          f"measure at least {math.ceil(p / space.size)} modes per plate or add configurations")
    offered = candidates(space, problem.specimen)
    solved = problem.solve((ORIGINAL,) + offered.configurations, pool=pool, progress=progress)
    original, solved = solved[0], solved[1:]
    if not problem.measured(original).any():
        raise unmeasurable(problem, original)
    excluded = dict(offered.excluded)
    usable = []
    for s in solved:
        if problem.measured(s).any():
            usable.append(s)
        else:
            excluded[s.configuration.name] = "no mode inside band_hz" if space.limits.band else "no separable mode"
    if len(usable) < n:
        raise DesignError(
            f"[design].configurations = {space.size} needs {n} added plates but the design space offers "
            f"{len(usable)} candidate(s) ({len(space.materials)} materials x {len(space.thicknesses)} thicknesses x "
            f"{len(space.placements)} placements, {len(excluded)} left out by the limits); lower configurations "
            "or add materials, thicknesses or placements")
    blocks, rows0 = stacked_rows(problem, usable), problem.rows(original)
    if method == "auto":
        method = "exhaustive" if math.comb(len(usable), n) <= EXHAUSTIVE_LIMIT else "relaxation"
    if method == "exhaustive":
        (best, sets), bound = exhaustive(problem, rows0, blocks, n, top, progress), None
    else:
        best, sets, bound = relaxed(problem, rows0, blocks, n, top)
    designs = sorted((Design.of(problem, [original] + [usable[i] for i in s]) for s in best),
                     key=lambda d: d.scores.loss(space.criterion))
    baseline = None
    if len(problem.specimen.configurations) > 1:
        baseline = Design.of(problem, problem.solve(problem.specimen.configurations))
    return Recommendation(tuple(designs), space.criterion, method, len(usable), sets, excluded, bound, baseline,
                          poisson_plate(problem.specimen), time.perf_counter() - start)
