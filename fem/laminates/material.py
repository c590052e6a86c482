"""Orthotropic ply materials in plane stress (SI units inside: Pa, kg/m^3)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from ..errors import SpecError

#: The in-plane elastic constants an identification can update.
ELASTIC_CONSTANTS = ("E1", "E2", "G12", "nu12")
#: Transverse shear moduli; they matter only with the transverse-shear effect.
SHEAR_MODULI = ("G13", "G23")
#: Material parameters with exact sensitivities (elastic constants, density, shear moduli).
MATERIAL_PARAMETERS = ELASTIC_CONSTANTS + ("density",) + SHEAR_MODULI
#: Plausible ranges that catch unit slips and bound identifications [SI]: soft elastomer
#: (0.1 MPa) to above diamond (~1050 GPa); foams (10 kg/m^3) to above osmium (22 590).
MODULUS_RANGE = (1e5, 2e12)
DENSITY_RANGE = (10.0, 25000.0)
#: Default bounds of an identified property [SI]; nu12 within 0..0.5 unless the spec widens
#: it (fibre laminates at +-45 deg or some woods exceed 0.5: give `bounds` then).
#: Loss factors of a material's complex moduli E*(1 + i eta): one per in-plane modulus.
LOSS_FACTORS = ("eta_E1", "eta_E2", "eta_G12")
#: What an identification may find of a material's damping: the three loss factors, or
#: ``eta``, one loss factor shared by all three moduli (an isotropic material's).
DAMPING_PARAMETERS = ("eta",) + LOSS_FACTORS
#: Loss factors a spec may give: 0 (elastic) up to this.  Viscoelastic adhesives and
#: damping layers reach 1-1.5 at their glass transition; beyond 2 a "modal" resonance no
#: longer exists in a free-plate test.
MAX_LOSS_FACTOR = 2.0
DEFAULT_BOUNDS = {
    "E1": MODULUS_RANGE,
    "E2": MODULUS_RANGE,
    "G12": MODULUS_RANGE,
    "G13": MODULUS_RANGE,
    "G23": MODULUS_RANGE,
    "nu12": (0.0, 0.5),
    "density": DENSITY_RANGE,
}


@dataclass(frozen=True)
class Material:
    """An orthotropic layer material.

    E1, E2, G12 [Pa]: in-plane moduli along and across material axis 1.
    nu12 [-]: major Poisson ratio.  density [kg/m^3].
    G13, G23 [Pa]: transverse shear moduli (None = not given; used only by the
    transverse-shear effect, which then states its default).
    identify: the properties an identification finds (empty = a known material); True
    means the in-plane elastic constants ``ELASTIC_CONSTANTS``.  A soft core's in-plane
    constants hardly enter bending: identify its shear moduli instead, e.g.
    ("G13", "G23").
    """

    name: str
    E1: float
    E2: float
    G12: float
    nu12: float
    density: float
    G13: float | None = None
    G23: float | None = None
    identify: tuple[str, ...] = ()
    bounds: tuple[tuple[str, float, float], ...] = ()  # (kind, lower, upper) [SI] set in the spec
    # through-thickness modulus [Pa]: a stretching core's (layerwise model); None = E2
    E3: float | None = None
    # Loss factors of E1, E2 and G12 [-] (E*(1 + i eta)); None = not given (taken as 0, an
    # elastic material, and said so by a damping identification).  The transverse shear
    # moduli G13, G23 carry eta_G12.
    eta_E1: float | None = None
    eta_E2: float | None = None
    eta_G12: float | None = None
    identify_damping: tuple[str, ...] = ()  # of DAMPING_PARAMETERS; () = known loss factors

    def __post_init__(self):
        kinds = (
            ELASTIC_CONSTANTS
            if self.identify is True
            else ()
            if self.identify is False
            else tuple(self.identify)
        )
        unknown = [k for k in kinds if k not in MATERIAL_PARAMETERS]
        if unknown:
            raise SpecError(
                f"material '{self.name}': identify = {list(kinds)!r}: {unknown[0]!r} is not a material "
                f"property; use true, false or a list of {', '.join(MATERIAL_PARAMETERS)}"
            )
        object.__setattr__(self, "identify", kinds)
        for field in ("E1", "E2", "G12", "density"):
            value = getattr(self, field)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SpecError(
                    f"material '{self.name}': {field} = {value!r} must be a positive finite number"
                )
        for field in ("G13", "G23", "E3"):
            value = getattr(self, field)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise SpecError(f"material '{self.name}': {field} = {value!r} must be positive")
        for field in ("E1", "E2", "G12", "G13", "G23", "E3"):
            value = getattr(self, field)
            if value is not None and value < MODULUS_RANGE[0]:
                raise SpecError(
                    f"material '{self.name}': {field} = {value:g} Pa is below {MODULUS_RANGE[0]:g} Pa: a "
                    f"unit slip? Moduli are in Pa here (e.g. {value:g}e9 for {value:g} GPa); specs give GPa"
                )
        if self.density < DENSITY_RANGE[0]:
            raise SpecError(
                f"material '{self.name}': density = {self.density:g} kg/m^3 is below {DENSITY_RANGE[0]:g}: "
                "a unit slip? Densities are in kg/m^3 (7850 for steel, not 7.85)"
            )
        for field in LOSS_FACTORS:
            value = getattr(self, field)
            if value is not None and not (
                isinstance(value, (int, float)) and math.isfinite(value) and 0 <= value <= MAX_LOSS_FACTOR
            ):
                raise SpecError(
                    f"material '{self.name}': {field} = {value!r} must be a loss factor "
                    f"0..{MAX_LOSS_FACTOR:g} "
                    "(0.001 for steel, 0.01-0.1 for polymers, up to 1-1.5 for damping layers)"
                )
        unknown = [k for k in self.identify_damping if k not in DAMPING_PARAMETERS]
        if unknown or ("eta" in self.identify_damping and len(self.identify_damping) > 1):
            raise SpecError(
                f"material '{self.name}': identify_damping = {list(self.identify_damping)!r}: need true, "
                f'false or a list of {", ".join(LOSS_FACTORS)}, or ["eta"] alone (one loss factor for '
                "all three moduli)"
            )
        isotropic = self.E1 == self.E2 and abs(self.G12 * 2 * (1 + self.nu12) / self.E1 - 1) < 1e-6
        if isotropic and not -1 < self.nu12 < 0.5:
            raise SpecError(
                f"material '{self.name}': nu12 = {self.nu12!r} for an isotropic material "
                "(E1 = E2, G12 = E/2(1 + nu)): need -1 < nu < 0.5 (steel 0.3, rubber 0.499)"
            )
        limit = self.E1 / self.E2
        # nu12^2 < E1/E2, no overflow
        if not (math.isfinite(self.nu12) and abs(self.nu12) < math.sqrt(limit)):
            raise SpecError(
                f"material '{self.name}': nu12 = {self.nu12!r} makes the ply stiffness not positive "
                f"definite: need nu12^2 < E1/E2 = {limit:.4g} (|nu12| < {math.sqrt(limit):.4g})"
            )

    @property
    def nu21(self) -> float:
        """Minor Poisson ratio nu21 = nu12 E2 / E1."""
        return self.nu12 * self.E2 / self.E1

    @property
    def transverse_shear_moduli(self) -> tuple[float, float]:
        """(G13, G23) [Pa] as used by the transverse-shear effect.  A modulus not given
        defaults to G12: exact for an isotropic material and for G13 of a transversely
        isotropic (unidirectional) ply; for G23 of such a ply it is an upper estimate."""
        return (self.G12 if self.G13 is None else self.G13, self.G12 if self.G23 is None else self.G23)

    @property
    def defaulted_shear_moduli(self) -> tuple[str, ...]:
        """Names of the transverse shear moduli not given, hence set to G12."""
        return tuple(name for name in SHEAR_MODULI if getattr(self, name) is None)

    @property
    def isotropic(self) -> bool:
        """E1 = E2 and G12 = E1 / 2(1 + nu12) to 0.1 % (a spec's rounded G12, e.g. 37.31 GPa for
        brass's 100 GPa and 0.34)."""
        return self.E1 == self.E2 and abs(self.G12 * 2 * (1 + self.nu12) / self.E1 - 1) < 1e-3

    def loss_factor(self, kind: str) -> float:
        """The loss factor of E1, E2 or G12 (``eta_E1`` ...) [-]; 0 when not given."""
        return getattr(self, kind) or 0.0

    def bound(self, parameter: str) -> tuple[float, float]:
        """(lower, upper) [SI] an identification keeps the property within: the spec's
        ``bounds`` or ``DEFAULT_BOUNDS``."""
        for kind, low, high in self.bounds:
            if kind == parameter:
                return low, high
        return DEFAULT_BOUNDS.get(parameter, (-math.inf, math.inf))

    def value(self, parameter: str) -> float:
        """The value of a named material parameter (SI units; G13, G23 with their default)."""
        if parameter in SHEAR_MODULI:
            return self.transverse_shear_moduli[SHEAR_MODULI.index(parameter)]
        return getattr(self, parameter)

    def with_values(self, **values: float) -> Material:
        """A copy with some parameters replaced (validated again)."""
        return replace(self, **values)
