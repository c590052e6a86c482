"""A quick check of the mode pairing at a solution, for the many refits of a diagnosis.

``ambiguity.settle_pairings`` refits every pairing frequencies cannot rule out (a few
iterations each): right for the fit a user reads, too costly for each candidate effect of
a diagnosis.  A candidate is still judged after re-pairing, not with the pairing its start
inherited: at its solution the pairing made afresh (by rank and label) and every swap of
adjacent unlabelled modes with equal and opposite residuals are evaluated at the same
parameter values (cached solves, no iteration); the best one that lowers the misfit is
refitted from, and the check repeated.

When none lowers the misfit at once, the same two modes followed the wrong way round in
several configurations (``ambiguity.same_two_modes``) are swapped together: that often
raises the misfit at the solution, which moved to fit the wrong order, and pays only
after a refit.  They are refitted from when one linearised step from the swapped state is
predicted below the current misfit (``predicted_chi2``: the swapped state carries its
sensitivities, so no solve); a refit that does not end below the current misfit is
dropped, as any other.  Only then: a candidate may lack some of the specimen's physics
(a sensor), and a joint swap taken before the re-pairing that pays at once can pair the
modes to suit that lack, which the later rounds inherit (``docs/identify.md``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .ambiguity import (
    beneficial_swaps,
    describe_pairs,
    near_pairs,
    predicted_chi2,
    same_two_modes,
    swapped,
    swapped_together,
)
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
    the misfit at once, or else (the same two modes swapped together) where it is
    predicted to after one step, refitted from there (``refit`` as in
    ``settle_pairings``)."""
    done = []
    for _ in range(ROUNDS):
        threshold = objective.cost(current) * (1 - 1e-9)
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
        better = [o for o in options if objective.cost(o[0]) < threshold]
        # The re-pairing that pays at once; only when none does, the joint swaps predicted
        # to pay, most promising first (each refit dropped if it does not end lower).
        if better:
            tries = [min(better, key=lambda o: objective.cost(o[0]))]
        else:
            tries = [t[1:] for t in sorted(_joint_swaps(objective, current, threshold), key=lambda t: t[0])]
        for state, what in tries:
            branch = history[:]
            state, stop = refit(objective.differentiated(state), branch, REFIT_ITERATIONS)
            if stop.converged and objective.cost(state) < objective.cost(current):
                current, history[:] = state, branch
                done.append(what)
                break
        else:
            break
    notes = (
        [f"re-paired {'; '.join(done)}: lower misfit than the pairing followed from the start"]
        if done
        else []
    )
    return current, "; ".join(done), notes


def _joint_swaps(
    objective: Objective, current: Evaluation, threshold: float
) -> list[tuple[float, Evaluation, str]]:
    """(predicted cost, state, what) of the same two modes swapped together in several
    configurations, where one linearised step from the swapped state is predicted below
    ``threshold`` (a cost)."""
    current, out = objective.differentiated(current), []
    for group in same_two_modes(objective, current, near_pairs(objective)):
        state = swapped_together(objective, current, group)
        predicted = 0.5 * predicted_chi2(objective, state)
        if predicted < threshold:
            out.append((predicted, state, f"modes {describe_pairs(objective, group)} together (predicted)"))
    return out


__all__ = ["quick_repair"]
