"""The effect registry: spec tables, free switching, a user-registered kind, bad input."""

import copy
import tomllib

import numpy as np
import pytest

from fem.effects import REGISTRY, Effect, SwitchedOn, effect, register
from fem.errors import SpecError
from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.examples import COATED_PLATE

BASE = tomllib.loads(COATED_PLATE.read_text())


def with_effects(*tables):
    data = copy.deepcopy(BASE)
    data["effects"] = list(tables)
    return data


def test_spec_point_mass_is_applied(example_spec):
    """A loaded model has its fixed effects on: nobody applies them by hand."""
    model = parse_spec(with_effects({"kind": "point_mass", "mass_g": 3.0, "x_mm": 125.0, "y_mm": 110.0}))
    (mass,) = model.specimen.attachments
    assert (mass.mass, mass.x, mass.y) == pytest.approx((3e-3, 0.125, 0.110))
    assert model.effects == ("point_mass",)
    loaded = model.solve("original").frequencies_hz
    free = example_spec.solve("original").frequencies_hz
    assert np.all(loaded < free)
    assert mass.base == 0.0  # a point unless the spec gives the sensor's base
    spread = parse_spec(
        with_effects({"kind": "point_mass", "mass_g": 3.0, "x_mm": 125.0, "y_mm": 110.0, "base_mm": 12.0})
    )
    assert spread.specimen.attachments[0].base == pytest.approx(0.012)


def test_spec_plate_theory_effects_switch_options(example_spec):
    model = parse_spec(with_effects({"kind": "transverse_shear"}, {"kind": "rotary_inertia"}))
    assert model.options.transverse_shear and model.options.rotary_inertia
    assert any("G13 = G23 = G12 assumed" in n for n in model.notes)


@pytest.mark.parametrize(
    "table,message",
    [
        ({"kind": "sensor"}, "unknown effect kind 'sensor'; known: transverse_shear"),
        ({"kind": "point_mass", "mass_g": 3.0, "x_mm": 180.0, "y_mm": 10.0}, "outside the plate"),
        ({"kind": "point_mass", "mass_g": -3.0, "x_mm": 10.0, "y_mm": 10.0}, "must not be negative"),
        ({"kind": "suspension", "stiffness_N_m": -50.0}, "must not be negative"),
        ({"kind": "point_mass", "mass_g": 3.0, "x_mm": 10.0}, "missing field 'y_mm'"),
        ({"kind": "point_mass", "mass": 3.0, "x_mm": 10.0, "y_mm": 10.0}, "unknown key 'mass'"),
        ({"kind": "orientation", "layer": "layer9", "angle_deg": 5.0}, "layer = 'layer9'"),
    ],
)
def test_bad_effect_tables_fail_at_load(table, message):
    with pytest.raises(SpecError, match=message.replace("(", r"\(")):
        parse_spec(with_effects(table))


def test_free_effects_bring_parameters(example_spec):
    on = effect("point_mass").free(example_spec)[0]
    assert on.free == tuple(Parameter(k, "point_mass") for k in ("mass", "x", "y"))
    assert effect("orientation").free_all(example_spec).free == tuple(
        Parameter("angle", f"layer{i}") for i in (1, 2, 3)
    )
    assert {p.target for p in effect("adhesive").free(example_spec)[0].free} == {
        "brass_bottom.bottom1",
        "brass_top.top1",
    }


def test_a_point_mass_starts_where_a_refit_ended(example_spec):
    """``hint_at`` turns a finished refit's values [SI] into the start ``free`` takes: the
    switched-on model holds exactly those values (a refit from a fit's end starts at it)."""
    kind = effect("point_mass")
    mass, x, y = (Parameter(k, "point_mass") for k in ("mass", "x", "y"))
    ended = {mass: 4.2e-3, x: 0.031, y: 0.117}
    on = kind.free(example_spec, kind.hint_at(ended))[0]
    assert {p: on.model.value(p) for p in on.free} == ended
    assert on.note.startswith("start where a refit ended")


def test_user_registered_effect(example_spec):
    """The README's worked example: a layer of paint of unknown mass per area on top."""

    class Paint(Effect):
        kind = "paint_test"
        description = "paint on the top face: extra mass per area"
        keys = ("grams_per_m2",)

        def fixed(self, model, table):
            self._check(table)
            return SwitchedOn(self.kind, self._painted(model, self._number(table, "grams_per_m2")))

        def free(self, model, hint=None):
            top = model.specimen.layers[-1].material.name
            return [
                SwitchedOn(
                    self.kind, self._painted(model, 20.0), (Parameter("density", top),), "top mass free"
                )
            ]

        @staticmethod
        def _painted(model, grams_per_m2):
            top = model.specimen.layers[-1]
            extra = grams_per_m2 * 1e-3 / top.thickness
            return model.with_values({Parameter("density", top.material.name): top.material.density + extra})

    try:
        register(Paint())
        model = parse_spec(with_effects({"kind": "paint_test", "grams_per_m2": 50.0}))
        assert model.specimen.materials["top_coating"].density == pytest.approx(2700 + 0.05 / 2e-4)
        assert effect("paint_test").free(model)[0].free == (Parameter("density", "top_coating"),)
    finally:
        REGISTRY.pop("paint_test", None)
