"""Where a refit of transverse shear moduli that only default to G12 starts, and where
it holds those that run out (``fitting.driver``): the starts with G23 != G13 and the
unidirectional ply's relation only for unidirectional plies (a fabric, a foam or a metal
has G23 = G13), and a hold at the spec's values or the ply class's relation, never at a
screened start."""

from types import SimpleNamespace

import pytest

from fem.laminates.material import Material
from fem.specimen import Parameter
from identify.fitting.driver import (
    SHEAR_STARTS,
    TRANSVERSELY_ISOTROPIC,
    UD_NU23,
    _class_shear,
    _shear_starts,
    _shear_values,
)

CARBON = Material("carbon_ud", 140e9, 9e9, 5e9, 0.3, 1600.0)  # E1 / E2 = 15.6: a unidirectional ply
FABRIC = Material("carbon_fabric", 60e9, 58e9, 4.5e9, 0.05, 1500.0)  # a balanced weave
STEEL = Material("steel", 210e9, 210e9, 80.8e9, 0.3, 7850.0)
SPECIMEN = SimpleNamespace(materials={m.name: m for m in (CARBON, FABRIC, STEEL)})


def _moduli(*materials):
    return [Parameter(kind, m.name) for m in materials for kind in ("G13", "G23")]


def test_fabrics_and_metals_start_with_g23_equal_to_g13():
    assert _shear_starts(SPECIMEN, _moduli(FABRIC, STEEL)) == [(1.0, 1.0), (0.25, 0.25)]
    assert _shear_starts(SPECIMEN, _moduli(CARBON, FABRIC)) == list(SHEAR_STARTS)
    # wood's rolling-shear start, screened for the carbon, leaves the fabric at G23 = G13
    values = _shear_values(SPECIMEN, _moduli(CARBON, FABRIC), (1.0, 1 / 16))
    assert values[Parameter("G23", "carbon_ud")] == pytest.approx(CARBON.G12 / 16, rel=1e-12)
    assert (
        values[Parameter("G23", "carbon_fabric")] == values[Parameter("G13", "carbon_fabric")] == FABRIC.G12
    )
    ply_class = _shear_values(SPECIMEN, _moduli(CARBON, FABRIC), TRANSVERSELY_ISOTROPIC)
    assert ply_class[Parameter("G13", "carbon_ud")] == CARBON.G12
    assert ply_class[Parameter("G23", "carbon_ud")] == pytest.approx(
        CARBON.E2 / (2 * (1 + UD_NU23)), rel=1e-12
    )
    assert ply_class[Parameter("G23", "carbon_fabric")] == FABRIC.G12


@pytest.mark.parametrize(
    "material, given, expected",
    [
        (
            CARBON,
            CARBON,
            (None, CARBON.E2 / (2 * (1 + UD_NU23))),
        ),  # given none: G13 follows G12, G23 the relation
        (FABRIC, FABRIC, (None, None)),  # G13 = G23 = G12
        (
            CARBON,
            Material("carbon_ud", 140e9, 9e9, 5e9, 0.3, 1600.0, G13=4e9, G23=3e9),
            (4e9, 3e9),
        ),  # the spec's
    ],
)
def test_a_held_pair_goes_to_the_spec_or_the_ply_class_not_to_the_start(material, given, expected):
    started = Material(
        material.name,
        material.E1,
        material.E2,
        material.G12,
        material.nu12,
        material.density,
        G13=0.25 * material.G12,
        G23=0.25 * material.G12,
    )  # a screened start that ran out
    held = _class_shear(started, given)
    assert held.G13 == expected[0]
    assert held.G23 == (pytest.approx(expected[1], rel=1e-12) if expected[1] is not None else None)
