"""plan-tests: check / recommend / sweep, their JSON contracts (docs/json.md), exit
statuses, the sweep's report folder, and a sweep's numbers against a direct check."""

import io
import json

import numpy as np
import pandas as pd
import pytest

from designer.cli import main
from designer.progress import Bar, Progress
from fem.io import REPORT_MARK

from .conftest import PAPER_TOML


def run(capsys, *argv) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    out = capsys.readouterr()
    return status, out.out, out.err


def test_check_paper_design_json(capsys):
    status, out, _ = run(capsys, "check", PAPER_TOML, "--json")
    data = json.loads(out)
    assert status == 0 and data["feasible"] is True
    assert data["verdict"] == "good" and 10 < data["condition_number"] < 100
    assert set(data["predicted_std"]) == {"steel", "top_coating", "bottom_coating"}
    assert set(data["predicted_std"]["steel"]) == {"E1_GPa", "E2_GPa", "G12_GPa", "nu12"}
    assert [c["name"] for c in data["configurations"]] == ["original", "brass_bottom", "brass_top"]
    assert any("modes 4 and 5 of 'original'" in w for w in data["warnings"]), "close-mode warning"


def test_check_single_plate_is_infeasible_exit_1(capsys):
    status, out, _ = run(capsys, "check", PAPER_TOML, "--modes", "15", "--configurations", "original")
    assert status == 1
    assert "singular" in out and "feasible: NO" in out


def test_check_bad_input_exit_2_one_line(capsys, tmp_path):
    data = PAPER_TOML.read_text().replace(
        'materials = ["brass", "aluminium", "steel_stock"]', 'materials = ["brass", "unobtainium"]'
    )
    bad = tmp_path / "bad.toml"
    bad.write_text(data)
    status, _, err = run(capsys, "check", bad)
    assert status == 2
    assert err.startswith("error: [design].materials[1] = 'unobtainium'") and err.count("\n") == 1


def test_recommend_json_best_first(capsys):
    status, out, _ = run(capsys, "recommend", PAPER_TOML, "--json", "--top", "3")
    data = json.loads(out)
    assert status == 0 and len(data["designs"]) == 3
    conds = [d["condition_number"] for d in data["designs"]]
    assert conds == sorted(conds)
    assert conds[0] <= data["baseline"]["condition_number"]
    first = data["designs"][0]
    assert first["configurations"][0]["name"] == "original" and len(first["configurations"]) == 3
    # 24 candidates, of which the default mass limit (3 x the specimen's 148.7 g = 446.2 g) leaves out
    # the 3 mm brass (575.1 g) and steel (531.2 g) plates on either face: C(20, 2) sets
    assert data["search"]["method"] == "exhaustive" and data["search"]["sets"] == 190
    assert data["limits"]["max_added_mass_g"] == pytest.approx(
        3 * 0.0225 * (2 * 2700 * 0.2 + 7900 * 0.7), rel=1e-12
    )
    assert data["limits"]["defaults"] == ["mass", "thickness"] and len(data["search"]["excluded"]) == 4


def test_recommend_default_example(capsys):
    status, out, err = run(capsys, "recommend", "--top", "1")
    assert status == 0 and "bundled example" in err
    assert "best design" in out and "Poisson-plate rule" in out


def test_recommend_refine_json(capsys):
    status, out, _ = run(capsys, "recommend", PAPER_TOML, "--json", "--top", "1", "--refine")
    data = json.loads(out)
    assert status == 0
    refined = data["refined"]
    assert all(0.5 <= t <= 3.0 for t in refined["thicknesses_mm"]), "within the stock range"
    assert refined["design"]["condition_number"] <= data["designs"][0]["condition_number"]


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    assert (
        main(
            [
                "sweep",
                str(PAPER_TOML),
                "--vary",
                "thickness=0.5,2",
                "--vary",
                "brass_top.material=aluminium",
                "--out",
                str(folder),
            ]
        )
        == 0
    )
    return folder


