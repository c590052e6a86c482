"""Regression cases of the blind diagnosis study: the diagnosis's two known failures on 3-D
cases it was not tuned on, rebuilt with the blind generator (``tests/data/solid3d/blind.py``,
``REGRESSION``) on other stacks and masses, from handbook starts as a user gives them,
0.05 % scatter.

- A thick carbon/glass/carbon laminate carrying a sensor: the diagnosis selected
  ``thickness`` (layer thicknesses -85 % / +386 %, condition number 5e34) over the shear
  and the sensor, and the shear candidates ended worse than the baseline.
- A foam-core sandwich: ``layerwise`` was rejected because it freed the skins' G13/G23,
  which the data cannot see, and they ran to the bound.
"""

import os

import pytest

from studies import blind_diagnosis as study

NOISE = 5e-4
GPA = 1e9
#: The issue's woven-fabric handbook guess, for both ply materials of the laminate.
FABRIC_GUESS = {
    ("cfrp_ud", "E1"): 45 * GPA,
    ("cfrp_ud", "E2"): 45 * GPA,
    ("cfrp_ud", "G12"): 4.5 * GPA,
    ("cfrp_ud", "nu12"): 0.1,
    ("gfrp_ud", "E1"): 45 * GPA,
    ("gfrp_ud", "E2"): 45 * GPA,
    ("gfrp_ud", "G12"): 4.5 * GPA,
    ("gfrp_ud", "nu12"): 0.1,
}
#: A glass-fabric handbook guess for the skins, a data-sheet foam (35 MPa) for the core.
SANDWICH_GUESS = {
    ("gfrp_fabric", "E1"): 20 * GPA,
    ("gfrp_fabric", "E2"): 20 * GPA,
    ("gfrp_fabric", "G12"): 3.5 * GPA,
    ("gfrp_fabric", "nu12"): 0.15,
    ("foam_core", "G13"): 0.035 * GPA,
    ("foam_core", "G23"): 0.035 * GPA,
}

#: Each case is a whole diagnosis of a 3-D case (tens of minutes on a loaded 2-core
#: machine, the layerwise candidate most of it): run with LAYER_ID_LONG_TESTS=1.
needs_data = pytest.mark.skipif(
    not (study.REGRESSION / "regression_foam_sandwich.json").exists()
    or not os.environ.get("LAYER_ID_LONG_TESTS"),
    reason="long: set LAYER_ID_LONG_TESTS=1 (cases from python tests/data/solid3d/blind.py --regression)",
)


def _physics(selected) -> set:
    return set().union(*(study.PHYSICS.get(k, {k}) for k in selected)) if selected else set()


@needs_data
@pytest.mark.xfail(
    strict=True,
    reason="measured: from the fabric guess the baseline runs to its bounds (11.8 % RMS, "
    "carbon E1 and glass G12 at 0.5 MPa) and the global stage does not leave it; shear is pruned, "
    "the implausible point mass and thickness are no longer selected: nothing is",
)
def test_sensor_on_a_thick_hybrid():
    """Shear and the sensor are both selected (never the thickness), every selected
    estimate plausible, the refit within 1.5x the oracle floor."""
    o = study.run_case("regression_sensor_on_thick", starts=FABRIC_GUESS, noise=NOISE)
    assert not o.error, o.error
    assert {"shear", "point_mass"} <= _physics(o.selected), o.row()
    assert "thickness" not in o.selected
    assert o.within_floor, o.row()


@needs_data
def test_foam_sandwich():
    """The layerwise model (or a shear model that reaches the floor) is selected and the
    refit is within 1.5x the oracle floor."""
    o = study.run_case("regression_foam_sandwich", starts=SANDWICH_GUESS, noise=NOISE)
    assert not o.error, o.error
    assert "shear" in _physics(o.selected), o.row()
    assert o.within_floor, o.row()


@pytest.mark.skipif(not os.environ.get("LAYER_ID_LONG_TESTS"), reason="long: set LAYER_ID_LONG_TESTS=1")
def test_held_properties_are_freed_before_the_next_round():
    """blind07 (development half): the thin-plate fit holds the carbon's nu12 and the
    glass's E1 at their handbook values.  Freed only in the final refit, their error stayed
    in every round's misfit: layerwise stopped at 0.073 % (3.5 x the floor) and a spurious
    bond line was added.  Freed as layerwise is selected, the misfit is consistent with
    the scatter in round 1 (measured 0.0285 %, floor 0.0209 %)."""
    o = study.run_case("blind07_hybrid")
    assert not o.error, o.error
    assert o.selected in (("layerwise",), ("thick_plate",)), o.row()
    assert o.within_floor, o.row()


@pytest.mark.skipif(not os.environ.get("LAYER_ID_LONG_TESTS"), reason="long: set LAYER_ID_LONG_TESTS=1")
def test_an_effect_that_pays_at_the_noise_level_is_selected():
    """blind86 (third series, development half): a 5.38 g sensor on aluminium skins over
    a balsa-type core.  Layerwise ends at 0.102 %, 1.18 x the stated scatter, which the
    chi^2 test calls consistent; the selection used to stop there, with the skins' nu12
    5.7 std off.  The next round refits the point mass, which gains 14 / c (measured:
    6.1 g, 0.066 %, 0.96 x the floor, worst property 1.5 std)."""
    o = study.run_case("blind86_sensor")
    assert not o.error, o.error
    assert "point_mass" in o.selected and "shear" in _physics(o.selected), o.row()
    assert o.within_floor and o.max_z < 3, o.row()
