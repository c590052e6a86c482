"""Structured rectangular meshes of a plate."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import ModelError

#: Edge grading: the elements at a free edge start at ``EDGE_SIZE_PER_THICKNESS`` x the
#: plate's thickness and grow by ``EDGE_GROWTH`` towards the interior until they reach
#: about the interior size.  Why: a shear-deformable (Reissner-Mindlin or layerwise)
#: plate has a boundary layer about one thickness wide along a free edge, where the
#: twisting moment falls to zero; equal elements much wider than the plate is thick
#: cannot follow it, and its twisting modes then converge slowly (a 4.5 mm hybrid plate:
#: 0.12 % high at the default 16 divisions against 32, and the 3-D solid model agrees
#: with the fine mesh).  tests/fem/test_mesh_grading.py has the convergence study.
EDGE_SIZE_PER_THICKNESS = 1.0
#: Growth factor of the edge elements, and the fraction of the interior element size they
#: stay below.  Growth 3 keeps the default mesh within 0.01 % (coated plate with shear
#: 0.005 %, 4.5 mm hybrid 0.007 %, against 40 divisions) with about 25 % less time than
#: doubling (0.004 % and 0.003 %).
EDGE_GROWTH = 3.0
EDGE_GROWTH_LIMIT = 0.6
#: At most this many graded elements at each edge: every element size is a set of element
#: matrices (the layerwise element has ~100 of up to ~160 x 160).  A third level made the
#: layerwise fit of a 1 mm plate on 6 divisions 1.5x slower (159 s against 104 s) and
#: changes the default meshes by nothing a test can see (the coated plate with shear:
#: 0.0021 % against 0.0025 % from converged).
EDGE_LEVELS = 2
#: Edge element sizes are this [m] times a power of two.
EDGE_QUANTUM = 1e-4
#: Elements across each side of a sensor's base (``PointMass.base``): on a shear-soft plate
#: the plate bends sharply at its edges.  A 6 g sensor on a 12 mm base on the foam sandwich
#: reference (FSDT, 8 modes, default divisions): 0.71 % off without, 0.046 % with 3 and
#: 0.018 % with 4 from a mesh of 8 per side and 40 divisions (layerwise: 0.049 % and
#: 0.024 %; 6 per side 0.007 % and 0.014 %).
FOOTPRINT_ELEMENTS = 4


def edge_size(thickness: float) -> float:
    """Edge element size [m] for a plate ``thickness`` [m] thick: ``EDGE_SIZE_PER_THICKNESS``
    x the thickness, rounded down to ``EDGE_QUANTUM`` x a power of two, so that nearby
    stacks (a derivative's step, a refit's thickness) share one mesh."""
    size = max(EDGE_SIZE_PER_THICKNESS * thickness, EDGE_QUANTUM)
    return EDGE_QUANTUM * 2.0 ** math.floor(math.log2(size / EDGE_QUANTUM))


def _spacing(length: float, divisions: int, edge_size: float | None) -> np.ndarray:
    """Node positions [m] along one side: ``divisions`` equal elements, or with
    ``edge_size`` [m] graded elements at both ends (sizes edge_size, 3 edge_size, at most
    ``EDGE_LEVELS`` of them, below ``EDGE_GROWTH_LIMIT`` of the interior size) and equal
    ones between, about as wide as ``length / divisions``."""
    interior = length / divisions
    edge = []
    size = edge_size
    while size is not None and size < EDGE_GROWTH_LIMIT * interior and len(edge) < EDGE_LEVELS:
        edge.append(size)
        size *= EDGE_GROWTH
    if not edge:
        return np.linspace(0.0, length, divisions + 1)
    middle = length - 2 * sum(edge)
    n_middle = max(1, round(middle / interior))
    sizes = np.concatenate([edge, np.full(n_middle, middle / n_middle), edge[::-1]])
    nodes = np.concatenate([[0.0], np.cumsum(sizes)])
    nodes[-1] = length
    return nodes


def with_footprints(nodes: np.ndarray, spans, per_side: int) -> np.ndarray:
    """Node positions ``nodes`` [m] along one side with each span (lo, hi) [m] (a sensor's
    base) divided into ``per_side`` equal elements: those lines added, the nodes closer to
    them than half such an element dropped (the sides' ends kept)."""
    for lo, hi in spans:
        inner = np.linspace(lo, hi, per_side + 1)
        far = np.abs(nodes[:, None] - inner[None, :]).min(axis=1) > 0.5 * (hi - lo) / per_side
        ends = (nodes == nodes[0]) | (nodes == nodes[-1])
        nodes = np.unique(np.concatenate([nodes[far | ends], inner]))
    return nodes


@dataclass(frozen=True)
class PlateMesh:
    """nx x ny rectangles over [0, length] x [0, width] (metres): equal ones, or graded
    towards the edges when ``x_nodes`` and ``y_nodes`` (the node positions along each
    side, from 0 to length / width) are given.

    Nodes are numbered row by row (x fastest).
    """

    length: float
    width: float
    nx: int
    ny: int
    x_nodes: tuple[float, ...] | None = None
    y_nodes: tuple[float, ...] | None = None

    def __post_init__(self):
        if self.nx < 1 or self.ny < 1:
            raise ModelError(f"mesh: nx = {self.nx}, ny = {self.ny}; need at least one element each way")
        for name, nodes, n, side in (
            ("x_nodes", self.x_nodes, self.nx, self.length),
            ("y_nodes", self.y_nodes, self.ny, self.width),
        ):
            if nodes is not None and (
                len(nodes) != n + 1 or nodes[0] != 0.0 or nodes[-1] != side or np.any(np.diff(nodes) <= 0)
            ):
                raise ModelError(f"mesh: {name} must rise from 0 to {side:g} m in {n + 1} positions")

    @classmethod
    def with_element_size(
        cls, length: float, width: float, divisions: int, edge_size: float | None = None, bases=()
    ) -> PlateMesh:
        """``divisions`` elements along the longer side, a matching count along the other;
        with ``edge_size`` [m], graded towards the four edges (``_spacing``); each of
        ``bases`` ((x0, x1, y0, y1) [m], a sensor's footprint) divided into
        ``FOOTPRINT_ELEMENTS`` x ``FOOTPRINT_ELEMENTS`` elements (``with_footprints``)."""
        long_side = max(length, width)
        n_long = divisions
        n_short = max(4, int(round(divisions * min(length, width) / long_side)))
        nx, ny = (n_long, n_short) if length >= width else (n_short, n_long)
        x, y = _spacing(length, nx, edge_size), _spacing(width, ny, edge_size)
        if bases and FOOTPRINT_ELEMENTS:
            x = with_footprints(x, [(b[0], b[1]) for b in bases], FOOTPRINT_ELEMENTS)
            y = with_footprints(y, [(b[2], b[3]) for b in bases], FOOTPRINT_ELEMENTS)
        if (
            len(x) == nx + 1
            and len(y) == ny + 1
            and np.allclose(np.diff(x), x[1])
            and np.allclose(np.diff(y), y[1])
        ):
            return cls(length, width, nx, ny)
        return cls(length, width, len(x) - 1, len(y) - 1, tuple(map(float, x)), tuple(map(float, y)))

    @property
    def n_nodes(self) -> int:
        return (self.nx + 1) * (self.ny + 1)

    @cached_property
    def x(self) -> np.ndarray:
        """Node positions along x [m]."""
        return np.linspace(0.0, self.length, self.nx + 1) if self.x_nodes is None else np.array(self.x_nodes)

    @cached_property
    def y(self) -> np.ndarray:
        """Node positions along y [m]."""
        return np.linspace(0.0, self.width, self.ny + 1) if self.y_nodes is None else np.array(self.y_nodes)

    @cached_property
    def node_xy(self) -> np.ndarray:
        """Node coordinates (n_nodes, 2) [m]."""
        xx, yy = np.meshgrid(self.x, self.y)
        return np.column_stack([xx.ravel(), yy.ravel()])

    @cached_property
    def element_nodes(self) -> np.ndarray:
        """Corner nodes per element (n_elements, 4), counter-clockwise from (0, 0)."""
        ex, ey = np.meshgrid(np.arange(self.nx), np.arange(self.ny))
        first = (ey * (self.nx + 1) + ex).ravel()
        return np.column_stack([first, first + 1, first + self.nx + 2, first + self.nx + 1])

    @cached_property
    def size_groups(self) -> tuple[np.ndarray, np.ndarray]:
        """The distinct element sizes (G, 2) (hx, hy) [m] and each element's group
        (n_elements,), elements row by row: one set of element matrices per group (G = 1
        on an equal mesh)."""
        hx, hy = np.meshgrid(np.diff(self.x), np.diff(self.y))
        sizes = np.column_stack([hx.ravel(), hy.ravel()])
        distinct, group = np.unique(np.round(sizes, 12), axis=0, return_inverse=True)
        return distinct, group.ravel()

    def cells(self, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """For points (x, y) [m]: the element column and row holding each, the local
        coordinates (s, t) in [0, 1] there and the element's sizes (hx, hy) [m]."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        ex = np.clip(np.searchsorted(self.x, x, side="right") - 1, 0, self.nx - 1)
        ey = np.clip(np.searchsorted(self.y, y, side="right") - 1, 0, self.ny - 1)
        hx, hy = np.diff(self.x)[ex], np.diff(self.y)[ey]
        return ex, ey, (x - self.x[ex]) / hx, (y - self.y[ey]) / hy, hx, hy
