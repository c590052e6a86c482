"""The test sheet: how to carry out the free-free test of each configuration.

Computed from the predicted modes of the measured band (mass-normalised FE shapes,
deflection w sampled on a regular grid with 1 % spacing, each mode normalised by its
peak |w| over the plate), following impact-test practice for free plates:

- supports (soft foam pads, elastic cords or thin threads) on the nodal lines of the
  lowest mode, where they damp and stiffen least: a support of stiffness k shifts a
  mode's eigenvalue by k w^2, relatively most for the lowest modes (by 1/f^2).  Points
  on the lowest mode's nodal line (interpolated on the grid, a margin from the edges)
  are ranked by sum_i (f_1/f_i)^2 a_i^2 over the measured modes (a_i the normalised
  amplitude) and taken best first, spread at least ``SUPPORT_SPACING`` apart;
- the sensor where every measured mode moves: the point that maximises the smallest
  normalised amplitude over the measured modes, at least ``EDGE_MARGIN`` of each side
  from the edges (an accelerometer needs room, and a tap on an edge excites in-plane
  motion).  "Tapped at a node" and "a sensor on a nodal line" make a mode vanish;
- the excitation (tap) point chosen the same way, at least ``EXCITATION_SPACING`` of the
  shorter side from the sensor (not on it);
- the frequencies to expect with their spread over the prior range: the extremes over
  the prior samples when the design was scored over them (exact solves), else the
  log-linear prediction ln f = ln f0 + S ln(factor) over the same kind of sample with
  ``SPREAD_RANGE`` (S: the relative sensitivities);
- close pairs (within ``CLOSE_MODES_WARNING``, 1 %): their peaks overlap, so the lab
  needs a label column (the nodal pattern, ``fem.solver.mode_shapes``) and a way to tell them
  apart: a point where one of the two moves much more than the other (mass-normalised
  shapes, so the comparison is fair) - touching there damps that one;
- the sensor's own mass m shifts every mode, by about -m phi(x, y)^2 / 2 (relative, phi
  the mass-normalised displacement there; ``fem.solver.attachments``): for ``[design]
  sensor_mass_g`` the configuration is solved once more with the sensor as a point mass
  and the shift of every mode reported (exactly, since for a close pair the first-order
  formula fails: the sensor loads one combination of the two and leaves the other).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fem.io import html_pre
from fem.limits import CLOSE_MODES_WARNING
from fem.plotting import new_figure, save_figure
from fem.solver.assembly import UnitMatrices
from fem.solver.attachments import PointMass, point_operators
from fem.solver.mode_shapes import deflection_operator
from fem.solver.threads import one_blas_thread

from .problem import Problem, Solved
from .scores.prior import prior_factors

#: Points per side of the sampling grid (1 % spacing).
GRID = 101
#: Sensor, excitation and supports stay this fraction of each side from the edges.
EDGE_MARGIN = 0.05
#: Supports suggested, and their smallest spacing as a fraction of the shorter side.
SUPPORTS = 4
SUPPORT_SPACING = 0.3
#: The tap at least this fraction of the shorter side from the sensor.
EXCITATION_SPACING = 0.2
#: Points whose smallest amplitude is within this of the best are as good: among them
#: the one nearest the first configuration's point is taken (the same spot on every plate).
AMPLITUDE_TIE = 0.02
#: Prior half-range of the linearised frequency spread when the design has none.
SPREAD_RANGE = 0.3
SPREAD_SAMPLES = 64


def nodal_points(xs: np.ndarray, ys: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Where w (len(xs), len(ys)) changes sign along the grid lines, linearly
    interpolated: points (k, 2) [m] on its nodal lines."""
    out = []
    a, b = w[:-1, :], w[1:, :]  # along x
    i, j = np.nonzero(a * b < 0)
    t = a[i, j] / (a[i, j] - b[i, j])
    out.append(np.column_stack([xs[i] + t * (xs[i + 1] - xs[i]), ys[j]]))
    a, b = w[:, :-1], w[:, 1:]  # along y
    i, j = np.nonzero(a * b < 0)
    t = a[i, j] / (a[i, j] - b[i, j])
    out.append(np.column_stack([xs[i], ys[j] + t * (ys[j + 1] - ys[j])]))
    return np.vstack(out)


