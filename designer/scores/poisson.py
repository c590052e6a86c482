"""The Poisson-plate rule (paper eq. 16): the length/width ratio at which the first
bending modes along x and y coincide, so they mix into the anticlastic and synclastic
modes that make the frequencies sensitive to the Poisson ratio.

For one orthotropic layer the rule is length/width = (E1/E2)^(1/4); for a laminate the
bending stiffnesses take the moduli's place: (D11/D22)^(1/4), the same for one layer
since D11/D22 = E1/E2 there.
"""

from __future__ import annotations

from dataclasses import dataclass

from fem.laminates.laminate import Laminate
from fem.specimen import Specimen

#: Ratios within this of the rule are reported as a Poisson plate already.
TOLERANCE = 0.01


@dataclass(frozen=True)
class PoissonPlate:
    """length, width [m] of the specimen and the ratio eq. 16 suggests (nominal D11/D22)."""

    length: float
    width: float
    suggested_ratio: float

    @property
    def ratio(self) -> float:
        return self.length / self.width

    @property
    def suggested_width(self) -> float:
        """The width [m] that makes the present length a Poisson plate."""
        return self.length / self.suggested_ratio

    @property
    def cut_to(self) -> tuple[float, float]:
        """(length, width) [m] of the Poisson plate cut from this one: the width trimmed,
        or, where that would need a wider plate than there is, the length."""
        if self.suggested_width <= self.width:
            return self.length, self.suggested_width
        return self.width * self.suggested_ratio, self.width

    @property
    def complies(self) -> bool:
        return abs(self.ratio / self.suggested_ratio - 1) <= TOLERANCE

    def to_dict(self) -> dict:
        length, width = self.cut_to
        return {
            "length_width_ratio": self.ratio,
            "suggested_ratio": self.suggested_ratio,
            "suggested_width_mm": self.suggested_width * 1e3,
            "cut_to_mm": [length * 1e3, width * 1e3],
            "complies": self.complies,
        }

    def report(self) -> str:
        head = (
            f"Poisson-plate rule (paper eq. 16): length/width = (D11/D22)^(1/4) = {self.suggested_ratio:.4f} "
            f"at the nominal properties; this plate: {self.ratio:.4f}"
        )
        if self.complies:
            return head + f" (within {100 * TOLERANCE:g} %: a Poisson plate)"
        length, width = self.cut_to
        return head + f"; cut it to {length * 1e3:.1f} x {width * 1e3:.1f} mm for modes sensitive to nu12"


def poisson_plate(specimen: Specimen) -> PoissonPlate:
    """Eq. 16 for the original plate at its nominal properties."""
    D = Laminate(specimen.layers).matrices()["D"]
    return PoissonPlate(specimen.length, specimen.width, (D[0, 0] / D[1, 1]) ** 0.25)
