"""plan-tests scores designs for the layers' loss factors: the condition number of the
loss-factor columns and each loss factor's predicted std (``designer.scores.damping``)."""

import json

import numpy as np
import pytest
import tomli_w

from designer.check import check
from designer.cli import main
from designer.scores.damping import damping_scores
from fem.spec import parse_spec

from .conftest import paper_data


def damped(adhesive: bool = False, **design) -> dict:
    """The paper's plate asking for the three layers' loss factors (and the adhesive's)."""
    data = paper_data()
    for name in ("steel", "top_coating", "bottom_coating"):
        data["materials"][name]["identify_damping"] = True
    data["materials"]["brass"]["eta"] = 0.001
    data["materials"]["adhesive"]["eta"] = 0.1
    if adhesive:
        data["materials"]["adhesive"]["identify_damping"] = True
    data.setdefault("design", {}).update(design)
    return data


def test_check_json_has_the_damping_block(capsys, tmp_path):
    spec = tmp_path / "damped.toml"
    spec.write_bytes(tomli_w.dumps(damped()).encode())
    status = main(["check", str(spec), "--json"])
    data = json.loads(capsys.readouterr().out)
    block = data["damping"]
    assert status == 0 and block["verdict"] == "good" and 1 < block["condition_number"] < 1e3
    assert set(block["predicted_std"]) == {"steel", "top_coating", "bottom_coating"}
    assert set(block["predicted_std"]["steel"]) == {"eta_E1", "eta_E2", "eta_G12"}
    assert all(0 < s < 0.01 for m in block["predicted_std"].values() for s in m.values())
    assert block["useless_for"] == []


def test_predicted_std_scales_with_the_damping_scatter():
    """Linear least squares: the predicted std is proportional to the stated scatter."""
    model = parse_spec(damped())
    configurations = model.specimen.configurations
    a, b = (damping_scores(model, configurations, s) for s in (0.03, 0.06))
    assert b.predicted_std == pytest.approx(2 * a.predicted_std, rel=1e-12)
    assert a.condition_number == pytest.approx(b.condition_number)


def test_good_for_stiffness_useless_for_damping():
    """The 50 um adhesive's loss factor: its share of the strain energy is tiny, so the
    design that identifies every stiffness well cannot find it, and check says so."""
    result = check(parse_spec(damped(adhesive=True)))
    assert result.design.scores.verdict == "good"
    assert "adhesive.eta" in result.damping.useless
    assert any("does not determine the loss factors" in w and "adhesive.eta" in w for w in result.warnings)
    assert "useless for their damping" in result.report()


def test_one_plate_alone_is_singular_for_damping():
    model = parse_spec(damped())
    scores = damping_scores(model, [model.specimen.configuration("original")], 0.03)
    assert scores.verdict == "singular" and np.isinf(scores.predicted_std).all()
    assert json.dumps(scores.to_dict(), allow_nan=False)


def test_no_damping_asked_no_block():
    model = parse_spec(paper_data())
    assert damping_scores(model, model.specimen.configurations, 0.03) is None
