"""Known inputs and their standard uncertainty, for the identification's uncertainty
budget (GUM-style): the moduli, Poisson ratios, densities and thicknesses of the known
layers, the plate's size and weighed mass are not exact, and their scatter carries into
the identified properties."""

from __future__ import annotations

from dataclasses import dataclass

#: Kinds of known inputs that are not model parameters (the plate's geometry, its mass).
GEOMETRY = ("length", "width")
MASS = "mass"
#: A layer's angle: frequencies are even in it where the laminate is symmetric about the
#: plate's axes, so its budget has a second-order part beside the first-order one.
ANGLE = "angle"
ANGLE_SECOND_ORDER = "angle, second order"


@dataclass(frozen=True)
class InputStd:
    """A known input's standard uncertainty [SI]: ``kind`` a material property (E1, E2,
    G12, nu12, density, G13, G23; ``target`` the material), ``thickness`` or ``angle``
    [rad] (``target`` a layer label), ``length`` / ``width`` of the plate, or ``mass`` of
    the weighed plate (its layers' densities scale with it)."""

    kind: str
    target: str
    std: float

    @property
    def name(self) -> str:
        return f"{self.target}.{self.kind}"


__all__ = ["InputStd", "GEOMETRY", "MASS", "ANGLE", "ANGLE_SECOND_ORDER"]
