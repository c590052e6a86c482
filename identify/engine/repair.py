"""A quick check of the mode pairing at a solution, for the many refits of a diagnosis.

``ambiguity.settle_pairings`` refits every pairing frequencies cannot rule out (a few
iterations each): right for the fit a user reads, too costly for each candidate effect of
a diagnosis.  A candidate is still judged after re-pairing, not with the pairing its start
inherited: at its solution the pairing made afresh (by rank and label) and every swap of
adjacent unlabelled modes with equal and opposite residuals are evaluated at the same
parameter values (cached solves, no iteration); the best one that lowers the misfit is
refitted from, and the check repeated.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .ambiguity import beneficial_swaps, describe_pairs, swapped
from .objective import Evaluation, Objective

#: Re-pair-and-refit rounds at most.
ROUNDS = 3
#: Iterations of a refit from a re-paired state.
REFIT_ITERATIONS = 30


def quick_repair(
    objective: Objective,
    current: Evaluation,
    history: list,
    refit: Callable[[Evaluation, list, int], tuple[Evaluation, object]],
) -> tuple[Evaluation, str, list]:
    """(state, what was re-paired or '', notes): ``current`` re-paired where that lowers
    the misfit at once, refitted from there (``refit`` as in ``settle_pairings``)."""
    done = []
    for _ in range(ROUNDS):
        options = []
        fresh = objective.evaluate(current.values, None, differentiate=False)
        if any(
            np.any(fresh.pairings[c].indices != current.pairings[c].indices) for c in objective.configurations
        ):
            options.append((fresh, "the pairing made afresh at the solution (by rank and label)"))
        options += [
            (
                swapped(objective, current, rows),
                f"modes {describe_pairs(objective, [rows])} (equal and opposite residuals)",
            )
            for rows in beneficial_swaps(objective, current)
        ]
        better = [o for o in options if objective.cost(o[0]) < objective.cost(current) * (1 - 1e-9)]
        if not better:
            break
        state, what = min(better, key=lambda o: objective.cost(o[0]))
        branch = history[:]
        state, stop = refit(objective.differentiated(state), branch, REFIT_ITERATIONS)
        if not stop.converged or objective.cost(state) >= objective.cost(current):
            break
        current, history[:] = state, branch
        done.append(what)
    notes = (
        [f"re-paired {'; '.join(done)}: lower misfit than the pairing followed from the start"]
        if done
        else []
    )
    return current, "; ".join(done), notes


__all__ = ["quick_repair"]
