"""Choosing n of m candidate configurations: a convex relaxation and exchange swaps.

The Fisher information of a set is additive over configurations,
F = (I_0 + sum_c x_c I_c) / sigma^2 with I_c = S_c^T S_c and x_c in {0, 1},
sum x_c = n.  Relaxing x to 0 <= w <= 1 makes log det F (D-optimality) and
lambda_min(F) (E-optimality) concave in w: a convex program (cvxpy) whose optimum is
an upper bound on every set's value.  The largest weights give a set; swaps of one
chosen configuration for another (Fedorov exchange) improve it while they help.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.errors import DesignError

#: The convex criterion that stands in for each ranking criterion: the condition
#: number is not concave in w, its denominator lambda_min is.
RELAXED = {"d": "d", "e": "e", "condition": "e"}


def information_loss(info: np.ndarray, criterion: str) -> np.ndarray:
    """The criterion to minimise from information matrices (..., p, p): log condition
    number of S (half the log of lambda_max / lambda_min), -log det or -log lambda_min."""
    lam = np.linalg.eigvalsh(info)
    with np.errstate(divide="ignore", invalid="ignore"):
        smallest = np.where(lam[..., 0] > 0, lam[..., 0], 0.0)
        if criterion == "condition":
            return np.where(smallest > 0, 0.5 * np.log(lam[..., -1] / smallest), np.inf)
        if criterion == "d":
            return np.where(smallest > 0, -np.sum(np.log(np.abs(lam)), axis=-1), np.inf)
        if criterion == "e":
            return np.where(smallest > 0, -np.log(smallest), np.inf)
    raise ValueError(f"criterion {criterion!r}: allowed: 'condition', 'd', 'e'")


@dataclass(frozen=True)
class Relaxation:
    """The relaxed weights (m,) and the relaxed optimum of ``criterion`` ('d': log det,
    'e': smallest eigenvalue) of I_0 + sum w_c I_c: no set of n does better."""

    weights: np.ndarray
    bound: float
    criterion: str


def relax(info0: np.ndarray, infos: np.ndarray, n: int, criterion: str) -> Relaxation:
    """Solve the relaxation of choosing ``n`` of the ``infos`` (m, p, p) added to ``info0``."""
    import cvxpy as cp  # here: importing it takes ~1 s, which every worker process would pay

    m, p, _ = infos.shape
    relaxed = RELAXED[criterion]
    scale = np.trace(info0 + n * infos.mean(axis=0)) / p  # O(1) entries for the solver
    w = cp.Variable(m)
    stacked = (infos.reshape(m, p * p) / scale).T
    total = info0 / scale + cp.reshape(stacked @ w, (p, p), order="C")
    total = (total + total.T) / 2
    objective = cp.log_det(total) if relaxed == "d" else cp.lambda_min(total)
    problem = cp.Problem(cp.Maximize(objective), [w >= 0, w <= 1, cp.sum(w) == n])
    try:
        problem.solve(solver=cp.CLARABEL)
    except cp.SolverError as exc:
        raise DesignError(
            f"the convex relaxation failed ({exc}); use --method exhaustive on a smaller space"
        ) from None
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or w.value is None:
        raise DesignError(
            f"the convex relaxation ended {problem.status}: every candidate set may be singular; "
            "check with plan-tests check or add modes"
        )
    bound = problem.value + p * np.log(scale) if relaxed == "d" else problem.value * scale
    return Relaxation(np.clip(w.value, 0.0, 1.0), float(bound), relaxed)


def swap_search(info0: np.ndarray, infos: np.ndarray, start, criterion: str) -> dict[tuple[int, ...], float]:
    """Best-improvement exchange from the set ``start``: replace one member by one
    non-member while that lowers the loss.  Returns every set looked at -> its loss
    (the final set is the best of them).

    With a leading axis of parameter points (``info0`` (k, p, p), ``infos`` (k, m, p, p))
    the loss of a set is its worst over the points (the robust score)."""
    if info0.ndim == 2:
        info0, infos = info0[None], infos[None]
    m = infos.shape[1]

    def worst(total: np.ndarray) -> np.ndarray:
        return information_loss(total, criterion).max(axis=0)

    current = tuple(sorted(start))
    seen = {current: float(worst(info0 + infos[:, list(current)].sum(axis=1)))}
    while True:
        total = info0 + infos[:, list(current)].sum(axis=1)
        others = np.setdiff1d(np.arange(m), current)
        best, best_loss = current, seen[current]
        for i in current:
            losses = worst((total - infos[:, i])[:, None] + infos[:, others])
            for j, value in zip(others, losses):
                key = tuple(sorted(set(current) - {i} | {int(j)}))
                seen[key] = float(value)
                if value < best_loss - 1e-12 * abs(best_loss):
                    best, best_loss = key, float(value)
        if best == current:
            return seen
        current = best