def test_sweep_report_folder(swept):
    table = pd.read_csv(swept / "sweep.csv")
    assert list(table.variable) == ["base", "thickness", "thickness", "brass_top.material"]
    for name in ("sweep_thickness.png", "sweep_brass_top.material.png"):
        assert (swept / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = (swept / "summary.md").read_text()
    assert "## thickness" in summary and "## brass_top.material" in summary
    assert [p.name for p in swept.glob(".*")] == [REPORT_MARK], "no temporary files left behind"


def spec_with(tmp_path, thickness_top: float, thickness_bottom: float, top_material: str = "brass"):
    """The paper spec with other added plates, written as a user would."""
    text = PAPER_TOML.read_text()
    text = text.replace(
        'bottom = [ { material = "adhesive", thickness_mm = 0.05 },\n'
        '           { material = "brass", thickness_mm = 1.0 } ]',
        'bottom = [ { material = "adhesive", thickness_mm = 0.05 },\n'
        f'           {{ material = "brass", thickness_mm = {thickness_bottom} }} ]',
    )
    text = text.replace(
        'top = [ { material = "adhesive", thickness_mm = 0.05 },\n'
        '        { material = "brass", thickness_mm = 1.0 } ]',
        'top = [ { material = "adhesive", thickness_mm = 0.05 },\n'
        f'        {{ material = "{top_material}", thickness_mm = {thickness_top} }} ]',
    )
    if top_material == "aluminium":  # a spec defines its materials: the stock values written out
        text = text.replace(
            "[[configurations]]",
            """[materials.aluminium]
E1_GPa = 68.9
E2_GPa = 68.9
G12_GPa = 25.902255639097744
nu12 = 0.33
density_kg_m3 = 2700

[[configurations]]""",
            1,
        )
    path = tmp_path / "variant.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "row,variant",
    [(2, (2.0, 2.0, "brass")), (3, (1.0, 1.0, "aluminium"))],
    ids=["thickness=2", "brass_top.material=aluminium"],
)
def test_sweep_numbers_equal_a_direct_check(swept, tmp_path, capsys, row, variant):
    """A sweep row and `plan-tests check` of a spec written with that design: the same
    condition number, Fisher information and predicted std (same solves: to round-off)."""
    table = pd.read_csv(swept / "sweep.csv")
    capsys.readouterr()
    status, out, _ = run(capsys, "check", spec_with(tmp_path, *variant), "--json")
    direct = json.loads(out)
    r = table.iloc[row]
    assert r.condition_number == pytest.approx(direct["condition_number"], rel=1e-9)
    assert r.logdet_fisher == pytest.approx(direct["logdet_fisher"], rel=1e-9)
    for material, stds in direct["predicted_std_rel"].items():
        for kind, value in stds.items():
            assert r[f"std_rel.{material}.{kind}"] == pytest.approx(value, rel=1e-9)
    for c in direct["configurations"]:
        f = [r[f"{c['name']}.f{i + 1}_hz"] for i in range(len(c["frequencies_hz"]))]
        np.testing.assert_allclose(f, c["frequencies_hz"], rtol=1e-6)  # JSON rounds to 1e-4 Hz


def test_sweep_bad_variable(capsys):
    status, _, err = run(capsys, "sweep", PAPER_TOML, "--vary", "thikness=1,2", "--out", "unused")
    assert status == 2 and "did you mean 'thickness'" in err


def test_progress_bar_draws_and_ends_its_line():
    stream = io.StringIO()
    with Bar(Progress(stream, show_after=0.0), 4, "solving") as bar:
        for _ in range(4):
            bar.update()
    text = stream.getvalue()
    assert text.startswith("\rsolving [") and "4/4" in text and text.endswith("\n")
    quiet = io.StringIO()
    with Bar(Progress(quiet), 4, "solving") as bar:  # shows only after 0.5 s
        bar.update(4)
    assert quiet.getvalue() == ""


def test_check_over_a_limit_is_infeasible(capsys, tmp_path):
    """The paper's brass plates add 192.6 g each: a 150 g limit makes the set infeasible
    (exit 1) although it is well conditioned."""
    spec = tmp_path / "limited.toml"
    spec.write_text(PAPER_TOML.read_text().replace("[design]", "[design]\nmax_added_mass_g = 150.0"))
    status, out, _ = run(capsys, "check", spec, "--json")
    data = json.loads(out)
    assert status == 1 and data["verdict"] == "good" and data["feasible"] is False
    assert data["violations"] == [
        "'brass_bottom' adds 192.6 g > max_added_mass_g = 150",
        "'brass_top' adds 192.6 g > max_added_mass_g = 150",
    ]
