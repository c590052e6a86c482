"""What frequencies alone cannot decide: which of two close modes is which, and the
square plate's E1 <-> E2 mirror.

Close pairs.  On a near-square plate the (1,2)/(2,1) pair may be 0.05 % apart; with one
such pair per configuration each of the 2^k assignments can be fitted, giving twin
solutions that differ by percents in E1, E2 and nu12.  ``explore_pairings`` refits every
assignment of the unlabelled close pairs, keeps the lowest misfit and returns the
others that fit within the scatter, so the user learns that only mode shapes (a
``label`` column) can decide.

The mirror.  When a 90-degree turn maps every configuration onto itself with only the
identified materials' axes exchanged, E1 <-> E2 (nu12 -> nu21) of all identified
materials together changes no frequency; the answer is oriented like the start values.
"""
from __future__ import annotations

import itertools
from typing import Callable

import numpy as np

from fem.specimen import Parameter

from .objective import Evaluation, Objective
from .pairing import ModePairing

#: Adjacent measured modes closer than this (relative) may be paired either way round.
CLOSE_MODES = 0.01
#: Up to this many close pairs every assignment (2^k) is refitted; beyond, single swaps.
MAX_EXHAUSTIVE_PAIRS = 4
#: Twins: other assignments whose chi^2 is within this of the best (about 2 std).
TWIN_CHI2 = 4.0


def close_pairs(objective: Objective) -> list[tuple[int, int]]:
    """Rows of adjacent measured modes closer than ``CLOSE_MODES`` with no labels."""
    table = objective.measurements.table
    pairs = []
    for rows in objective.rows.values():
        for a, b in zip(rows[:-1], rows[1:]):
            ta, tb = table.iloc[a], table.iloc[b]
            if tb["mode"] == ta["mode"] + 1 and not ta["label"] and not tb["label"] \
                    and tb["frequency_hz"] / ta["frequency_hz"] - 1 < CLOSE_MODES:
                pairs.append((int(a), int(b)))
    return pairs


def describe_pairs(objective: Objective, pairs) -> str:
    table = objective.measurements.table
    return ", ".join(f"{table['configuration'].iloc[a]} {table['mode'].iloc[a]}/{table['mode'].iloc[b]}"
                     for a, b in pairs)


def swapped(objective: Objective, e: Evaluation, rows: tuple[int, int]) -> Evaluation:
    """The same state with the model partners of two measured rows exchanged."""
    configuration = objective.measurements.table["configuration"].iloc[rows[0]]
    local = [int(np.flatnonzero(objective.rows[configuration] == r)[0]) for r in rows]
    pairing = e.pairings[configuration]
    indices = pairing.indices.copy()
    indices[local] = indices[local[::-1]]
    shapes = pairing.shapes.copy()
    shapes[:, local] = shapes[:, local[::-1]]
    pairings = dict(e.pairings)
    pairings[configuration] = ModePairing(configuration, indices, shapes)
    model_hz, derivatives = e.model_hz.copy(), e.derivatives.copy()
    model_hz[list(rows)] = model_hz[list(rows[::-1])]
    derivatives[list(rows)] = derivatives[list(rows[::-1])]
    return Evaluation(e.values, model_hz, derivatives, pairings, e.model)


def mirror_symmetric(objective: Objective) -> bool:
    """True when a 90-degree turn maps every configuration onto itself with only the
    identified materials' axes exchanged: a square plate, layer angles 0 or 90 deg,
    known materials in-plane isotropic, E1, E2 and nu12 of every identified material free."""
    sp = objective.model.specimen
    if abs(sp.length - sp.width) > 1e-9 * sp.length:
        return False
    kinds = {p.kind for p in objective.parameters}
    if not kinds <= {"E1", "E2", "G12", "nu12", "density"}:
        return False
    identified = {p.target for p in objective.parameters}
    for layer in sp.all_layers():
        if abs(np.sin(2 * layer.angle)) > 1e-12:
            return False
        m = layer.material
        if m.name not in identified and abs(m.E1 - m.E2) > 1e-12 * m.E1:
            return False
    return all({Parameter(k, t) for k in ("E1", "E2", "nu12")} <= set(objective.parameters) for t in identified)


