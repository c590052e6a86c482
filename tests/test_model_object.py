"""One model object from the spec: every command and the API see the same
model, the spec's fixed effects included, and a bad [design] table stops them all."""

import copy
import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import designer
import identify
from designer.cli import main as plan_tests
from identify.cli import main as identify_layers
from identify.examples import COATED_PLATE

ROOT = Path(__file__).parent.parent
BASE = tomllib.loads(COATED_PLATE.read_text())


def toml_text(data: dict) -> str:
    """A minimal TOML writer for the spec dicts used here (tables, arrays of tables)."""

    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = []
    for key, table in data.items():
        if isinstance(table, list):
            for item in table:
                lines += [f"[[{key}]]"] + [f"{k} = {value(v)}" for k, v in item.items()]
        elif key == "materials":
            for name, props in table.items():
                lines += [f"[materials.{name}]"] + [f"{k} = {value(v)}" for k, v in props.items()]
        else:
            lines += [f"[{key}]"] + [f"{k} = {value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def effects_spec(tmp_path_factory) -> Path:
    """The bundled example with a 30 g sensor and transverse shear switched on in the spec."""
    data = copy.deepcopy(BASE)
    data["effects"] = [
        {"kind": "point_mass", "mass_g": 30.0, "x_mm": 125.0, "y_mm": 110.0},
        {"kind": "transverse_shear"},
    ]
    path = tmp_path_factory.mktemp("spec") / "with_effects.toml"
    path.write_text(toml_text(data))
    return path


def test_predict_check_fit_and_api_agree_with_fixed_effects(effects_spec, capsys, tmp_path):
    """predict, plan-tests check, fit and the API solve the same model.  Reference: the
    API's model; a 30 g sensor moves the first mode by ~6 %, so a command that forgot the
    effects would be off by far more than the 1e-6 allowed (the JSON rounds to 1e-4 Hz)."""
    model = identify.load_spec(effects_spec)
    assert model.effects == ("point_mass", "transverse_shear") and model.options.transverse_shear
    api = identify.predict(model).frequencies_hz
    bare = identify.predict(identify.load_spec(COATED_PLATE)).frequencies_hz
    assert api["original"][0] < 0.97 * bare["original"][0], "the sensor lowers the first mode"

    assert identify_layers(["predict", str(effects_spec), "--json"]) == 0
    predicted = {
        c["name"]: c["frequencies_hz"] for c in json.loads(capsys.readouterr().out)["configurations"]
    }
    assert plan_tests(["check", str(effects_spec), "--json"]) in (0, 1)
    checked = {c["name"]: c["frequencies_hz"] for c in json.loads(capsys.readouterr().out)["configurations"]}
    for name, f in api.items():
        np.testing.assert_allclose(predicted[name], f, rtol=1e-6)
        np.testing.assert_allclose(checked[name], f, rtol=1e-6)

    # fit starts from the spec's values: with the predicted frequencies as data, its start
    # reproduces them (RMS error ~1e-12) only if it models the same effects.
    rows = [
        {"configuration": n, "mode": i + 1, "frequency_hz": v}
        for n, f in api.items()
        for i, v in enumerate(f)
    ]
    csv = tmp_path / "predicted.csv"
    pd.DataFrame(rows).to_csv(csv, index=False)
    assert identify_layers(["fit", str(effects_spec), str(csv), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["history"][0]["rms_rel_error"] < 1e-9
    assert out["iterations"] == 0 or out["rms_rel_error"] < 1e-9


@pytest.mark.parametrize(
    "argv",
    [
        ["predict"],
        ["fit", "DATA"],
        ["compare", "DATA"],
        ["diagnose", "DATA"],
        ["check"],
        ["recommend"],
        ["sweep", "--out", "OUT"],
    ],
)
def test_a_bad_design_table_stops_every_command(argv, capsys, tmp_path):
    data = copy.deepcopy(BASE)
    data["design"]["band_hz"] = "wide"
    spec = tmp_path / "bad_design.toml"
    spec.write_text(toml_text(data))
    command, *rest = argv
    rest = [
        str(identify.examples.COATED_PLATE_MEASURED)
        if a == "DATA"
        else str(tmp_path / "out")
        if a == "OUT"
        else a
        for a in rest
    ]
    tool = plan_tests if command in ("check", "recommend", "sweep") else identify_layers
    assert tool([command, str(spec), *rest]) == 2
    err = capsys.readouterr().err
    assert "[design].band_hz = 'wide'" in err and err.count("\n") == 1


def test_no_consumer_applies_effects_by_hand():
    """Only the spec loader switches on the spec's effects: no module outside fem/ (and no
    test) imports apply_fixed."""
    offenders = [
        str(p.relative_to(ROOT))
        for folder in ("identify", "designer", "studies", "benchmarks", "tests")
        for p in (ROOT / folder).rglob("*.py")
        if re.search(r"\bapply_fixed\b", p.read_text()) and p.name != Path(__file__).name
    ]
    assert offenders == []


def test_public_api_results_report_and_export(capsys):
    """Every API function returns a result with report(), to_dict() and a notebook view."""
    model = identify.load_spec(COATED_PLATE)
    data = identify.load_measurements(identify.examples.COATED_PLATE_MEASURED, model)
    for result in (identify.predict(model), identify.fit(model, data), designer.check(model)):
        assert result.report() and json.dumps(result.to_dict(), default=lambda x: x.tolist())
        view = result._repr_html_()
        # identify's views are the HTML report's tables; the planner's the text report
        assert "<table" in view if not isinstance(result, designer.CheckResult) else view.startswith("<pre>")
    assert set(identify.__all__) >= {
        "load_spec",
        "load_measurements",
        "predict",
        "fit",
        "compare",
        "diagnose",
    }
    assert set(designer.__all__) >= {"check", "recommend", "sweep"}
