"""`plan-tests recommend --write-spec`: the best design as a spec that `check` and `fit`
take as they are, reproducing the recommendation's scores."""

import json
import tomllib

import numpy as np
import pandas as pd
import pytest

import identify
from designer.check import check
from designer.cli import main as plan_tests
from designer.problem import Problem
from designer.search.ranking import recommend
from designer.spec_file import write_spec
from fem.errors import DesignError
from fem.spec import load_spec, parse_spec
from identify.cli import main as identify_layers

from .conftest import PAPER_TOML, paper_data, problem_of

#: Scores of the written spec against the recommendation's: the same solves (materials
#: written with full precision), so only the last bits of a GPa round trip may differ.
SAME = 1e-9


def assert_same_scores(checked, recommended):
    a, b = checked.scores, recommended.scores
    assert a.condition_number == pytest.approx(b.condition_number, rel=SAME)
    assert a.logdet_fisher == pytest.approx(b.logdet_fisher, rel=SAME)
    np.testing.assert_allclose(a.std_rel, b.std_rel, rtol=SAME)
    assert checked.names == recommended.names
    for x, y in zip(checked.solved, recommended.solved):
        np.testing.assert_allclose(x.frequencies_hz, y.frequencies_hz, rtol=SAME)


def test_check_of_the_written_spec_reproduces_the_recommendation(paper_problem, tmp_path):
    """The paper's space: the best set (stock steel on both faces, which the paper spec
    does not define) written, loaded and checked: the same configurations, frequencies,
    condition number, log det F and predicted std.  The stock steel is written out as
    [materials.steel_stock] with its source; the spec's own tables are kept."""
    best = recommend(paper_problem, top=1).best
    path = write_spec(paper_problem, best, tmp_path / "plan.toml")
    written = tomllib.loads(path.read_text())
    original = tomllib.loads(PAPER_TOML.read_text())
    assert [c["name"] for c in written["configurations"]] == list(best.names)
    assert written["design"] == original["design"] and written["specimen"] == original["specimen"]
    for name in original["materials"]:
        assert written["materials"][name] == original["materials"][name]
    added = {l.material.name for s in best.solved for l in s.configuration.top + s.configuration.bottom}
    assert added <= set(written["materials"])
    if "steel_stock" in added:
        assert written["materials"]["steel_stock"]["E1_GPa"] == pytest.approx(210.0)
        assert "built-in stock" in written["materials"]["steel_stock"]["note"]
    assert path.read_text().startswith("# Test plan written by plan-tests recommend")
    assert_same_scores(check(load_spec(path)).design, best)


def test_written_robust_spec_reproduces_the_robust_scores(tmp_path):
    """Scored over the prior (4 samples of +-30 %, given on the command line's behalf as
    the problem's prior range): the written spec carries prior_range_rel, and its check
    gives the same worst and mean over the same prior points."""
    data = paper_data()
    data["design"].update(materials=["brass", "aluminium"], thicknesses_mm=[0.5, 1.0], prior_samples=4)
    problem = Problem.of(problem_of(data), prior_range=0.3)
    best = recommend(problem, top=1).best
    path = write_spec(problem, best, tmp_path / "robust.toml")
    assert tomllib.loads(path.read_text())["design"]["prior_range_rel"] == 0.3
    checked = check(load_spec(path)).design
    assert_same_scores(checked, best)
    for criterion in ("condition", "d", "e"):
        assert checked.robust.worst(criterion) == pytest.approx(best.robust.worst(criterion), rel=SAME)
        assert checked.robust.mean(criterion) == pytest.approx(best.robust.mean(criterion), rel=SAME)


def test_cli_write_spec_then_check_and_fit(tmp_path, capsys):
    """The command line: recommend --write-spec, then `plan-tests check` of that file gives
    the recommended condition number, and `identify-layers fit` takes it with the
    frequencies it predicts (a virtual test at the spec's values): converged, exit 0."""
    out = tmp_path / "plan.toml"
    assert plan_tests(["recommend", str(PAPER_TOML), "--top", "1", "--json", "--write-spec", str(out)]) == 0
    recommended = json.loads(capsys.readouterr().out)
    assert recommended["written_spec"] == str(out) and out.exists()
    assert not list(tmp_path.glob(".*")), "written atomically: no temporary file left"
    assert plan_tests(["check", str(out), "--json"]) == 0
    checked = json.loads(capsys.readouterr().out)
    assert checked["condition_number"] == pytest.approx(
        recommended["designs"][0]["condition_number"], rel=SAME
    )

    model = identify.load_spec(out)
    rows = [
        {"configuration": name, "mode": i + 1, "frequency_hz": f}
        for name, fs in identify.predict(model).frequencies_hz.items()
        for i, f in enumerate(fs)
    ]
    csv = tmp_path / "measured.csv"
    pd.DataFrame(rows).to_csv(csv, index=False)
    assert identify_layers(["fit", str(out), str(csv), "--json"]) == 0
    fit = json.loads(capsys.readouterr().out)
    assert fit["status"] == "converged" and fit["rms_rel_error"] < 1e-9


def test_stock_materials_by_name_in_configurations():
    """A spec may name built-in stock in [[configurations]] without defining it: the
    bonded aluminium is the stock one (68.9 GPa), and such a spec checks like one that
    writes the values out."""
    data = paper_data()
    del data["materials"]["brass"]
    data["configurations"][2]["top"][1]["material"] = "aluminium"
    data["configurations"][1]["bottom"][1]["material"] = "aluminium"
    data["design"]["materials"] = ["aluminium"]
    model = parse_spec(data)
    added = model.specimen.configuration("brass_top").top[1].material
    assert added.name == "aluminium" and added.E1 == pytest.approx(68.9e9)
    assert check(model).design.scores.verdict == "good"


def test_a_model_changed_in_code_is_not_written_as_its_file(paper_problem, tmp_path):
    """A model loaded from a file and then changed (here steel's E1 raised 10 %) no longer
    matches its file: writing it would give a spec whose check scores another plate, so
    the writer refuses in one line, and writes nothing."""
    steel_E1 = next(p for p in paper_problem.parameters if p.name == "steel.E1")
    changed = paper_problem.at({steel_E1: 1.1 * paper_problem.specimen.value(steel_E1)})
    design = check(changed).design
    with pytest.raises(DesignError, match="would not read back as the same laminate") as info:
        write_spec(changed, design, tmp_path / "changed.toml")
    assert "\n" not in str(info.value) and not (tmp_path / "changed.toml").exists()
