"""A small built-in library of common plate stock to bond to a specimen.

Nominal room-temperature properties of isotropic sheet metals (G = E / 2(1 + nu)),
each with its source.  Alloy and temper change them by a few per cent; a lab that
knows its plates better defines them in the spec's ``[materials]`` instead, and a
spec material always takes precedence over a stock one of the same name.

The values are cross-checked in the tests against an independent table: the
extensional (thin-rod) and shear wave speeds sqrt(E/rho), sqrt(G/rho) of the CRC
Handbook of Chemistry and Physics, "Speed of sound in various media", Table 1.
"""

from __future__ import annotations

from dataclasses import dataclass

from .laminates.material import Material

GPA = 1e9


@dataclass(frozen=True)
class StockMaterial:
    """An isotropic stock material: E [Pa], nu [-], density [kg/m^3] and its source."""

    name: str
    E: float
    nu: float
    density: float
    source: str

    def material(self, name: str | None = None) -> Material:
        """The known (not identified) layer material, optionally renamed."""
        G = self.E / (2 * (1 + self.nu))
        return Material(name or self.name, self.E, self.E, G, self.nu, self.density)


STOCK = {
    s.name: s
    for s in (
        StockMaterial(
            "brass",
            110 * GPA,
            0.34,
            8530,
            "cartridge brass C26000 (CuZn30): E and density from the Copper Development "
            "Association alloy data (16 000 ksi, 0.308 lb/in^3); nu typical of alpha brass",
        ),
        StockMaterial(
            "aluminium",
            68.9 * GPA,
            0.33,
            2700,
            "aluminium 6061-T6: Aluminum Association, Aluminum Standards and Data "
            "(E 10.0 Msi, density 0.098 lb/in^3); ASM Handbook Vol. 2",
        ),
        StockMaterial(
            "steel",
            210 * GPA,
            0.30,
            7850,
            "structural (mild) steel: EN 1993-1-1 (Eurocode 3) section 3.2.6 "
            "(E 210 GPa, nu 0.3); density from EN 1991-1-1 Annex A",
        ),
        StockMaterial(
            "stainless_steel",
            193 * GPA,
            0.29,
            8000,
            "stainless steel AISI 304 (1.4301), annealed sheet: ASM Handbook Vol. 1",
        ),
        StockMaterial(
            "copper",
            117 * GPA,
            0.34,
            8890,
            "copper C11000 (ETP): Copper Development Association alloy data "
            "(17 000 ksi, 0.321 lb/in^3); nu from Kaye & Laby",
        ),
        StockMaterial(
            "titanium",
            113.8 * GPA,
            0.342,
            4430,
            "titanium Ti-6Al-4V (grade 5), annealed: ASM Materials Properties "
            "Handbook: Titanium Alloys (1994)",
        ),
        StockMaterial(
            "epoxy",
            3.0 * GPA,
            0.35,
            1200,
            "a generic cured structural epoxy adhesive (products range 2-4 GPa): "
            "use the data sheet of your adhesive when it matters",
        ),
    )
}
#: Suffix that names the stock material when the spec uses the plain name for
#: another material (e.g. "steel_stock" when the specimen's own "steel" is identified).
STOCK_SUFFIX = "_stock"
#: Common metric sheet thicknesses [mm] that metal stockists carry in all of these metals.
STOCK_THICKNESSES_MM = (0.5, 0.8, 1.0, 1.5, 2.0, 3.0)
#: The stock adhesive bond used when a spec gives none: epoxy, 50 um (the paper's bond line).
DEFAULT_ADHESIVE = ("epoxy", 0.05)


def stock_name(name: str) -> str | None:
    """The library entry a name refers to ("steel" or "steel_stock" -> "steel"), or None."""
    if name in STOCK:
        return name
    if name.endswith(STOCK_SUFFIX) and name[: -len(STOCK_SUFFIX)] in STOCK:
        return name[: -len(STOCK_SUFFIX)]
    return None
