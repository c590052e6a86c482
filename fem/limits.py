"""The limits a lab works within: added mass and thickness, the frequency band of the
measurement chain and the separation two modes need to be told apart."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # annotations only: the design space's help needs no finite-element code
    from .specimen import Configuration

#: Modes closer than this (relative) are flagged: with the loss factors of bonded
#: plates (0.2-1 %, the adhesive adds damping) their resonance peaks overlap.
CLOSE_MODES_WARNING = 0.01
#: Default limits relative to the specimen, used where ``[design]`` gives none: an added
#: configuration may add at most 3 x the specimen's mass and 3 x its thickness (adhesive
#: included).  Why: the paper's design adds 1.3 x the mass and 0.95 x the thickness; 3 x
#: leaves room for denser or thicker stock, while beyond it the known plate carries most
#: of the bending stiffness and mass of the bonded plate, so its own property errors
#: (stock values are good to a few per cent) are read as errors of the specimen's layers,
#: the bond line carries a plate far heavier than the specimen (peel, creep, handling),
#: and a thick stack leaves the thin-plate (Kirchhoff) range the model assumes.
DEFAULT_MASS_RATIO = 3.0
DEFAULT_THICKNESS_RATIO = 3.0


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
    #: which of the two limits are the defaults relative to the specimen ("mass", "thickness")
    defaults: tuple[str, ...] = ()

    def with_defaults(self, specimen_mass: float, specimen_thickness: float) -> Limits:
        """The limits with the mass and thickness limits not given set to the defaults
        relative to the specimen (``DEFAULT_MASS_RATIO``, ``DEFAULT_THICKNESS_RATIO``)."""
        mass, thickness, defaults = self.max_added_mass, self.max_added_thickness, list(self.defaults)
        if mass is None:
            mass = DEFAULT_MASS_RATIO * specimen_mass
            defaults.append("mass")
        if thickness is None:
            thickness = DEFAULT_THICKNESS_RATIO * specimen_thickness
            defaults.append("thickness")
        return replace(self, max_added_mass=mass, max_added_thickness=thickness, defaults=tuple(defaults))

    def describe(self) -> str:
        """One line stating the mass and thickness limits and where they come from."""
        parts = []
        if self.max_added_mass is not None:
            parts.append(
                f"added mass <= {self.max_added_mass * 1e3:.4g} g"
                + (
                    f" (default: {DEFAULT_MASS_RATIO:g} x the specimen's mass; set [design] max_added_mass_g)"
                    if "mass" in self.defaults
                    else " ([design] max_added_mass_g)"
                )
            )
        if self.max_added_thickness is not None:
            parts.append(
                f"added thickness <= {self.max_added_thickness * 1e3:.4g} mm"
                + (
                    f" (default: {DEFAULT_THICKNESS_RATIO:g} x the specimen's thickness; set [design] "
                    "max_added_thickness_mm)"
                    if "thickness" in self.defaults
                    else " ([design] max_added_thickness_mm)"
                )
            )
        return "limits per configuration: " + ("; ".join(parts) if parts else "none")

    def to_dict(self) -> dict:
        return {
            "max_added_mass_g": None if self.max_added_mass is None else round(self.max_added_mass * 1e3, 6),
            "max_added_thickness_mm": (
                None if self.max_added_thickness is None else round(self.max_added_thickness * 1e3, 6)
            ),
            "defaults": list(self.defaults),
            "band_hz": list(self.band) if self.band else None,
            "min_separation_rel": self.min_separation,
        }

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
            out.append(
                f"adds {thickness * 1e3:.4g} mm > max_added_thickness_mm = {self.max_added_thickness * 1e3:g}"
            )
        return out
