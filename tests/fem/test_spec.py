"""Spec loading: the bundled example loads; every kind of bad input gets a one-line error
naming the field, the value and what is allowed."""

import copy
import tomllib

import pytest

from fem.errors import SpecError
from fem.spec import load_spec, parse_spec
from identify.examples import COATED_PLATE

BASE = tomllib.loads(COATED_PLATE.read_text())


def test_example_loads_in_si(example_spec):
    s = example_spec.specimen
    assert (s.length, s.width) == (0.15, 0.15)
    assert [l.thickness for l in s.layers] == pytest.approx([2e-4, 7e-4, 2e-4])
    assert [c.name for c in s.configurations] == ["original", "brass_bottom", "brass_top"]
    bottom = s.laminate("brass_bottom").layers
    assert [l.material.name for l in bottom[:2]] == ["brass", "adhesive"], "bottom additions listed outward"
    assert {m.name for m in s.identified_materials} == {"steel", "top_coating", "bottom_coating"}
    assert s.materials["steel"].E1 == pytest.approx(151e9)
    assert example_spec.options.modes == 5


def edited(edit):
    data = copy.deepcopy(BASE)
    edit(data)
    return data


def set_layer(i, **kw):
    return lambda d: d["specimen"]["layers"][i].update(kw)


CASES = [
    ("negative thickness", set_layer(1, thickness_mm=-0.7), ["thickness_mm", "-0.7", "positive"]),
    ("zero thickness", set_layer(1, thickness_mm=0.0), ["thickness_mm", "0", "positive"]),
    (
        "thickness in the wrong unit",
        set_layer(1, thickness_mm=1100.0),
        ["thickness_mm = 1100", "150", "in mm"],
    ),
    ("thickness in metres", set_layer(1, thickness_mm=0.00000007), ["thickness_mm", "in mm"]),
    (
        "unknown material",
        set_layer(0, material="bottom_coatnig"),
        ["bottom_coatnig", "did you mean 'bottom_coating'"],
    ),
    (
        "nu12 not positive definite",
        lambda d: d["materials"]["steel"].update(nu12=1.5),
        ["[materials.steel]", "nu12 = 1.5", "nu12^2 < E1/E2 = 1.007"],
    ),
    (
        "missing field",
        lambda d: d["materials"]["steel"].pop("G12_GPa"),
        ["[materials.steel]", "missing field 'G12_GPa'"],
    ),
    (
        "modulus in MPa",
        lambda d: d["materials"]["steel"].update(E1_GPa=201000.0),
        ["E1_GPa = 201000", "in GPa"],
    ),
    (
        "density in g/cm3",
        lambda d: d["materials"]["steel"].update(density_kg_m3=7.9),
        ["density_kg_m3 = 7.9", "kg/m^3"],
    ),
    (
        "misspelt key",
        lambda d: d["materials"]["steel"].update(E_GPa=1.0),
        ["unknown key 'E_GPa'", "did you mean"],
    ),
    ("empty layer list", lambda d: d["specimen"].update(layers=[]), ["layers is empty"]),
    ("missing layers", lambda d: d["specimen"].pop("layers"), ["missing field 'layers'"]),
    (
        "two configurations adding nothing",
        lambda d: d["configurations"].append({"name": "again"}),
        ["'again'", "adds nothing", "'original'"],
    ),
    (
        "duplicate configuration name",
        lambda d: d["configurations"].append({"name": "brass_top", "top": []}),
        ["'brass_top'", "used twice"],
    ),
    ("length in metres", lambda d: d["specimen"].update(length_mm=0.15), ["length_mm = 0.15", "in mm"]),
    ("modes not a count", lambda d: d["model"].update(modes=0), ["[model].modes = 0", "1 to"]),
    ("NaN thickness", set_layer(1, thickness_mm=float("nan")), ["thickness_mm", "finite"]),
    (
        "identify an unknown property",
        lambda d: d["materials"]["steel"].update(identify=["G13", "G99"]),
        ["[materials.steel]", "'G99' is not a material property", "G23"],
    ),
    (
        "identify not a list of names",
        lambda d: d["materials"]["steel"].update(identify="yes"),
        ["[materials.steel].identify = 'yes'", "true, false or a list"],
    ),
]


@pytest.mark.parametrize("edit,expected", [(e, x) for _, e, x in CASES], ids=[c[0] for c in CASES])
def test_bad_spec_one_line_error(edit, expected):
    with pytest.raises(SpecError) as info:
        parse_spec(edited(edit))
    message = str(info.value)
    assert "\n" not in message
    for fragment in expected:
        assert fragment in message, message


def test_unreadable_and_invalid_toml(tmp_path):
    with pytest.raises(SpecError, match="cannot be read"):
        load_spec(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[specimen\nname = 1")
    with pytest.raises(SpecError, match="not valid TOML"):
        load_spec(bad)


def test_identify_names_the_properties_to_find():
    """identify = true means E1, E2, G12, nu12; a list names others (a core's shear moduli)."""
    data = edited(lambda d: d["materials"]["steel"].update(identify=["G13", "G23", "density"]))
    names = [p.name for p in parse_spec(data).specimen.material_parameters()]
    assert names[4:7] == ["steel.G13", "steel.G23", "steel.density"]
    assert names[:4] == [
        "bottom_coating.E1",
        "bottom_coating.E2",
        "bottom_coating.G12",
        "bottom_coating.nu12",
    ]