@dataclass(frozen=True)
class ClosePair:
    """Two modes within ``CLOSE_MODES_WARNING``: their numbers (1-based), frequencies,
    relative gap, labels, whether each is measured, and for each a point [m] where it
    moves more than the other, with the ratio of their squared (mass-normalised)
    amplitudes there (capped at ``RATIO_CAP`` in reports)."""

    modes: tuple[int, int]
    frequencies_hz: tuple[float, float]
    gap_rel: float
    labels: tuple[str, str]
    measured: tuple[bool, bool]
    touch_points: tuple[tuple[float, float], tuple[float, float]]
    ratios: tuple[float, float]

    def to_dict(self) -> dict:
        return {
            "modes": list(self.modes),
            "frequencies_hz": [round(f, 4) for f in self.frequencies_hz],
            "gap_rel": self.gap_rel,
            "labels": list(self.labels),
            "measured": list(self.measured),
            "tell_apart": [
                {
                    "touch_point_mm": _mm(p),
                    "damps_mode": m,
                    "damps_label": label,
                    "amplitude_ratio": _ratio(r),
                }
                for p, m, label, r in zip(self.touch_points, self.modes, self.labels, self.ratios)
            ],
        }

    def report(self) -> str:
        (i, j), (li, lj) = self.modes, self.labels
        (pi, pj), (ri, rj) = self.touch_points, self.ratios
        return (
            f"modes {i} {li} and {j} {lj} are {100 * self.gap_rel:.3g} % apart "
            f"({self.frequencies_hz[0]:.2f}, "
            f"{self.frequencies_hz[1]:.2f} Hz): one peak or two overlapping - give them a label column "
            f"({li}, {lj}); to tell them apart touch lightly at {_point(pi)}: mode {i} {li} damps (it moves "
            f"{_ratio_text(ri)} as much there), or at {_point(pj)}: mode {j} {lj} damps ({_ratio_text(rj)})"
        )


def _mm(point) -> list[float]:
    return [round(1e3 * float(v), 1) for v in point]


def _point(point) -> str:
    return f"({1e3 * point[0]:.1f}, {1e3 * point[1]:.1f}) mm"


#: Amplitude ratios of a close pair are capped here (one mode on a node of the other).
RATIO_CAP = 1000.0


def _ratio(r: float) -> float:
    return round(min(float(r), RATIO_CAP), 3)


def _ratio_text(r: float) -> str:
    return f"{r:.3g} x" if r < RATIO_CAP else f"over {RATIO_CAP:g} x"


