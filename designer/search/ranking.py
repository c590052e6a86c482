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

from ..candidates import candidates
from ..problem import Problem, Solved, solve_points, unmeasurable
from ..progress import Bar, Progress
from ..scores.design import Design, score_design
from ..scores.poisson import PoissonPlate, poisson_plate
from ..scores.scoring import loss, singular_values
from .methods import METHODS
from .mirror import collapse, is_mirror_symmetric
from .relaxation import information_loss, relax, swap_search

#: Sets up to which the search is exhaustive (a few seconds of batched SVDs).
EXHAUSTIVE_LIMIT = 50_000
#: Sets scored per batched SVD (bounds memory to ~20 MB).
BATCH = 4096
ORIGINAL = Configuration("original")


@dataclass(frozen=True)
class Bound:
    """How far the chosen set can be from the best one: the relaxation's optimum of the
    convex ``criterion`` ('d': log det F, 'e': smallest eigenvalue of F) against the
    chosen set's value.  No set of the space exceeds ``relaxed``."""

    criterion: str
    relaxed: float
    chosen: float
    basis: str = "nominal"

    def report(self) -> str:
        of = "" if self.basis == "nominal" else " (of the Fisher information averaged over the prior samples)"
        if self.criterion == "d":
            gap = max(self.relaxed - self.chosen, 0.0)
            return (
                f"relaxation bound{of}: log det F <= {self.relaxed:.5g}; chosen {self.chosen:.5g} (gap "
                f"{gap:.3g}): "
                f"its confidence ellipsoid is at most {math.exp(gap / 2):.4f} x the volume of the best set's"
            )
        return (
            f"relaxation bound{of}: smallest eigenvalue of F <= {self.relaxed:.5g}; chosen {self.chosen:.5g} "
            f"({100 * self.chosen / self.relaxed:.3g} % of the bound)"
        )

    def to_dict(self) -> dict:
        return {
            "criterion": self.criterion,
            "relaxed": self.relaxed,
            "chosen": self.chosen,
            "basis": self.basis,
        }


