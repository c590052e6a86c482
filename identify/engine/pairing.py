"""Pairing measured modes with model modes, and tracking them through the updating.

At the start a measured mode is paired with the model mode of the same rank, or of the
same nodal-line label when the measurements give one.  After every update the paired
model modes are followed by their shapes: the new model modes are assigned to the
previous ones by the modal assurance criterion (MAC, mass-weighted), with an optimal
one-to-one assignment, so two close modes that swap order keep their measured partners.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linear_sum_assignment

from fem.errors import MeasurementError
from fem.solver.modal import Modes
from fem.solver.mode_shapes import LABEL_SHARE, label_shares

#: Below this MAC a tracked mode is reported as lost (its shape changed too much).
MAC_LOST = 0.8
#: Weight of the affinity that breaks ties between model modes at the same rank distance.
LABEL_TIE = 1e-3


def mac_matrix(a: np.ndarray, b: np.ndarray, weight: sp.spmatrix) -> np.ndarray:
    """MAC(i, j) = (a_i^T W b_j)^2 / ((a_i^T W a_i)(b_j^T W b_j)) for shapes as columns."""
    wb = weight @ b
    cross = a.T @ wb
    return cross**2 / np.outer(np.einsum("ij,ij->j", a, weight @ a), np.einsum("ij,ij->j", b, wb))


def monotone_assignment(targets: np.ndarray, slots: np.ndarray) -> np.ndarray:
    """Slots for targets (both ascending), in order, minimising sum |slot - target|: the
    unlabelled measured modes keep their order and their ranks' gaps among the model modes
    the labelled ones left free (dynamic programming, O(targets x slots))."""
    n, m = len(targets), len(slots)
    cost = np.full((n + 1, m + 1), np.inf)
    cost[0, :] = 0.0
    for i in range(1, n + 1):
        for j in range(i, m + 1):
            cost[i, j] = min(cost[i, j - 1], cost[i - 1, j - 1] + abs(slots[j - 1] - targets[i - 1]))
    out, j = np.empty(n, dtype=int), m
    for i in range(n, 0, -1):
        while cost[i, j] == cost[i, j - 1]:
            j -= 1
        out[i - 1], j = slots[j - 1], j - 1
    return out


@dataclass
class ModePairing:
    """For one configuration: which model mode (0-based index) each measured mode is
    paired with, and the paired shapes of the last iteration."""

    configuration: str
    indices: np.ndarray
    shapes: np.ndarray | None = None
    lowest_mac: float = 1.0
    note: str = ""

    @classmethod
    def initial(cls, configuration: str, solution, measured_modes, labels) -> ModePairing:
        """By nodal pattern where a label is given: a labelled mode goes to the nearest-ranked
        model mode that holds its pattern (``label_shares`` at least ``LABEL_SHARE``, never an
        in-plane mode; an optimal assignment, ties to the higher affinity).  Near-degenerate
        modes that a sensor's mass mixes share both patterns in proportions that small
        changes swing (blind33: the 3-D (3,2) at 1585 Hz is 35 % (3,2) in the plate model at
        1590 Hz and 63 % in its partner 5 % higher); their ranks are what stays.  The others
        by rank (``mode`` numbers): measured mode k with model mode k, so ranks with a gap
        skip the unmeasured mode; where labels took modes out of order, the rest keep their
        order among the modes left free."""
        modes = solution.modes
        n_model = len(modes.eigenvalues)
        ranks = np.asarray(measured_modes, dtype=int) - 1
        if np.any(ranks >= n_model):
            raise MeasurementError(f"configuration {configuration!r}: mode {ranks.max() + 1} is beyond the "
                                   f"{n_model} model modes computed")
        indices = np.full(len(ranks), -1)
        labelled = [k for k, label in enumerate(labels) if label]
        unmatched = []
        if labelled:
            affinities = np.array([label_shares(solution.shape_coefficients, solution.labels, labels[k]) for k in labelled])
            nearness = np.abs(np.arange(n_model)[None, :] - ranks[labelled][:, None]) / n_model
            permitted = affinities >= LABEL_SHARE
            rows, cols = linear_sum_assignment(np.where(permitted, nearness - LABEL_TIE * affinities, n_model))
            for r, c in zip(rows, cols):
                if permitted[r, c]:
                    indices[labelled[r]] = c
                else:
                    unmatched.append(f"mode {measured_modes[labelled[r]]} {labels[labelled[r]]}")
        unpaired = [k for k in np.argsort(ranks, kind="stable") if indices[k] < 0]
        used = set(indices[indices >= 0].tolist())
        free = [i for i in range(n_model) if i not in used]
        indices[unpaired] = monotone_assignment(ranks[unpaired], np.array(free))
        note = (f"{configuration}: no start-model mode shows the pattern of {', '.join(unmatched)}; paired by rank"
                if unmatched else "")
        return cls(configuration, indices, modes.shapes[:, indices], note=note)

    def track(self, modes: Modes, weight: sp.spmatrix) -> ModePairing:
        """The pairing for new model modes, following the previous paired shapes by MAC."""
        mac = mac_matrix(self.shapes, modes.shapes, weight)
        rows, cols = linear_sum_assignment(-mac)
        indices = cols[np.argsort(rows)]
        return ModePairing(self.configuration, indices, modes.shapes[:, indices], float(mac[rows, cols].min()))

    @property
    def lost(self) -> bool:
        return self.lowest_mac < MAC_LOST
