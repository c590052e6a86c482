"""Every command ends cleanly: each command of both tools on the inputs a lab hands in
(labelled, ranks with a gap, a bare peak list with missing and spurious peaks, one
configuration, mixed-up configurations, frequencies in the wrong unit), with text, --json
and --report output: exit status 0, 1 or 2, no traceback, strict JSON, a report folder
whole or absent, CSV without NaN.  The cross product is sampled: every input meets
``fit --json``, every output meets the labelled and peak-list inputs, every other command
meets the inputs that stress it.  The --effect kinds are walked in test_walk_effects.py."""

import pytest

from designer.cli import main as plan_tests
from identify.cli import main as identify_layers

from .walk import check_clean_end, run, strict_json, write_files

INPUTS = ("labelled", "gap", "peaks", "one_configuration", "mixed_up", "kHz")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return write_files(tmp_path_factory.mktemp("walk"))


def walk(main, argv, tmp_path=None, report=False):
    argv = list(argv)
    json_out = "--json" in argv
    folder = None
    if report:
        folder = tmp_path / "report"
        argv += ["--report", folder]
    result = run(main, argv)
    check_clean_end(result, argv, folder, json_out)
    return result


@pytest.mark.parametrize("output", ["text", "--json"])
def test_predict(files, output):
    result = walk(identify_layers, ["predict", files.spec] + ([output] if output != "text" else []))
    assert result.code == 0


@pytest.mark.parametrize("measured", INPUTS)
def test_fit_json_on_every_input(files, measured):
    """The status says what happened: the labelled, gap and peak-list inputs converge to
    the true steel; the kHz file and the mixed-up configurations do not pass as converged."""
    result = walk(identify_layers, ["fit", files.spec, files.measurements[measured], "--json"])
    if measured in ("labelled", "gap", "peaks"):
        data = strict_json(result.out)
        assert result.code == 0 and data["status"] == "converged", result.err[-1500:]
        assert data["materials"]["steel"]["E1_GPa"] == pytest.approx(205, rel=5e-3)
    if measured in ("mixed_up", "kHz"):
        assert result.code != 0


@pytest.mark.parametrize("measured", ["labelled", "peaks"])
@pytest.mark.parametrize("output", ["text", "--report"])
def test_fit_outputs(files, tmp_path, measured, output):
    argv = ["fit", files.spec, files.measurements[measured]]
    result = walk(identify_layers, argv, tmp_path, report=output == "--report")
    assert result.code == 0
    if output == "--report":
        names = {p.name for p in (tmp_path / "report").iterdir()}
        assert {"report.html", "fit.json", "parameters.csv", "residuals.csv"} <= names


def test_peak_list_residual_rows_are_null_not_nan(files):
    """A spurious peak's row: matched false, no model mode, no model frequency, no error,
    and a note naming the nearest mode."""
    rows = strict_json(walk(identify_layers, ["fit", files.spec, files.measurements["peaks"], "--json"]).out)[
        "residuals"
    ]
    left_out = [r for r in rows if not r["matched"]]
    assert sorted(r["measured_hz"] for r in left_out) == [60.0, 560.0]
    assert all(r["mode"] is None and r["model_hz"] is None and r["rel_error"] is None for r in left_out)
    assert all(r["note"].startswith("left out: matches no model mode (nearest: mode") for r in left_out)
    assert all(isinstance(r["mode"], int) and r["note"] == "" for r in rows if r["matched"])


@pytest.mark.parametrize(
    "measured,output",
    [("labelled", "--json"), ("peaks", "--json"), ("gap", "text"), ("peaks", "--report"), ("kHz", "--json")],
)
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_compare(files, tmp_path, measured, output):
    """A valid input is compared, whatever its fit's status: exit 0 or 1, never the
    error exit 2 (the kHz file fits the wrong plate and says so, it is not an error)."""
    argv = ["compare", files.spec, files.measurements[measured]] + ([output] if output == "--json" else [])
    result = walk(identify_layers, argv, tmp_path, report=output == "--report")
    assert result.code in (0, 1), result.err[-1500:]


@pytest.mark.parametrize("measured,output", [("peaks", "--report"), ("labelled", "--json")])
def test_diagnose(files, tmp_path, measured, output):
    """A valid input is diagnosed: exit 0 or 1, never the error exit 2."""
    argv = ["diagnose", files.spec, files.measurements[measured], "--effects", "rotary_inertia,adhesive"]
    argv += ["--json"] if output == "--json" else []
    result = walk(identify_layers, argv, tmp_path, report=output == "--report")
    assert result.code in (0, 1), result.err[-1500:]


@pytest.mark.parametrize("output", ["text", "--json", "--report"])
def test_peaks(files, tmp_path, output):
    argv = ["peaks", *files.recordings, "--spec", files.spec, "--out", tmp_path / "peaks.csv"]
    argv += ["--json"] if output == "--json" else []
    result = walk(identify_layers, argv, tmp_path, report=output == "--report")
    assert result.code == 0
    assert (tmp_path / "peaks.csv").exists()


@pytest.mark.parametrize(
    "argv",
    [["check"], ["check", "--json"], ["recommend", "--json"], ["recommend"]],
    ids=["check", "check --json", "recommend --json", "recommend"],
)
def test_plan_tests(files, argv):
    result = walk(plan_tests, [argv[0], files.spec, *argv[1:]])
    assert result.code in (0, 1)


def test_plan_tests_sweep_report(files, tmp_path):
    folder = tmp_path / "sweep"
    argv = ["sweep", files.spec, "--no-cache", "--vary", "thickness=0.5,1", "--out", folder]
    result = run(plan_tests, argv)
    check_clean_end(result, argv, folder)
    assert result.code == 0 and (folder / "summary.md").exists() and (folder / "sweep.csv").exists()


def test_recommend_writes_a_spec_that_fits(files, tmp_path):
    written = tmp_path / "best.toml"
    walk(plan_tests, ["recommend", files.spec, "--no-cache", "--write-spec", written])
    assert walk(identify_layers, ["predict", written, "--json"]).code == 0
