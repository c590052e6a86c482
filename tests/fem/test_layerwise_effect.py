"""The layerwise effect switched on: a stretching layer's through-thickness modulus is held
at the E2 it starts from (``Layerwise.held_normal_moduli``), so that fitting E2 moves the
layer in plane only."""

import tomllib

import numpy as np
import pytest

from fem.effects import effect
from fem.laminates.layerwise import LayerwiseLaminate
from fem.spec import parse_spec
from fem.specimen import Parameter

#: A 1 mm polymer coating on 2.7 mm aluminium, the coating identified (blind99's stack,
#: smaller and with 6 modes so that the test is quick).
COATED = """
[specimen]
name = "coated aluminium"
length_mm = 120
width_mm = 80
layers = [
  { material = "coating", thickness_mm = 1.0, angle_deg = 0 },
  { material = "aluminium", thickness_mm = 2.7, angle_deg = 0 },
]

[materials.coating]
E1_GPa = 0.85
E2_GPa = 0.85
G12_GPa = 0.30
nu12 = 0.42
density_kg_m3 = 1370
identify = true

[materials.aluminium]
E1_GPa = 70
E2_GPa = 70
G12_GPa = 26.3
nu12 = 0.33
density_kg_m3 = 2700
identify = false

[[configurations]]
name = "original"

[model]
modes = 6
"""

COATING_E2 = Parameter("E2", "coating")


@pytest.fixture(scope="module")
def coated():
    return parse_spec(tomllib.loads(COATED), "coated")


def test_the_coating_stretches_and_its_e3_is_held_at_its_e2(coated):
    """The soft coating carries nearly all the stack's through-thickness compliance, so it
    stretches; switched on, its E3 is its E2 (0.85 GPa), said in the note, and the other
    material (not identified) is left as it is."""
    stack = LayerwiseLaminate.of(coated.specimen.laminate("original"))
    assert stack.stretch == (0,)
    switched = effect("layerwise").free(coated)[0]
    materials = switched.model.specimen.materials
    assert materials["coating"].E3 == 0.85e9
    assert materials["aluminium"].E3 is None
    assert "coating E3 = 0.85 GPa" in switched.note


def test_fitting_e2_moves_the_coating_in_plane_only(coated):
    """With E3 held, d f / d E2 of the switched model matches central differences in E2
    (E3 unmoved) to 1e-6 of the largest (steps of 1e-4 relative: truncation ~1e-8, solver
    round-off ~1e-12 / 1e-4; measured 3e-7).  And E2 at 1/250 of its value (blind99's
    3.5 MPa) lowers the lowest three modes by the in-plane change alone, 0.03-0.07 %;
    with E3 following E2 the coating also softens through its thickness and they fall
    1.9-3.2 x as far (0.06-0.22 %): the lever the tie gave a fit."""
    held = effect("layerwise").free(coated)[0].model
    analytic = held.solve("original").derivatives([COATING_E2])[:, 0]
    e2, step = held.value(COATING_E2), 1e-4
    f = [
        held.with_values({COATING_E2: e2 * (1 + s * step)}).solve("original").frequencies_hz for s in (1, -1)
    ]
    central = (f[0] - f[1]) / (2 * step * e2)
    assert np.allclose(analytic, central, rtol=0, atol=1e-6 * np.abs(central).max())
    tied = coated.with_options(theory="layerwise")
    assert tied.specimen.materials["coating"].E3 is None
    f0 = held.solve("original").frequencies_hz[:3]
    drop_held, drop_tied = (
        1 - model.with_values({COATING_E2: e2 / 250}).solve("original").frequencies_hz[:3] / f0
        for model in (held, tied)
    )
    assert np.all(drop_tied > 1.5 * drop_held), (drop_held, drop_tied)
