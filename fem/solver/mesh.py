"""Structured rectangular meshes of a plate."""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import ModelError


@dataclass(frozen=True)
class PlateMesh:
    """nx x ny equal rectangles over [0, length] x [0, width] (metres).

    Nodes are numbered row by row (x fastest).
    """

    length: float
    width: float
    nx: int
    ny: int

    def __post_init__(self):
        if self.nx < 1 or self.ny < 1:
            raise ModelError(f"mesh: nx = {self.nx}, ny = {self.ny}; need at least one element each way")

    @classmethod
    def with_element_size(cls, length: float, width: float, divisions: int) -> "PlateMesh":
        """``divisions`` elements along the longer side, a matching count along the other."""
        long_side = max(length, width)
        n_long = divisions
        n_short = max(4, int(round(divisions * min(length, width) / long_side)))
        nx, ny = (n_long, n_short) if length >= width else (n_short, n_long)
        return cls(length, width, nx, ny)

    @property
    def n_nodes(self) -> int:
        return (self.nx + 1) * (self.ny + 1)

    @property
    def element_size(self) -> tuple[float, float]:
        return self.length / self.nx, self.width / self.ny

    @cached_property
    def node_xy(self) -> np.ndarray:
        """Node coordinates (n_nodes, 2) [m]."""
        x = np.linspace(0.0, self.length, self.nx + 1)
        y = np.linspace(0.0, self.width, self.ny + 1)
        xx, yy = np.meshgrid(x, y)
        return np.column_stack([xx.ravel(), yy.ravel()])

    @cached_property
    def element_nodes(self) -> np.ndarray:
        """Corner nodes per element (n_elements, 4), counter-clockwise from (0, 0)."""
        ex, ey = np.meshgrid(np.arange(self.nx), np.arange(self.ny))
        first = (ey * (self.nx + 1) + ex).ravel()
        return np.column_stack([first, first + 1, first + self.nx + 2, first + self.nx + 1])

    def locate(self, x: float, y: float) -> tuple[int, float, float]:
        """Element containing (x, y) [m] and the local coordinates (s, t) in [0, 1]."""
        hx, hy = self.element_size
        ex = min(int(x / hx), self.nx - 1)
        ey = min(int(y / hy), self.ny - 1)
        return ey * self.nx + ex, x / hx - ex, y / hy - ey