@dataclass(frozen=True)
class ConfigurationSheet:
    """The test of one configuration.  Points [m] from the plate's corner (x along the
    length, y along the width); amplitudes relative to each mode's peak |w|."""

    configuration: str
    length: float
    width: float
    modes: tuple[int, ...]
    labels: tuple[str, ...]
    frequencies_hz: np.ndarray
    frequency_range_hz: np.ndarray
    spread: str
    support_points: np.ndarray
    support_distances: np.ndarray
    support_amplitudes: np.ndarray
    excitation_point: np.ndarray
    excitation_amplitudes: np.ndarray
    sensor_point: np.ndarray
    sensor_amplitudes: np.ndarray
    edge_margin: tuple[float, float]
    close_pairs: tuple[ClosePair, ...]
    lowest_mode: int
    sensor_mass: float | None = None
    sensor_shift_rel: np.ndarray | None = None
    # (xs, ys, w (x, y, modes) normalised) for plots
    grid: tuple = field(default=(), repr=False, compare=False)

    def to_dict(self) -> dict:
        return {
            "configuration": self.configuration,
            "modes": list(self.modes),
            "labels": list(self.labels),
            "frequencies_hz": [round(float(f), 4) for f in self.frequencies_hz],
            "frequency_range_hz": [
                [round(float(lo), 2), round(float(hi), 2)] for lo, hi in self.frequency_range_hz
            ],
            "frequency_spread": self.spread,
            "support_points_mm": [_mm(p) for p in self.support_points],
            "support_nodal_distance_mm": [round(1e3 * float(d), 2) for d in self.support_distances],
            "support_nodal_mode": self.lowest_mode,
            "excitation_point_mm": _mm(self.excitation_point),
            "excitation_amplitude_rel": [round(float(a), 3) for a in self.excitation_amplitudes],
            "sensor_point_mm": _mm(self.sensor_point),
            "sensor_amplitude_rel": [round(float(a), 3) for a in self.sensor_amplitudes],
            "edge_margin_mm": _mm(self.edge_margin),
            "close_pairs": [p.to_dict() for p in self.close_pairs],
            "sensor_mass_g": None if self.sensor_mass is None else self.sensor_mass * 1e3,
            "sensor_shift_rel": None
            if self.sensor_shift_rel is None
            else [float(s) for s in self.sensor_shift_rel],
        }

    def report(self) -> str:
        lines = [
            f"'{self.configuration}' ({1e3 * self.length:g} x {1e3 * self.width:g} mm; points from the "
            "corner at "
            f"the origin, x along the length)"
        ]
        lines.append(
            "  supports (foam pads or elastic cords; or hang by threads at two of them): "
            + ", ".join(_point(p) for p in self.support_points)
            + f" - on the nodal lines of mode {self.lowest_mode} (within "
            f"{max(1e3 * float(np.max(self.support_distances)), 0.01):.2g} mm)"
        )
        lines.append(
            f"  sensor at {_point(self.sensor_point)}, tap at {_point(self.excitation_point)} "
            f"(at least {100 * EDGE_MARGIN:g} % of each side from the edges)"
        )
        lines.append(
            f"  {'mode':>4s}  {'label':<12s}  {'expected [Hz]':>13s}  {'over the prior [Hz]':>19s}  "
            f"{'at sensor':>9s}  {'at tap':>6s}"
            + ("  sensor shift" if self.sensor_shift_rel is not None else "")
        )
        for k, (mode, label, f, (lo, hi)) in enumerate(
            zip(self.modes, self.labels, self.frequencies_hz, self.frequency_range_hz)
        ):
            shift = (
                f"  {100 * self.sensor_shift_rel[k]:+10.3g} %" if self.sensor_shift_rel is not None else ""
            )
            lines.append(
                f"  {mode:>4d}  {label:<12s}  {f:>13.1f}  {lo:>8.1f} .. {hi:<8.1f}  "
                f"{100 * self.sensor_amplitudes[k]:>7.0f} %  {100 * self.excitation_amplitudes[k]:>4.0f} %"
                + shift
            )
        lines.append(f"  (amplitudes relative to each mode's peak; spread: {self.spread})")
        if self.sensor_shift_rel is not None:
            lines.append(
                f"  a {1e3 * self.sensor_mass:g} g sensor at that point shifts the modes as listed (solved "
                "with "
                "it as a point mass): model it as a point_mass effect in the spec, or use a lighter sensor"
            )
        for pair in self.close_pairs:
            lines.append("  " + pair.report())
        return "\n".join(lines)

    def plot(self, path: str | Path) -> Path:
        """One panel per measured mode: the normalised deflection, its nodal lines, the
        supports (triangles), the sensor (circle) and the tap (cross)."""
        xs, ys, w = self.grid
        n = len(self.modes)
        cols = min(n, 3)
        rows = math.ceil(n / cols)
        aspect = self.width / self.length
        fig, axes = new_figure(rows, cols, figsize=(3.6 * cols, 3.6 * rows * aspect + 0.6), squeeze=False)
        X, Y = np.meshgrid(1e3 * xs, 1e3 * ys, indexing="ij")
        for k, ax in enumerate(axes.ravel()):
            if k >= n:
                ax.axis("off")
                continue
            ax.imshow(
                w[:, :, k].T,
                origin="lower",
                extent=(0, 1e3 * self.length, 0, 1e3 * self.width),
                cmap="RdBu_r",
                vmin=-1,
                vmax=1,
                interpolation="bilinear",
            )
            ax.contour(X, Y, w[:, :, k], levels=[0.0], colors="k", linewidths=1.2)
            ax.plot(
                *(1e3 * self.support_points.T),
                "^",
                color="k",
                markersize=8,
                markerfacecolor="yellow",
                label="support",
            )
            ax.plot(
                *(1e3 * self.sensor_point),
                "o",
                color="k",
                markersize=9,
                markerfacecolor="tab:green",
                label="sensor",
            )
            ax.plot(
                *(1e3 * self.excitation_point),
                "X",
                color="k",
                markersize=10,
                markerfacecolor="tab:red",
                label="tap",
            )
            ax.set_title(
                f"mode {self.modes[k]} {self.labels[k]}: {self.frequencies_hz[k]:.1f} Hz", fontsize=9
            )
            ax.set_aspect("equal")
            ax.tick_params(labelsize=7)
        fig.suptitle(
            f"test sheet '{self.configuration}' [mm]: nodal lines black, supports yellow triangles, "
            "sensor green circle, tap red cross",
            fontsize=9,
        )
        return save_figure(fig, path)


