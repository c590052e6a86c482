"""The unknowns of an identification and how the updating moves them.

Moduli, densities and thicknesses are positive: they are updated in log space, so a
step is a relative change (the paper's Delta P / P) and can never make them negative.
Poisson ratios and angles are updated linearly.  Material properties stay within their
bounds (``Material.bound``: the spec's ``bounds`` or physical defaults, nu12 in 0..0.5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.errors import SpecError
from fem.specimen import Parameter, Specimen

LOG_KINDS = frozenset({"E1", "E2", "G12", "G13", "G23", "density", "thickness", "mass", "stiffness"})
#: Display units per kind: (unit name, factor from SI).
UNITS = {
    "E1": ("GPa", 1e-9),
    "E2": ("GPa", 1e-9),
    "G12": ("GPa", 1e-9),
    "G13": ("GPa", 1e-9),
    "G23": ("GPa", 1e-9),
    "nu12": ("", 1.0),
    "density": ("kg/m^3", 1.0),
    "thickness": ("mm", 1e3),
    "angle": ("deg", 180 / np.pi),
    "mass": ("g", 1e3),
    "x": ("mm", 1e3),
    "y": ("mm", 1e3),
    "stiffness": ("N/m", 1.0),
}


def display(parameter: Parameter, value: float) -> float:
    """A parameter value in its display unit (GPa, mm, deg...)."""
    return value * UNITS[parameter.kind][1]


def json_key(parameter: Parameter) -> str:
    """The spec and JSON key of a parameter's kind, e.g. ``E1_GPa`` or ``nu12``."""
    unit = UNITS[parameter.kind][0].replace("/", "_").replace("^", "")
    return f"{parameter.kind}_{unit}" if unit else parameter.kind


@dataclass(frozen=True)
class ParameterSpace:
    """Parameters with their transform: z = log(p), or z = p / scale for the others
    (positions in plate lengths, so every z is dimensionless and steps compare), and
    their bounds [SI] (lower, upper; infinite where only admissibility limits them)."""

    parameters: tuple[Parameter, ...]
    scales: tuple[float, ...] = ()
    lower: tuple[float, ...] = ()
    upper: tuple[float, ...] = ()

    @classmethod
    def of(cls, parameters, specimen: Specimen) -> ParameterSpace:
        scale = {"x": specimen.length, "y": specimen.width}
        materials = specimen.materials
        bounds = [
            materials[p.target].bound(p.kind) if p.target in materials else (-np.inf, np.inf)
            for p in parameters
        ]
        return cls(
            tuple(parameters),
            tuple(scale.get(p.kind, 1.0) for p in parameters),
            tuple(b[0] for b in bounds),
            tuple(b[1] for b in bounds),
        )

    @property
    def is_log(self) -> np.ndarray:
        return np.array([p.kind in LOG_KINDS for p in self.parameters], dtype=bool)

    @property
    def _scale(self) -> np.ndarray:
        return np.array(self.scales) if self.scales else np.ones(len(self.parameters))

    def to_z(self, values: np.ndarray) -> np.ndarray:
        log = self.is_log
        return np.where(log, np.log(np.where(log, np.abs(values), 1.0)), values / self._scale)

    def to_values(self, z: np.ndarray) -> np.ndarray:
        return np.where(self.is_log, np.exp(z), z * self._scale)

    def dvalue_dz(self, values: np.ndarray) -> np.ndarray:
        return np.where(self.is_log, values, self._scale)

    def z_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds in z (log bounds of log parameters; a zero lower bound is -inf)."""
        low, high = np.array(self.lower, dtype=float), np.array(self.upper, dtype=float)
        with np.errstate(divide="ignore"):
            return (
                np.where(self.is_log, np.log(np.maximum(low, 0.0)), low / self._scale),
                np.where(self.is_log, np.log(np.maximum(high, 0.0)), high / self._scale),
            )

    def clip(self, values: np.ndarray) -> np.ndarray:
        """Values moved into their bounds."""
        return np.clip(values, self.lower, self.upper)

    def at_bound(self, values: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
        """Which values sit on a bound (within ``tolerance`` in z)."""
        z, (low, high) = self.to_z(values), self.z_bounds()
        return (z <= low + tolerance) | (z >= high - tolerance)

    def bound_of(self, index: int, values: np.ndarray) -> float:
        """The bound value ``values[index]`` sits on."""
        z, (low, _) = self.to_z(values), self.z_bounds()
        return self.lower[index] if z[index] <= low[index] + 1e-6 else self.upper[index]

    def apply(self, specimen: Specimen, values: np.ndarray) -> Specimen:
        """The specimen with these values; raises ``SpecError`` for an inadmissible material."""
        return specimen.with_values(dict(zip(self.parameters, values)))

    def admissible(self, specimen: Specimen, values: np.ndarray) -> bool:
        try:
            self.apply(specimen, values)
        except SpecError:
            return False
        return True