def mirrored(objective: Objective, values: np.ndarray) -> np.ndarray:
    """Values with E1 and E2 exchanged and nu12 -> nu21 for every identified material."""
    index = {p: i for i, p in enumerate(objective.parameters)}
    out = values.copy()
    for p, i in index.items():
        if p.kind == "E1":
            j = index[Parameter("E2", p.target)]
            out[i], out[j] = values[j], values[i]
            n = index[Parameter("nu12", p.target)]
            out[n] = values[n] * values[j] / values[i]
    return out


def _anisotropy_sign(objective: Objective, values: np.ndarray) -> float:
    """sign(D11 - D22) of the original plate with these values."""
    specimen = objective.space.apply(objective.model.specimen, values)
    d = specimen.laminate(specimen.configurations[0].name).stiffness
    return float(np.sign(d[12] - d[14]))


def oriented_like_start(objective: Objective, e: Evaluation) -> Evaluation:
    """The state or its exact mirror, whichever has D11 - D22 of the start's sign."""
    start = np.array([objective.model.value(p) for p in objective.parameters])
    if _anisotropy_sign(objective, e.values) * _anisotropy_sign(objective, start) >= 0:
        return e
    return objective.evaluate(mirrored(objective, e.values), None)


def same_or_mirror(objective: Objective, a: Evaluation, b: Evaluation, tolerance: float = 1e-4) -> bool:
    def close(x, y):
        return bool(np.all(np.abs(x / y - 1) < tolerance))

    return close(a.values, b.values) or (mirror_symmetric(objective) and close(mirrored(objective, a.values), b.values))


def explore_pairings(objective: Objective, current: Evaluation, history: list,
                     refit: Callable[[Evaluation, list], tuple[Evaluation, bool]]):
    """Refit with every other assignment of the close unlabelled measured pairs.

    ``refit(state, history)`` iterates from a state, appending to ``history``, and returns
    (state, converged).  Returns (best state, re-paired pairs or (), notes, twin values).
    """
    pairs = close_pairs(objective)
    if not pairs:
        return current, (), [], []
    symmetric = mirror_symmetric(objective)
    if len(pairs) <= MAX_EXHAUSTIVE_PAIRS:
        combos = [c for k in range(1, len(pairs) + 1) for c in itertools.combinations(pairs, k)]
        if symmetric:
            # Swapping a set of pairs or all the others gives mirror images (same misfit):
            # refit one of each.
            combos = [c for c in combos if pairs[0] not in c]
    else:
        combos = [(p,) for p in pairs]
    outcomes = [(current, history[:], ())]
    for combo in combos:
        state = current
        for rows in combo:
            state = swapped(objective, state, rows)
        branch = history[:]
        alternative, ok = refit(state, branch)
        if ok:
            outcomes.append((alternative, branch, combo))
    best, branch, combo = min(outcomes, key=lambda o: objective.cost(o[0]))
    notes = []
    if symmetric:
        best = oriented_like_start(objective, best)
    if combo:
        history[:] = branch
        notes.append(f"re-paired close modes {describe_pairs(objective, combo)}: lower misfit than the start's pairing")
    if symmetric:
        notes.append("square plate, known layers in-plane isotropic: exchanging E1 and E2 (nu12 -> nu21) of all "
                     "identified materials changes no frequency; the orientation of the start values "
                     "(sign of D11 - D22) is given. Mode-shape labels or a non-square plate remove this ambiguity")
    unit = objective.statistics(best).chi2_unit
    twins = [o[0] for o in outcomes if 2 * (objective.cost(o[0]) - objective.cost(best)) < TWIN_CHI2 * unit
             and not same_or_mirror(objective, o[0], best)]
    if twins:
        spread = np.max(np.abs([t.values / best.values - 1 for t in twins]), axis=0)
        worst = np.argsort(-spread)[:3]
        names = ", ".join(f"{objective.parameters[i].name} {100 * spread[i]:.2g} %" for i in worst)
        notes.append(f"{len(twins)} other pairing(s) of the close modes {describe_pairs(objective, pairs)} fit within "
                     f"the scatter (twin solutions; largest differences: {names}); give mode-shape labels "
                     "(a 'label' column) for these modes to decide")
    return best, combo, notes, [t.values for t in twins]


__all__ = ["CLOSE_MODES", "close_pairs", "explore_pairings", "mirror_symmetric", "swapped"]