@dataclass(frozen=True)
class TestSheet:
    """The test sheet of every configuration of a design."""

    __test__ = False  # not a pytest class

    configurations: tuple[ConfigurationSheet, ...]

    def to_dict(self) -> list[dict]:
        return [c.to_dict() for c in self.configurations]

    def report(self) -> str:
        return "\n\n".join(["test sheet"] + [c.report() for c in self.configurations])

    def _repr_html_(self) -> str:
        return html_pre(self.report())

    def write(self, folder: str | Path) -> list[Path]:
        """One figure per configuration (``test_sheet_NAME.png``) in ``folder``."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        return [c.plot(folder / f"test_sheet_{c.configuration}.png") for c in self.configurations]


def _spread(
    problem: Problem, solved: Solved, modes: np.ndarray, prior: list[Solved] | None
) -> tuple[np.ndarray, str]:
    """(modes, 2) frequency range over the prior and how it was obtained."""
    f0 = solved.frequencies_hz[modes]
    if prior:
        f = np.array([s.frequencies_hz[modes] for s in prior] + [f0])
        r = problem.space.prior_range
        return np.column_stack([f.min(axis=0), f.max(axis=0)]), (
            f"extremes over the prior (+-{100 * r:g} %, {len(prior)} samples, exact solves)"
        )
    factors = prior_factors(len(problem.parameters), SPREAD_SAMPLES, SPREAD_RANGE)
    logs = np.log(factors) @ solved.sensitivities[modes].T  # (samples, modes)
    f = f0 * np.exp(logs)
    return np.column_stack([f.min(axis=0), f.max(axis=0)]), (
        f"linearised over +-{100 * SPREAD_RANGE:g} % of the identified properties ({SPREAD_SAMPLES} samples; "
        "set [design] prior_range_rel for exact solves over your range)"
    )


def _best(score: np.ndarray, points: np.ndarray, reference: np.ndarray | None) -> int:
    """The point of the highest score; among those within ``AMPLITUDE_TIE`` of it, the
    one nearest ``reference``."""
    best = int(np.argmax(score))
    if reference is None:
        return best
    near = np.flatnonzero(score >= score[best] - AMPLITUDE_TIE)
    return int(near[np.argmin(np.hypot(*(points[near] - reference).T))])


def configuration_sheet(
    problem: Problem, solved: Solved, prior: list[Solved] | None = None, reference: tuple | None = None
) -> ConfigurationSheet:
    """The test sheet of one configuration (``solved`` at the nominal values; ``prior``:
    the same configuration at each prior sample, for the frequency spread; ``reference``:
    the (sensor, tap) points [m] of another configuration to stay near when as good)."""
    solution = problem.solution(solved.configuration)
    units, shapes = solution.units, solution.modes.shapes
    L, W = problem.specimen.length, problem.specimen.width
    measured = np.flatnonzero(problem.measured(solved))
    bending = [i for i in range(shapes.shape[1]) if solution.labels[i] != "in-plane"]
    modes = np.array([i for i in measured if i in bending], dtype=int)
    xs, ys = np.linspace(0.0, L, GRID), np.linspace(0.0, W, GRID)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    op = deflection_operator(units, X.ravel(), Y.ravel())
    phi = op @ shapes  # (points, all solved modes), mass-normalised
    peak = np.abs(phi).max(axis=0)
    amplitude = np.abs(phi[:, modes]) / peak[modes]
    margin = (EDGE_MARGIN * L, EDGE_MARGIN * W)
    inside = (
        (X.ravel() >= margin[0] - 1e-12)
        & (X.ravel() <= L - margin[0] + 1e-12)
        & (Y.ravel() >= margin[1] - 1e-12)
        & (Y.ravel() <= W - margin[1] + 1e-12)
    )
    points = np.column_stack([X.ravel(), Y.ravel()])
    short = min(L, W)

    # sensor and tap: the largest smallest amplitude over the measured modes
    seen = np.where(inside, amplitude.min(axis=1), -1.0)
    sensor = _best(seen, points, None if reference is None else reference[0])
    away = np.hypot(*(points - points[sensor]).T) >= EXCITATION_SPACING * short
    tap = _best(np.where(away, seen, -1.0), points, None if reference is None else reference[1])

    # supports: on the lowest mode's nodal lines, where the measured modes move least
    lowest = bending[0]
    f = solution.frequencies_hz
    on_line = nodal_points(xs, ys, phi[:, lowest].reshape(GRID, GRID))
    keep = (
        (on_line[:, 0] >= margin[0])
        & (on_line[:, 0] <= L - margin[0])
        & (on_line[:, 1] >= margin[1])
        & (on_line[:, 1] <= W - margin[1])
    )
    on_line = on_line[keep] if keep.any() else on_line
    at_line = np.abs(deflection_operator(units, *on_line.T) @ shapes) / peak
    weights = (f[lowest] / f[modes]) ** 2
    score = (at_line[:, modes] ** 2) @ weights + at_line[:, lowest] ** 2
    chosen: list[int] = []
    for k in np.argsort(score, kind="stable"):
        if all(np.hypot(*(on_line[k] - on_line[c])) >= SUPPORT_SPACING * short for c in chosen):
            chosen.append(int(k))
            if len(chosen) == SUPPORTS:
                break
    supports = on_line[chosen]
    distances = np.array([_distance_to_node(units, shapes[:, lowest], p) for p in supports])

    # close pairs (within 1 %) among the solved modes, at least one of them measured
    pairs = []
    gaps = np.diff(f) / f[:-1]
    for i in np.flatnonzero(gaps < CLOSE_MODES_WARNING):
        j = i + 1
        if not (i in measured or j in measured):
            continue
        a2, b2 = phi[:, i] ** 2, phi[:, j] ** 2
        pi = int(np.argmax(np.where(inside, a2 - b2, -np.inf)))
        pj = int(np.argmax(np.where(inside, b2 - a2, -np.inf)))
        with np.errstate(divide="ignore"):
            ratios = (
                float(a2[pi] / b2[pi]) if b2[pi] > 0 else math.inf,
                float(b2[pj] / a2[pj]) if a2[pj] > 0 else math.inf,
            )
        pairs.append(
            ClosePair(
                (int(i) + 1, int(j) + 1),
                (float(f[i]), float(f[j])),
                float(gaps[i]),
                (solution.labels[i], solution.labels[j]),
                (bool(i in measured), bool(j in measured)),
                (tuple(points[pi]), tuple(points[pj])),
                ratios,
            )
        )

    shift = None
    mass = problem.space.sensor_mass
    if mass is not None:  # by rank: a close pair's two modes may change shape, not order
        loaded = problem.solution(solved.configuration, (PointMass(mass, *points[sensor], label="sensor"),))
        shift = loaded.frequencies_hz[modes] / f[modes] - 1

    frange, spread = _spread(problem, solved, modes, prior)
    signed = (phi[:, modes] / peak[modes]).reshape(GRID, GRID, len(modes))
    return ConfigurationSheet(
        solved.configuration.name,
        L,
        W,
        tuple(int(m) + 1 for m in modes),
        tuple(solution.labels[m] for m in modes),
        f[modes],
        frange,
        spread,
        supports,
        distances,
        at_line[chosen][:, modes],
        points[tap],
        amplitude[tap],
        points[sensor],
        amplitude[sensor],
        margin,
        tuple(pairs),
        lowest + 1,
        mass,
        shift,
        (xs, ys, signed),
    )


def _distance_to_node(units: UnitMatrices, shape: np.ndarray, point: np.ndarray) -> float:
    """Distance [m] from ``point`` to the nodal line of ``shape`` nearby: |w| / |grad w|."""
    dofs, rows = point_operators(units, *point)
    local = shape[dofs]
    w, wx, wy = (rows[k] @ local for k in ("w", "w_x", "w_y"))
    return float(abs(w) / max(math.hypot(wx, wy), 1e-300))


@one_blas_thread  # small systems: a second BLAS thread only slows them
def test_sheet(problem: Problem, solved: list[Solved], prior: list[list[Solved]] | None = None) -> TestSheet:
    """The test sheet of a design's configurations (``prior``: per prior sample, the
    same configurations solved there)."""
    sheets = []
    for k, s in enumerate(solved):
        reference = (sheets[0].sensor_point, sheets[0].excitation_point) if sheets else None
        sheets.append(configuration_sheet(problem, s, [p[k] for p in prior] if prior else None, reference))
    return TestSheet(tuple(sheets))


test_sheet.__test__ = False  # a pytest run that imports it must not collect it
