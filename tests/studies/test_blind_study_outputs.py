"""The blind study's outputs (without running a diagnosis: ``run_case`` is replaced by a
recorded outcome): each case's diagnosis report is kept as the case ends, the rows and the
summary are strict JSON."""

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from studies import blind_diagnosis as study

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "data" / "solid3d"))

import blind  # noqa: E402
import generate  # noqa: E402


def test_each_case_keeps_its_report_and_the_summary_is_strict_json(tmp_path, monkeypatch):
    def recorded(name, progress=None):
        oracle = study.Oracle(1.9e-4, "layerwise", 1.1, {"shear": (5e-3, 40.0)}, ("shear",))
        return study.Outcome(
            name,
            "hybrid",
            "dev",
            5e-4,
            oracle,
            selected=("layerwise",),
            rms_baseline=0.01,
            rms_after=2e-4,
            max_z=1.2,
            z={"cfrp_ud.E1": 1.2},
            seconds=12.0,
            oracle_seconds=3.0,
            report=f"== diagnosis of {name} ==",
            above_start=((1, "thick_plate"), (2, "point_mass")),
        )

    monkeypatch.setattr(study, "run_case", recorded)
    assert study.main(["--case", "blind04_hybrid", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "cases" / "blind04_hybrid.txt").read_text() == "== diagnosis of blind04_hybrid ==\n"
    data = json.loads((tmp_path / "blind_dev.json").read_text(), parse_constant=lambda c: 1 / 0)
    assert data["cases"][0]["selected"] == "layerwise"
    assert data["cases"][0]["without"] == {"shear": {"rms_pct": 0.5, "max_z": 40.0}}
    assert data["summary"]["dev"]["cases"] == 1
    assert data["summary"]["dev"]["contains_true_pct"] == 100.0
    # A shear refit that ended above its start is a fault the study counts; a point mass's is not.
    assert data["cases"][0]["above_start"] == ["round 1: thick_plate", "round 2: point_mass"]
    assert data["summary"]["dev"]["shear_refits_above_start"] == 1


def test_an_effect_is_true_when_leaving_it_out_costs_the_misfit_or_a_property():
    """blind24 (std of the scatter alone): without the skins' 5.5 and 3.7 deg misalignment the oracle ends
    1.28 x the floor (below 1.5) but its skins' G12 12 std off: true.  A property already
    off in the oracle itself (4 std) does not make every effect true."""
    floor = 4.39e-4
    without = {"shear": (0.2, 1e3), "orientation": (5.61e-4, 12.1), "point_mass": (4.40e-4, 1.1)}
    assert study.true_effects(without, floor, 1.12) == ("shear", "orientation")
    assert study.true_effects({"orientation": (4.5e-4, 3.9)}, floor, 4.0) == ()
    assert study.true_effects({"point_mass": (6.7e-4, 0.5)}, floor, 1.0) == ("point_mass",)
    # Undefined std (a refit that did not finish) leave the RMS alone to decide.
    assert study.true_effects({"orientation": (4.5e-4, math.inf)}, floor, 1.0) == ()
    assert study.true_effects({"orientation": (4.5e-4, 5.0)}, floor, math.inf) == ()


def test_the_properties_are_also_scored_in_the_measurements_std_alone():
    """A lay-up tolerance widens a property's std; the study scores it both ways, so the
    widening cannot pass for a better estimate (blind07's carbon nu12: 0.021 -> 0.44)."""
    from types import SimpleNamespace

    import numpy as np

    from fem.specimen import Parameter
    from identify.fitting.budget import Budget

    nu12 = Parameter("nu12", "carbon")
    fit = SimpleNamespace(
        parameters=(nu12,),
        value=lambda p: 0.30,
        std=lambda p: 0.44,
        budget=Budget((nu12,), (), np.array([0.021]), np.zeros((1, 0))),
    )
    assert math.isclose(study._z(fit, {nu12: 0.41})["carbon.nu12"], 0.11 / 0.44)
    assert math.isclose(study._z(fit, {nu12: 0.41}, measurement_only=True)["carbon.nu12"], 0.11 / 0.021)


def test_a_killed_worker_leaves_the_unfinished_cases_as_failures(tmp_path, monkeypatch):
    """The out-of-memory killer took one of two workers (run 8 of the dev half): the study
    still writes its table and summary, the unfinished cases counted as failures.  Its
    workers run one case each (a fresh process, so a row's peak memory is its case's)."""
    import threading
    from concurrent.futures import Future
    from concurrent.futures.process import BrokenProcessPool

    class Killed:
        """The first case submitted ends; the second's process is killed."""

        def __init__(self, max_workers, **options):
            assert options == {"max_tasks_per_child": 1}
            self.submitted = 0

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def submit(self, run, name):
            future = Future()
            if self.submitted == 0:
                future.set_result(
                    study.Outcome(
                        name,
                        "hybrid",
                        "dev",
                        5e-4,
                        selected=("layerwise",),
                        rms_after=2e-4,
                        peak_rss_gb=1.234,
                    )
                )
            else:  # killed after the first has ended (a timer: as_completed waits on it)
                threading.Timer(
                    0.05, future.set_exception, [BrokenProcessPool("terminated abruptly")]
                ).start()
            self.submitted += 1
            return future

    monkeypatch.setattr(study, "ProcessPoolExecutor", Killed)
    names = ["blind04_hybrid", "blind05_cross_ply"]
    assert study.main(["--case", names[0], "--case", names[1], "--jobs", "2", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "blind_dev.json").read_text(), parse_constant=lambda c: 1 / 0)
    assert [c["case"] for c in data["cases"]] == names
    assert "killed" in data["cases"][1]["error"] and data["summary"]["dev"]["tracebacks"] == 1
    # the finished case's peak memory, the killed one's unknown, the largest in the summary
    assert [c["peak_rss_gb"] for c in data["cases"]] == [1.23, None]
    assert data["summary"]["dev"]["max_peak_rss_gb"] == 1.23


def test_the_3d_top_face_shapes_load_as_a_shapes_table_that_pairs_with_the_plate_model():
    """blind27 (a foam sandwich with a 2.83 g sensor on its base): its stored 3-D shapes
    are a SHAPES.csv table of 10 modes x 13 x 11 points per configuration, each mode named
    by the frequency its measurement row has (the 3-D one with the case's scatter), and
    the first mode's top-face shape is the plate model's paired mode at the true values
    (MAC >= 0.9).  A case without stored shapes gives None."""
    import numpy as np

    from fem.solver.mode_shapes import deflection_operator

    name = "blind27_sandwich"
    table = study.shapes_table(name)
    assert list(table.columns) == list(study.SHAPE_COLUMNS)
    case = study.load(name)
    assert len(table) == len(case["configurations"]) * 10 * 13 * 11
    assert study.shapes_table("blind01_hybrid") is None
    assert study.shapes_table(name, ["al_top"])["configuration"].unique().tolist() == ["al_top"]
    for conf in case["configurations"]:
        rows = table[table["configuration"] == conf["name"]]
        f3d = np.array([m["frequency_hz"] for m in conf["modes"]])
        measured = rows["frequency_hz"].unique()
        assert len(measured) == len(f3d) and np.all(np.abs(measured / f3d - 1) < 5 * study.NOISE_RANGE[1])
        first = rows[rows["frequency_hz"] == measured[0]]
        assert np.isclose(first["amplitude"].abs().max(), 1.0)
        paired = conf["modes"][0]["plate_mode"]
        solution = study.truth_model(case).with_options(modes=paired + 2).solve(conf["name"])
        w = (
            deflection_operator(
                solution.units, 1e-3 * first["x_mm"].to_numpy(), 1e-3 * first["y_mm"].to_numpy()
            )
            @ solution.modes.shapes[:, paired - 1]
        )
        a = first["amplitude"].to_numpy()
        assert (a @ w) ** 2 / ((a @ a) * (w @ w)) >= 0.9, conf["name"]


def test_the_halves_select_the_third_series_apart(monkeypatch, tmp_path):
    """'dev3' and 'heldout3' are the third series' halves: 'dev' and 'both' stay the first
    two series' (a run of the development half is the one it was), 'all' is every case."""
    (tmp_path / "index.json").write_text(
        json.dumps({"cases": {"blind04_hybrid": "dev", "blind25_hybrid": "heldout", "blind37_x": "dev3"}})
    )
    for name in ("blind04_hybrid", "blind25_hybrid", "blind37_x"):
        (tmp_path / f"{name}.json").write_text("{}")
    monkeypatch.setattr(study, "DATA", tmp_path)
    assert study.case_names("dev") == ["blind04_hybrid"]
    assert study.case_names("both") == ["blind04_hybrid", "blind25_hybrid"]
    assert study.case_names("dev3") == study.case_names("both3") == ["blind37_x"]
    assert study.case_names("all") == ["blind04_hybrid", "blind25_hybrid", "blind37_x"]


def test_the_summary_has_figures_per_family(tmp_path, monkeypatch):
    """The summary (JSON and text) gives the acceptance figures per family too; a third
    series half is summarised when it is run."""

    def recorded(name, progress=None):
        family = name.split("_", 1)[1]
        return study.Outcome(
            name,
            family,
            "dev3",
            5e-4,
            study.Oracle(2e-4, "thick_plate", 1.0, {}, ()),
            rms_after=2e-4 if family == "coating" else 1e-3,
            max_z=1.0,
            seconds=10.0,
            stack="coating",
        )

    monkeypatch.setattr(study, "run_case", recorded)
    names = ["blind39_coating", "blind44_coating", "blind51_sensor"]
    assert (
        study.main([*(x for n in names for x in ("--case", n)), "--half", "dev3", "--out", str(tmp_path)])
        == 0
    )
    data = json.loads((tmp_path / "blind_dev3.json").read_text())
    families = data["summary"]["dev3"]["families"]
    assert list(families) == ["coating", "sensor"]
    assert families["coating"]["cases"] == 2 and families["coating"]["rms_within_1.5_floor_pct"] == 100.0
    assert families["sensor"]["rms_within_1.5_floor_pct"] == 0.0
    assert data["cases"][2]["stack"] == "coating"
    assert "per family" in (tmp_path / "blind_dev3.txt").read_text()


def _record(case: dict) -> dict:
    """The parts of a stored record that the study's models read, from a draw."""
    layers = lambda key: [dict(material=m, thickness_mm=t, angle_deg=a) for m, t, a in case[key]]  # noqa: E731
    return dict(
        case=case["name"],
        family=case["family"],
        choices=dict(
            nominal_layers=layers("nominal_layers"),
            true_layers=layers("layers"),
            misalignment_max_deg=case["misalignment_max_deg"],
            sensor=None,
            stack=case["stack"],
            core=case["core"],
        ),
        materials={
            m: {k: generate._sig(v) for k, v in c.items() if k != "note"}
            for m, c in case["materials"].items()
        },
        truth_spec_toml=blind.truth_spec(dict(case, sensor=None)),
    )


@pytest.mark.parametrize("family", blind.STACKS_3)
def test_the_third_series_stacks_identify_their_layers(family):
    """The user's spec of a new family: every layer's in-plane constants identified (a
    coating's and its metal's both), a core's G13 and G23 instead (at the start drawn
    0.7-1.3 x, its E3 stated); lay-up tolerances on the plies with axes only (the skins, the
    angle plies: not a core, a metal or a coating); the truth at the true angles."""
    case = next(c for c in blind.draw_cases_3() if c["family"] == family)
    record = _record(case)
    start = study.start_model(record, np.random.default_rng(0))
    identified = {m.name: m.identify for m in start.specimen.identified_materials}
    expected = {
        m: ("G13", "G23") if m == case["core"] else ("E1", "E2", "G12", "nu12") for m, _, _ in case["layers"]
    }
    assert identified == expected
    with_axes = set(blind.WITH_AXES)
    angles = [i.target for i in start.input_std if i.kind == "angle"]
    assert angles == [layer.label for layer in start.specimen.layers if layer.material.name in with_axes]
    assert bool(angles) == (family in ("balsa_sandwich", "angle_ply") or case["misalignment_max_deg"] > 0)
    if case["core"] == "balsa_core":
        core = start.specimen.materials["balsa_core"]
        assert core.E3 == pytest.approx(1e9 * case["materials"]["balsa_core"]["E3"], rel=1e-6)
        assert 0.7 <= core.G13 / (1e9 * case["materials"]["balsa_core"]["G13"]) <= 1.3
    truth = study.truth_model(record)
    assert [math.degrees(layer.angle) for layer in truth.specimen.layers] == pytest.approx(
        [a for _, _, a in case["layers"]]
    )


def test_a_run_is_compared_with_a_stored_one_by_its_answer_not_its_path():
    """The same effects added in another order, and figures within the stored digits, are
    the same answer; one effect more, a ratio 0.02 off or a property that lost its std
    differ, each named."""
    earlier = {"selected": "thick_plate+point_mass+layerwise", "ratio": 0.52, "max_z": 1.08}
    row = {"selected": "thick_plate+layerwise+point_mass", "ratio": 0.5249, "max_z": 1.0749}
    assert study.changes(row, earlier) == {}
    row = {"selected": "layerwise+point_mass", "ratio": 0.54, "max_z": None}
    assert study.changes(row, earlier) == {
        "selected": ("thick_plate+point_mass+layerwise", "layerwise+point_mass"),
        "ratio": (0.52, 0.54),
        "max_z": (1.08, None),
    }


def test_the_stored_development_run_covers_the_half_and_a_run_is_said_against_it(tmp_path, monkeypatch):
    stored = study.load_run(study.RUNS / "dev.json")
    assert sorted(stored["cases"]) == study.case_names("dev")
    for name, case in stored["cases"].items():
        assert set(case) >= {"selected", "ratio", "max_z", "seconds", "commit"}, name
    earlier = stored["cases"]["blind24_sandwich"]

    def recorded(name, progress=None):
        oracle = study.Oracle(4.39e-4, "layerwise", 1.12, {"shear": (0.2, None)}, ("shear",))
        return study.Outcome(
            name,
            "sandwich",
            "dev",
            4.6e-4,
            oracle,
            selected=tuple(earlier["selected"].split("+")),
            rms_baseline=0.2,
            rms_after=earlier["ratio"] * 4.39e-4,
            max_z=earlier["max_z"],
            seconds=earlier["seconds"] / 2,
        )

    monkeypatch.setattr(study, "run_case", recorded)
    path = str(study.RUNS / "dev.json")
    assert study.main(["--case", "blind24_sandwich", "--out", str(tmp_path), "--against", path]) == 0
    against = json.loads((tmp_path / "blind_dev.json").read_text())["against"]
    assert against == {
        "run": "dev",
        "same": ["blind24_sandwich"],
        "differ": [],
        "not_stored": [],
        "median_time_ratio": 0.5,
        "changes": {},
    }


@pytest.mark.parametrize("half", ["heldout3", "heldout4", "heldout6"])
def test_the_held_out_series_tables_in_the_docs_are_the_stored_runs(half):
    """docs/diagnosis.md's heldout3, heldout4 and heldout6 tables count the rows of
    ``blind_runs/<half>.json`` (a case meets a criterion as the study's ``Outcome`` judges
    it: the true effects selected, RMS within ``FLOOR_RATIO`` x its floor, every property
    within ``Z_MAX`` std), so the published figures cannot drift from the runs.  (Not
    heldout5: its blind142's worst property is 3.0 in the rows, rounded, and 3.00x in the
    study's judgement.)"""
    stored = study.load_run(study.RUNS / f"{half}.json")["cases"]
    assert sorted(stored) == study.case_names(half)
    families = {
        "angle_ply": "angle ply",
        "balsa_sandwich": "balsa core",
        "coating": "coating",
        "sensor": "sensor",
        "thick_skins": "thick skins",
    }
    counts = {label: [0, 0, 0, 0] for label in (*families.values(), "all")}
    for name, row in stored.items():
        label = families[study.load(name)["family"]]
        for key in (label, "all"):
            counts[key][0] += 1
            counts[key][1] += row["contains_true"]
            counts[key][2] += row["ratio"] <= study.FLOOR_RATIO
            counts[key][3] += row["max_z"] <= study.Z_MAX
    text = (Path(__file__).resolve().parents[2] / "docs" / "diagnosis.md").read_text()
    table = text.split(f"**The held-out half ({half})")[1].split("\n\n")[1]
    for label, (n, selected, rms, properties) in counts.items():
        if label == "all":
            figures = [f"{k} ({round(100 * k / n)} %)" for k in (selected, rms, properties)]
        else:
            figures = [str(k) for k in (selected, rms, properties)]
        assert f"| {label} | {n} | " + " | ".join(figures) + " |" in table, label


def test_the_measurements_are_numbered_in_their_measured_order():
    """blind140's original configuration has two modes 0.04 % apart, and its 0.031 %
    scatter puts the higher below the lower: a lab numbers the peaks as it measures them,
    so the rows rise in frequency, and both of the pair carry their label (a neighbour
    within 1 %).  (Numbered by the 3-D order, the case was refused as input.)"""
    case, _, data = study.case_start("blind140_angle_ply")
    for name in data.configurations:
        assert np.all(np.diff(data.of(name)["frequency_hz"].to_numpy()) > 0), name
    original = data.of("original")
    three_d = [m["frequency_hz"] for m in case["configurations"][0]["modes"]]
    swapped = [k for k in range(len(three_d) - 1) if three_d[k + 1] / three_d[k] - 1 < 4.1e-4]
    assert swapped == [7]
    assert original["label"].iloc[7] and original["label"].iloc[8]
    assert original["label"].iloc[7] == case["configurations"][0]["modes"][8]["label"]