@dataclass(frozen=True)
class Recommendation:
    """Ranked designs (best first) and how the search got them.

    method: 'exhaustive' or 'relaxation'; candidates: configurations solved; sets:
    sets scored; excluded: candidates left out (name -> reason); bound: the relaxation's
    (None when exhaustive); baseline: the spec's own set scored alike (None without
    added configurations); seconds: wall time; mirrors: per design, the added
    configurations of its mirror left out of the ranking (None when none); limits: the
    lab's limits used (``fem.limits.Limits``); prior_samples: parameter points besides
    the nominal one each set was scored at (0: nominal only).
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
    mirrors: tuple = ()
    limits: object = None
    prior_samples: int = 0

    @property
    def best(self) -> Design:
        return self.designs[0]

    def to_dict(self) -> dict:
        designs = []
        for d, mirror in zip(self.designs, self.mirrors or [None] * len(self.designs)):
            designs.append(
                {
                    **d.to_dict(),
                    "mirror": None if mirror is None else [c.name for c in mirror if not c.is_original],
                }
            )
        return {
            "designs": designs,
            "search": {
                "criterion": self.criterion,
                "method": self.method,
                "candidates": self.candidates,
                "sets": self.sets,
                "excluded": self.excluded,
                "seconds": round(self.seconds, 3),
                "bound": self.bound.to_dict() if self.bound else None,
                "ranked_by": "worst over the prior" if self.prior_samples else "nominal",
                "prior_samples": self.prior_samples,
                "mirrors_collapsed": sum(m is not None for m in self.mirrors),
            },
            "limits": self.limits.to_dict() if self.limits is not None else None,
            "baseline": self.baseline.to_dict() if self.baseline else None,
            "poisson_plate": self.poisson.to_dict(),
        }

    def _repr_html_(self) -> str:
        return html_pre(self.report())

    def report(self) -> str:
        robust = self.best.robust
        how = (
            f"scored at the nominal properties and {self.prior_samples} prior samples (+-"
            f"{100 * robust.range_rel:g} %), ranked by the worst case of"
            if robust is not None
            else "scored at the spec's nominal properties, ranked by"
        )
        lines = [
            f"searched {self.sets} sets of {len(self.best.solved) - 1} added plates from {self.candidates} "
            f"candidates ({self.method}, {self.seconds:.1f} s), {how} {CRITERIA[self.criterion]}"
        ]
        if robust is None:
            lines.append(
                "(the start values are what is unknown: set [design] prior_range_rel, e.g. 0.3, to score "
                "every set over that range)"
            )
        if self.limits is not None:
            lines.append(self.limits.describe())
        if self.excluded:
            lines.append(
                f"left out {len(self.excluded)} candidates: "
                + "; ".join(f"{name} ({why})" for name, why in list(self.excluded.items())[:5])
                + (" ..." if len(self.excluded) > 5 else "")
            )
        if self.bound:
            lines.append(self.bound.report())
        worst = (
            f"  {'worst ' + {'condition': 'cond', 'd': 'log det', 'e': 'min eig'}[self.criterion]:>12s}"
            if robust is not None
            else ""
        )
        lines += [
            "",
            f"{'rank':>4s}  {'condition':>10s}  {'log det F':>10s}{worst}  {'verdict':<15s} "
            f"{'targets':<9s} added plates",
        ]

        def row(label: str, d: Design) -> str:
            w = f"  {d.robust.worst(self.criterion):>12.5g}" if d.robust is not None else ""
            met = "met" if d.meets_targets else f"{len(d.target_misses())} miss"
            return (
                f"{label:>4s}  {d.scores.condition_number:>10.4g}  {d.scores.logdet_fisher:>10.5g}{w}  "
                f"{d.scores.verdict:<15s} {met:<9s} {', '.join(d.names[1:])}"
            )

        notes = []
        for rank, (d, mirror) in enumerate(zip(self.designs, self.mirrors or [None] * len(self.designs)), 1):
            lines.append(row(str(rank), d))
            if mirror is not None:
                notes.append(
                    f"rank {rank} stands for its mirror too: "
                    f"{', '.join(c.name for c in mirror if not c.is_original)}"
                )
        if self.baseline is not None:
            lines.append(row("spec", self.baseline) + " (the spec's configurations)")
        if notes:
            lines += [
                "",
                "mirror designs (top and bottom swapped) score alike on this mid-plane symmetric specimen; "
                "each is shown once:",
            ] + [f"  {n}" for n in notes]
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


def exhaustive(
    problem: Problem,
    original: np.ndarray,
    blocks: np.ndarray,
    n: int,
    top: int,
    progress: Progress | None = None,
) -> tuple[list[tuple[int, ...]], int]:
    """Every set of ``n`` of the candidate ``blocks``: the ``top`` best by the criterion
    (ties broken by enumeration order), and the number of sets scored.

    ``original`` (r0, p) and ``blocks`` (m, r, p) are the rows at the nominal point; with
    a leading axis of parameter points ((k, r0, p), (k, m, r, p)) a set's loss is its
    worst over the points."""
    if original.ndim == 2:
        original, blocks = original[None], blocks[None]
    k, m, r, p = blocks.shape
    total = math.comb(m, n)
    combos = itertools.combinations(range(m), n)
    best_loss, best_sets = np.empty(0), np.empty((0, n), dtype=int)
    batch = max(64, BATCH // k)
    with Bar(progress, total, "scoring sets") as bar:
        while True:
            chunk = np.fromiter(itertools.chain.from_iterable(itertools.islice(combos, batch)), dtype=int)
            if chunk.size == 0:
                break
            sets = chunk.reshape(-1, n)
            stacks = np.concatenate(
                [
                    np.broadcast_to(original[:, None], (k, len(sets)) + original.shape[1:]),
                    blocks[:, sets].reshape(k, len(sets), n * r, p),
                ],
                axis=2,
            )
            losses = loss(singular_values(stacks), problem.space.frequency_std_rel, problem.space.criterion)
            best_loss = np.concatenate([best_loss, losses.max(axis=0)])
            best_sets = np.concatenate([best_sets, sets])
            keep = np.argsort(best_loss, kind="stable")[:top]
            best_loss, best_sets = best_loss[keep], best_sets[keep]
            bar.update(len(sets))
    return [tuple(int(i) for i in s) for s in best_sets], total


def relaxed(
    problem: Problem, original: np.ndarray, blocks: np.ndarray, n: int, top: int
) -> tuple[list[tuple[int, ...]], int, Bound]:
    """The convex relaxation, rounded and improved by swaps: the ``top`` best sets seen,
    the number of sets scored, and the relaxation's bound (in Fisher-information units).

    With a leading axis of parameter points (as ``exhaustive``) the relaxation works on
    the Fisher information averaged over them (a pseudo-Bayesian design) and the swaps on
    the worst case; the bound then applies to the averaged information."""
    space = problem.space
    if original.ndim == 2:
        original, blocks = original[None], blocks[None]
    p = original.shape[-1]
    info0 = np.einsum("krp,krq->kpq", original, original)
    infos = np.einsum("kmrp,kmrq->kmpq", blocks, blocks)
    mean0, means = info0.mean(axis=0), infos.mean(axis=0)
    relaxation = relax(mean0, means, n, space.criterion)
    seen = swap_search(info0, infos, np.argsort(-relaxation.weights, kind="stable")[:n], space.criterion)
    best = sorted(seen, key=seen.get)[:top]
    chosen = float(-information_loss(mean0 + means[list(best[0])].sum(axis=0), relaxation.criterion))
    sigma2 = space.frequency_std_rel**2
    basis = "nominal" if len(info0) == 1 else "prior mean"
    if relaxation.criterion == "d":  # log det (I / sigma^2) = log det I - p log sigma^2
        bound = Bound("d", relaxation.bound - p * math.log(sigma2), chosen - p * math.log(sigma2), basis)
    else:  # lambda_min (I / sigma^2); the loss was -log lambda_min
        bound = Bound("e", relaxation.bound / sigma2, math.exp(chosen) / sigma2, basis)
    return best, len(seen), bound


def recommend(
    problem: Problem | SpecimenModel,
    top: int = 5,
    method: str = "auto",
    pool=None,
    progress: Progress | None = None,
) -> Recommendation:
    """The ``top`` best sets of ``space.size - 1`` candidates for the original plate.

    The candidates are the added plates of the ``[design]`` table (materials x
    thicknesses x placements, within the lab's limits); each set is ranked by the
    table's criterion.  With ``[design] prior_range_rel`` every set is scored over the
    prior samples too and ranked by its worst case; mirror designs of a mid-plane
    symmetric specimen are shown once.

    Parameters
    ----------
    problem : Problem or SpecimenModel
        A planning problem, or a model (its ``[design]`` table makes the problem).
    top : int, default 5
        How many designs to return (a whole number >= 1).
    method : {"auto", "exhaustive", "relaxation"}, default "auto"
        The search; "auto": exhaustive up to ``EXHAUSTIVE_LIMIT`` (50 000) sets, else the
        relaxation.
    pool : concurrent.futures.Executor, optional
        Where to solve the candidates not cached (None: in this process).
    progress : Progress, optional
        Where a progress bar goes for long runs (None: nowhere).

    Returns
    -------
    Recommendation
        The ranked designs (best first), the spec's own set scored alike and how the
        search got them.

    Raises
    ------
    DesignError
        ``method`` or ``top`` is not allowed, every set would be singular (too few
        frequencies for the parameters), the original plate has no measurable mode, or
        the design space offers too few usable candidates.

    Examples
    --------
    >>> import designer
    >>> from identify.examples import COATED_PLATE
    >>> from fem import load_spec
    >>> result = designer.recommend(load_spec(COATED_PLATE), top=1)
    >>> result.best.names, round(result.best.scores.condition_number, 1)
    (('original', 'steel_stock_1mm_top', 'steel_stock_1mm_bottom'), 19.3)
    """
    problem = Problem.of(problem)
    start = time.perf_counter()
    space = problem.space
    if method not in METHODS:
        raise DesignError(f"method {method!r}: allowed: {', '.join(METHODS)}")
    if not isinstance(top, int) or top < 1:
        raise DesignError(f"--top {top!r}: need a whole number >= 1")
    n, p = space.size - 1, len(problem.parameters)
    if space.size * problem.modes < p:
        raise DesignError(
            f"[design].configurations = {space.size} x [model].modes = {problem.modes} gives "
            f"{space.size * problem.modes} frequencies for {p} parameters: every set is singular; "
            f"measure at least {math.ceil(p / space.size)} modes per plate or add configurations"
        )
    offered = candidates(space, problem.specimen)
    points = problem.points()
    at_points = solve_points(points, (ORIGINAL,) + offered.configurations, pool=pool, progress=progress)
    original, solved = at_points[0][0], at_points[0][1:]
    if not problem.measured(original).any():
        raise unmeasurable(problem, original)
    excluded = dict(offered.excluded)
    usable = []
    for i, s in enumerate(solved):
        if problem.measured(s).any():
            usable.append(i)
        else:
            excluded[s.configuration.name] = (
                "no mode inside band_hz" if space.limits.band else "no separable mode"
            )
    if len(usable) < n:
        raise DesignError(
            f"[design].configurations = {space.size} needs {n} added plates but the design space offers "
            f"{len(usable)} candidate(s) ({len(space.materials)} materials x {len(space.thicknesses)} "
            "thicknesses x "
            f"{len(space.placements)} placements, {len(excluded)} left out by the limits); lower "
            "configurations "
            "or add materials, thicknesses or placements"
        )
    rows0 = np.stack([stacked_rows(problem, [row[0]])[0] for row in at_points])
    blocks = np.stack([stacked_rows(problem, [row[1 + i] for i in usable]) for row in at_points])
    symmetric = is_mirror_symmetric(problem.specimen)
    wanted = 2 * top if symmetric else top  # a set has at most one mirror
    if method == "auto":
        method = "exhaustive" if math.comb(len(usable), n) <= EXHAUSTIVE_LIMIT else "relaxation"
    if method == "exhaustive":
        (best, sets), bound = exhaustive(problem, rows0, blocks, n, wanted, progress), None
    else:
        best, sets, bound = relaxed(problem, rows0, blocks, n, wanted)

    def design(s: tuple[int, ...]) -> Design:
        chosen = [1 + usable[i] for i in s]
        prior = [[row[0]] + [row[j] for j in chosen] for row in at_points[1:]]
        return Design.of(problem, [original] + [solved[j - 1] for j in chosen], prior or None)

    designs = sorted((design(s) for s in best), key=lambda d: d.loss(space.criterion))
    designs, mirrors = collapse(designs, lambda d: [s.configuration for s in d.solved], symmetric)
    baseline = None
    if len(problem.specimen.configurations) > 1:
        baseline = score_design(problem, problem.specimen.configurations, pool=pool)
    return Recommendation(
        tuple(designs[:top]),
        space.criterion,
        method,
        len(usable),
        sets,
        excluded,
        bound,
        baseline,
        poisson_plate(problem.specimen),
        time.perf_counter() - start,
        tuple(mirrors[:top]),
        space.limits,
        len(points) - 1,
    )
