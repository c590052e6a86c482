"""The limits a lab works within: added mass and thickness, the frequency band of the
measurement chain and the separation two modes need to be told apart."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .specimen import Configuration

#: Modes closer than this (relative) are flagged: with the loss factors of bonded
#: plates (0.2-1 %, the adhesive adds damping) their resonance peaks overlap.
CLOSE_MODES_WARNING = 0.01


def added_layers(configuration: Configuration):
    return configuration.bottom + configuration.top


def added_mass(configuration: Configuration, area: float) -> float:
    """Mass [kg] of the layers a configuration adds to a plate of ``area`` [m^2]."""
    return area * sum(layer.material.density * layer.thickness for layer in added_layers(configuration))


def added_thickness(configuration: Configuration) -> float:
    """Total thickness [m] a configuration adds (adhesive and plates, both faces)."""
    return sum(layer.thickness for layer in added_layers(configuration))


def relative_gaps(frequencies: np.ndarray) -> np.ndarray:
    """Per mode, the relative distance |f_j - f_i| / f_i to its nearest other mode."""
    f = np.asarray(frequencies, dtype=float)
    if f.size < 2:
        return np.full(f.size, np.inf)
    gaps = np.abs(f[:, None] - f[None, :]) / f[:, None]
    np.fill_diagonal(gaps, np.inf)
    return gaps.min(axis=1)


@dataclass(frozen=True)
class Limits:
    """max_added_mass [kg] and max_added_thickness [m] per configuration (None = no limit);
    band (low, high) [Hz] the measurement chain covers (None = any); min_separation:
    the smallest relative gap at which two modes are still told apart (0 = always)."""

    max_added_mass: float | None = None
    max_added_thickness: float | None = None
    band: tuple[float, float] | None = None
    min_separation: float = 0.0

    def extra_modes(self) -> int:
        """Modes to solve beyond the measured ones: one, to see whether the last
        measured mode has a close neighbour just above it."""
        return 1 if self.min_separation > 0 else 0

    def measured(self, frequencies: np.ndarray, modes: int) -> np.ndarray:
        """Which of the first ``modes`` modes are measured: inside the band and at least
        ``min_separation`` from every other mode (a close pair shows one peak: both go)."""
        f = np.asarray(frequencies, dtype=float)
        keep = relative_gaps(f) >= self.min_separation
        if self.band is not None:
            keep &= (f >= self.band[0]) & (f <= self.band[1])
        return keep[:modes]

    def violations(self, configuration: Configuration, area: float) -> list[str]:
        """Why a configuration breaks the mass or thickness limit (empty when it does not)."""
        out = []
        mass = added_mass(configuration, area)
        if self.max_added_mass is not None and mass > self.max_added_mass:
            out.append(f"adds {mass * 1e3:.4g} g > max_added_mass_g = {self.max_added_mass * 1e3:g}")
        thickness = added_thickness(configuration)
        if self.max_added_thickness is not None and thickness > self.max_added_thickness * (1 + 1e-12):
            out.append(f"adds {thickness * 1e3:.4g} mm > max_added_thickness_mm = {self.max_added_thickness * 1e3:g}")
        return out
