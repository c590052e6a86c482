"""Pairing measured modes with model modes, and tracking them through the updating.

At the start a measured mode is paired with the model mode of the same rank, or of the
same nodal-line label when the measurements give one (a model mode that holds the
label's pattern of beam products, or whose nodal lines a lab would count as the label).
After every update the paired model modes are followed by their shapes: the new model
modes are assigned to the previous ones by the modal assurance criterion (MAC,
mass-weighted), with an optimal one-to-one assignment, so two close modes that swap order
keep their measured partners.

A measured mode shape (roving hammer, laser vibrometer) pins its mode as a label does,
more surely: the model modes it permits are those it resembles at the measured points
(MAC, ``SHAPE_MAC``), or, where model modes lie close in frequency, those whose span
holds it (a measured mode mixes close model modes in proportions that small changes
swing: a sensor's mass, a misaligned ply).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linear_sum_assignment

from fem.errors import MeasurementError
from fem.solver.modal import Modes
from fem.solver.mode_shapes import LABEL_SHARE, deflection_operator, label_shares, single_term

from ..measurements import ModeShape

#: Below this MAC a tracked mode is reported as lost (its shape changed too much).
MAC_LOST = 0.8
#: Weight of the affinity that breaks ties between model modes at the same rank distance.
LABEL_TIE = 1e-3
#: A measured shape permits a model mode whose MAC with it at the measured points, or the
#: share of it the span of the mode's close neighbours holds, reaches this.  Measured
#: shapes of separated modes correlate at 0.9 and more with their model modes; unrelated
#: modes sampled on a 5 x 4 grid reach 0.3-0.5 by aliasing.
SHAPE_MAC = 0.6
#: Model modes within this relative frequency of each other may mix in the measured shape.
CLOSE_MODES = 0.03
#: A member of a close group is permitted when its MAC is at least this share of the
#: group's best for the shape: the shape's projection on it then has half the amplitude
#: of the best one's or more, a true mixture, which frequency decides.  Below, the shape
#: decides (a hidden sensor that swaps two modes 0.4 % apart: MAC 0.88 against 0.001).
MEMBER_SHARE = 0.25


def mac_matrix(a: np.ndarray, b: np.ndarray, weight: sp.spmatrix) -> np.ndarray:
    """MAC(i, j) = (a_i^T W b_j)^2 / ((a_i^T W a_i)(b_j^T W b_j)) for shapes as columns."""
    wb = weight @ b
    cross = a.T @ wb
    return cross**2 / np.outer(np.einsum("ij,ij->j", a, weight @ a), np.einsum("ij,ij->j", b, wb))


def shape_at_points(solution, shape: ModeShape) -> np.ndarray:
    """The model modes' deflection at the shape's measured points: (points, modes)."""
    return deflection_operator(solution.units, shape.xy[:, 0], shape.xy[:, 1]) @ solution.modes.shapes


def close_modes(solution, j: int) -> np.ndarray:
    """The bending modes (indices) within ``CLOSE_MODES`` of mode j's frequency, j
    among them when it bends: the modes a measured shape of mode j may mix."""
    f = solution.frequencies_hz
    return np.flatnonzero((np.asarray(solution.labels) != "in-plane") & (np.abs(f / f[j] - 1) <= CLOSE_MODES))


def point_mac(model_at_points: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    """MAC of a measured (complex) shape with each model mode at the same points (modes,)."""
    cross = np.abs(amplitude.conj() @ model_at_points) ** 2
    norms = np.sum(np.abs(model_at_points) ** 2, axis=0) * np.vdot(amplitude, amplitude).real
    return cross / np.where(norms > 0, norms, 1.0)


def shape_permits(solution, shape: ModeShape) -> tuple[np.ndarray, np.ndarray]:
    """The model modes a measured shape permits (bool, modes) and its MAC with each.

    Mode j is permitted when the span of the modes within ``CLOSE_MODES`` of it (itself
    alone when separated) holds ``SHAPE_MAC`` of the shape and its own MAC is at least
    ``MEMBER_SHARE`` of the best in that group: close modes that the test mixes in other
    proportions than the model (a square plate's pairs under a sensor, MAC 0.31 and 0.68)
    are told apart by frequency; never an in-plane mode."""
    at_points = shape_at_points(solution, shape)
    mac = point_mac(at_points, shape.amplitude)
    bending = np.asarray(solution.labels) != "in-plane"
    held, member = np.zeros(len(mac)), np.zeros(len(mac), dtype=bool)
    for j in np.flatnonzero(bending):
        group = close_modes(solution, j)
        coefficients = np.linalg.lstsq(at_points[:, group], shape.amplitude, rcond=None)[0]
        projected = at_points[:, group] @ coefficients
        held[j] = np.vdot(projected, projected).real / np.vdot(shape.amplitude, shape.amplitude).real
        member[j] = mac[j] >= MEMBER_SHARE * mac[group].max()
    return bending & member & (held >= SHAPE_MAC), mac


def permits(solution, labels, shapes) -> tuple[np.ndarray | None, np.ndarray | None, list[str]]:
    """Which model modes each measured row may pair with, by its label (a mode that holds
    ``LABEL_SHARE`` of its pattern, or, for a label of one term, whose nodal lines a lab
    would count so) and its measured shape: (rows, modes) bool and the affinity that
    breaks ties (the shape's MAC, else the label's share), both None when no row has
    either; and a note for every shape that permits no mode (that row is then left free:
    a shape that fits nothing says nothing of which mode it is)."""
    if not any(labels) and not any(s is not None for s in shapes):
        return None, None, []
    n_model = len(solution.labels)
    allowed, affinity, notes = (
        np.ones((len(labels), n_model), dtype=bool),
        np.zeros((len(labels), n_model)),
        [],
    )
    for i, (label, shape) in enumerate(zip(labels, shapes)):
        if label:
            affinity[i] = label_shares(solution.shape_coefficients, solution.labels, label)
            allowed[i] = affinity[i] >= LABEL_SHARE
            counted = single_term(label)
            if counted is not None:
                # A lab counts the nodal lines on the plate: a mode whose lines it would
                # count so is permitted though bent lines spread its pattern.
                allowed[i] |= np.all(solution.nodal_lines == counted, axis=1)
        if shape is not None:
            by_shape, mac = shape_permits(solution, shape)
            if by_shape.any():
                allowed[i] &= by_shape
                affinity[i] = mac
            else:
                notes.append(
                    f"{shape.configuration}: the shape measured at {shape.frequency_hz:.6g} Hz resembles no "
                    f"model mode (best MAC {mac.max():.2f}, model mode {int(np.argmax(mac)) + 1}); "
                    "paired by frequency"
                )
    return allowed, affinity, notes


@dataclass(frozen=True)
class ShapeCorrelation:
    """One configuration's measured shapes against the model's modes at the measured
    points: the MAC matrix (measured shapes x model modes), the model mode each shape's
    peak is paired with (-1: left out), and two maps over the points measured.

    - ``comac``: the coordinate MAC (Lieven and Ewins) of the shapes and their paired
      model modes, each scaled to unit length: 1 where they agree in magnitude at the
      point over all modes (signs are not compared).
    - ``residual``: at each point, the part of the measured shapes that the paired model
      mode and the model modes within ``CLOSE_MODES`` of it cannot reproduce (their
      least-squares fit at the points), RMS over the modes, relative to the measured
      amplitude there: 0 where the model holds.  Close modes that the test mixes in
      other proportions (a square plate's pairs under a sensor) are not counted as
      failure; what is left is local: a sensor, a defect, a stiffer or softer patch."""

    configuration: str
    shapes: tuple[ModeShape, ...]
    model_hz: np.ndarray
    mac: np.ndarray
    paired: np.ndarray
    xy: np.ndarray  # the points measured, union over the shapes [m]
    comac: np.ndarray
    residual: np.ndarray

    @property
    def measured_hz(self) -> np.ndarray:
        return np.array([s.frequency_hz for s in self.shapes])

    @property
    def paired_mac(self) -> np.ndarray:
        """Each shape's MAC with its paired model mode (NaN: left out)."""
        ok = self.paired >= 0
        out = np.full(len(self.paired), np.nan)
        out[ok] = self.mac[np.flatnonzero(ok), self.paired[ok]]
        return out

    @property
    def worst_point(self) -> np.ndarray | None:
        """The point [m] where the model's shapes fail most (largest ``residual``); None
        when no shape was paired (every peak with a shape left out)."""
        if not np.isfinite(self.residual).any():
            return None
        return self.xy[int(np.nanargmax(self.residual))]

    def to_dict(self) -> dict:
        return {
            "measured_hz": self.measured_hz.tolist(),
            "model_mode": list(range(1, len(self.model_hz) + 1)),
            "model_hz": self.model_hz.tolist(),
            "mac": self.mac.tolist(),
        }


def _unit(v: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(v)
    return v / norm if norm > 0 else v


def shape_correlation(solution, shapes: list[ModeShape], paired: np.ndarray) -> ShapeCorrelation:
    """The correlation of a configuration's measured ``shapes`` with the ``solution``'s
    modes, each shape's peak paired with model mode ``paired[k]`` (-1: none)."""
    xy = np.unique(np.round(np.concatenate([s.xy for s in shapes]), 9), axis=0)
    mac = np.array([point_mac(shape_at_points(solution, s), s.amplitude) for s in shapes])
    at_points = deflection_operator(solution.units, xy[:, 0], xy[:, 1]) @ solution.modes.shapes
    product, measured2, model2, left2 = (np.zeros(len(xy)) for _ in range(4))
    for shape, j in zip(shapes, paired):
        if j < 0:
            continue
        where = np.array([np.flatnonzero(np.all(np.abs(xy - p) <= 1e-9, axis=1))[0] for p in shape.xy])
        a, x = _unit(shape.amplitude), _unit(at_points[where, j].astype(complex))
        product[where] += np.abs(a * x.conj())
        measured2[where] += np.abs(a) ** 2
        model2[where] += np.abs(x) ** 2
        close = at_points[np.ix_(where, np.union1d([j], close_modes(solution, j)))]
        left2[where] += np.abs(a - close @ np.linalg.lstsq(close, a, rcond=None)[0]) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        comac = np.where(measured2 > 0, product**2 / (measured2 * model2), np.nan)
        residual = np.where(measured2 > 0, np.sqrt(left2 / measured2), np.nan)
    return ShapeCorrelation(
        shapes[0].configuration,
        tuple(shapes),
        solution.frequencies_hz.copy(),
        mac,
        np.asarray(paired, dtype=int),
        xy,
        comac,
        residual,
    )


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
    def initial(cls, configuration: str, solution, measured_modes, labels, shapes=None) -> ModePairing:
        """By nodal pattern where a label or a measured shape is given (``permits``): such
        a mode goes to the nearest-ranked model mode it permits (an optimal assignment,
        ties to the higher affinity).  Near-degenerate modes that a sensor's mass mixes
        share both patterns in proportions that small changes swing (blind33: the 3-D
        (3,2) at 1585 Hz is 35 % (3,2) in the plate model at 1590 Hz and 63 % in its
        partner 5 % higher); their ranks are what stays.  The others by rank (``mode``
        numbers): measured mode k with model mode k, so ranks with a gap skip the
        unmeasured mode; where labels took modes out of order, the rest keep their order
        among the modes left free.  Ranks count the bending modes only: a test that
        measures the deflection does not see a mode that moves in the plate's plane (a
        thick unsymmetric laminate's or a light sandwich's membrane modes), so no
        unlabelled measured mode is paired with one."""
        modes = solution.modes
        n_model = len(modes.eigenvalues)
        bends = ~np.asarray(solution.moves_in_plane, dtype=bool)
        seen_rank = np.cumsum(bends) - 1  # each model mode's rank among the bending modes
        ranks = np.asarray(measured_modes, dtype=int) - 1
        if np.any(ranks >= bends.sum()):
            raise MeasurementError(
                f"configuration {configuration!r}: mode {ranks.max() + 1} is beyond the "
                f"{bends.sum()} bending model modes computed"
            )
        shapes = [None] * len(ranks) if shapes is None else shapes
        allowed, affinity, notes = permits(solution, labels, shapes)
        indices = np.full(len(ranks), -1)
        pinned = [
            k for k in range(len(ranks)) if labels[k] or (shapes[k] is not None and not allowed[k].all())
        ]
        unmatched = []
        if pinned:
            nearness = np.abs(seen_rank[None, :] - ranks[pinned][:, None]) / n_model
            permitted = allowed[pinned]
            rows, cols = linear_sum_assignment(
                np.where(permitted, nearness - LABEL_TIE * affinity[pinned], n_model)
            )
            for r, c in zip(rows, cols):
                if permitted[r, c]:
                    indices[pinned[r]] = c
                else:
                    k = pinned[r]
                    unmatched.append(f"mode {measured_modes[k]} {labels[k] or 'with its shape'}")
        unpaired = [k for k in np.argsort(ranks, kind="stable") if indices[k] < 0]
        used = set(indices[indices >= 0].tolist())
        free = np.array([i for i in np.flatnonzero(bends) if i not in used], dtype=int)
        indices[unpaired] = free[
            np.searchsorted(seen_rank[free], monotone_assignment(ranks[unpaired], seen_rank[free]))
        ]
        if unmatched:
            notes.append(
                f"{configuration}: no start-model mode shows the pattern of {', '.join(unmatched)}; "
                "paired by rank"
            )
        return cls(configuration, indices, modes.shapes[:, indices], note="; ".join(notes))

    def track(self, modes: Modes, weight: sp.spmatrix) -> ModePairing:
        """The pairing for new model modes, following the previous paired shapes by MAC."""
        mac = mac_matrix(self.shapes, modes.shapes, weight)
        rows, cols = linear_sum_assignment(-mac)
        indices = cols[np.argsort(rows)]
        return ModePairing(
            self.configuration, indices, modes.shapes[:, indices], float(mac[rows, cols].min())
        )

    @property
    def lost(self) -> bool:
        return self.lowest_mac < MAC_LOST
