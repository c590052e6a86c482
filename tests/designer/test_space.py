"""The [design] table and the stock library: cross-checked values, and one-line errors
that name the key, the value, what is allowed and a fix."""

import json
import math

import pytest

from designer.problem import Problem
from fem.errors import DesignError
from fem.spec import parse_spec
from fem.stock import STOCK
from tests.conftest import DATA

from .conftest import paper_data

SPEEDS = json.loads((DATA / "sound_speeds_crc.json").read_text())


@pytest.mark.parametrize("name", sorted(SPEEDS["materials"]))
def test_stock_against_handbook_wave_speeds(name):
    """Thin-rod and shear wave speeds sqrt(E/rho), sqrt(G/rho) of each stock metal within
    6 % of the CRC Handbook's table (independent of the data sheets the library cites).
    6 %: the handbook rows are generic metals, the library specific alloys; copper's
    modulus alone spans 110-130 GPa with texture and temper."""
    s, ref = STOCK[name], SPEEDS["materials"][name]
    m = s.material()
    assert math.sqrt(m.E1 / m.density) == pytest.approx(ref["v_ext"], rel=0.06)
    assert math.sqrt(m.G12 / m.density) == pytest.approx(ref["v_s"], rel=0.06)
    assert m.G12 == pytest.approx(m.E1 / (2 * (1 + m.nu12)), rel=1e-12) and not m.identify
    assert s.source


def test_spec_materials_before_stock_and_the_stock_suffix(paper):
    """'brass' is the spec's (100 GPa), 'steel_stock' the library's steel, since the
    spec's own 'steel' is identified; the default materials rename steel the same way."""
    space = paper.design
    by_name = {m.name: m for m in space.materials}
    assert by_name["brass"].E1 == pytest.approx(100e9)
    assert by_name["steel_stock"].E1 == pytest.approx(210e9)
    data = paper_data()
    del data["design"]["materials"]
    space = parse_spec(data).design
    assert [m.name for m in space.materials] == ["brass", "aluminium", "steel_stock"]
    assert space.materials[0].E1 == pytest.approx(100e9), "the spec's brass, not the stock one"


def test_defaults_without_a_design_table():
    data = paper_data()
    del data["design"]
    space = parse_spec(data).design
    assert space.size == 3, "one configuration per identified material (paper section 4.1)"
    assert space.adhesive.material.name == "epoxy" and space.adhesive.thickness == pytest.approx(50e-6)
    assert space.frequency_std_rel == 1e-3 and space.criterion == "condition"


def edit_design(**changes):
    data = paper_data()
    data["design"].update(changes)
    return data


CASES = [
    (
        "unknown material",
        edit_design(materials=["brass", "alumnium"]),
        [
            "[design].materials[1] = 'alumnium'",
            "neither a spec material nor built-in stock",
            "did you mean 'aluminium'",
        ],
    ),
    (
        "identified material as added plate",
        edit_design(materials=["steel"]),
        ["[design].materials[0] = 'steel' is identified", "use 'steel_stock'"],
    ),
    ("empty thickness list", edit_design(thicknesses_mm=[]), ["[design].thicknesses_mm is empty", "e.g."]),
    ("thickness in metres", edit_design(thicknesses_mm=[0.001]), ["thicknesses_mm[0] = 0.001", "in mm"]),
    ("bad placement", edit_design(placements=["top", "side"]), ["placements[1] = 'side'", "'top', 'bottom'"]),
    ("misspelt key", edit_design(frequency_std=0.001), ["unknown key 'frequency_std'", "frequency_std_rel"]),
    ("one configuration", edit_design(configurations=1), ["configurations = 1", ">= 2"]),
    (
        "scatter in per cent",
        edit_design(frequency_std_rel=0.5),
        ["frequency_std_rel = 0.5", "0.001 for 0.1 %"],
    ),
    ("reversed band", edit_design(band_hz=[5000, 20]), ["band_hz = [5000, 20]", "low < high"]),
    ("unknown criterion", edit_design(criterion="a"), ["criterion = 'a'", "'condition', 'd', 'e'"]),
    (
        "unknown adhesive",
        edit_design(adhesive={"material": "glue", "thickness_mm": 0.05}),
        ["[design].adhesive.material = 'glue'", "stock:"],
    ),
    ("material listed twice", edit_design(materials=["brass", "brass"]), ["'brass' is listed twice"]),
]


@pytest.mark.parametrize("data,expected", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_design_one_line_error(data, expected):
    with pytest.raises(DesignError) as info:
        parse_spec(data)
    message = str(info.value)
    assert "\n" not in message
    for fragment in expected:
        assert fragment in message, message


def test_no_identified_material():
    data = paper_data()
    for table in data["materials"].values():
        table["identify"] = False
    with pytest.raises(DesignError, match="no material has identify = true.*set identify = true"):
        Problem.of(parse_spec(data))
