"""A campaign of bad and odd inputs, tried as a new user would: each once ended in a
traceback or a silent wrong result; now each ends in a one-line error naming the value and
the fix, or in a correct result, or is warned about where the user looks."""

import json
import math
import os
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from designer.cli import main as plan_tests
from designer.store import SolveStore
from fem.errors import MeasurementError, OptionsError, SpecError
from fem.io import REPORT_MARK
from fem.model import ModelOptions
from fem.spec import load_spec, parse_spec
from identify.cli import main as identify_layers
from identify.engine.updating import FitOptions
from identify.measurements import parse_measurements

from .walk import check_report, run, write_files

ROOT = Path(__file__).parent.parent


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return write_files(tmp_path_factory.mktemp("campaign"))


def one_line_error(result, *fragments):
    assert result.code == 2, (result.code, result.err[-1500:])
    lines = result.err.strip().splitlines()
    assert lines[-1].startswith("error:") and "Traceback" not in result.err, result.err[-1500:]
    for fragment in fragments:
        assert fragment in lines[-1], lines[-1]
    return lines[-1]


# --- the API ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "options,fragment",
    [
        (dict(modes=0), "ModelOptions.modes = 0"),
        (dict(modes=-2), "ModelOptions.modes = -2"),
        (dict(modes=5.5), "ModelOptions.modes = 5.5"),
        (dict(divisions=1), "ModelOptions.divisions = 1"),
    ],
)
def test_model_options_out_of_range(options, fragment):
    with pytest.raises(OptionsError, match=fragment.replace(".", r"\.")):
        ModelOptions(**options)


@pytest.mark.parametrize(
    "options,fragment",
    [
        (dict(max_iterations=-5), "FitOptions.max_iterations = -5"),
        (dict(parameter_tolerance=math.nan), "FitOptions.parameter_tolerance = nan"),
        (dict(max_log_step=0.0), "FitOptions.max_log_step = 0"),
    ],
)
def test_fit_options_out_of_range(options, fragment):
    with pytest.raises(OptionsError, match=fragment.replace(".", r"\.")):
        FitOptions(**options)


def test_parse_spec_of_none():
    with pytest.raises(SpecError, match="need the parsed TOML document"):
        parse_spec(None)


def test_measurements_as_rows(files):
    """A list of row dicts is a table; a peak list longer than the modes a model can
    match is refused at once (it ran out of memory after a minute)."""
    model = load_spec(files.spec)
    parsed = parse_measurements([{"configuration": "original", "frequency_hz": 183.8}], model)
    assert len(parsed) == 1 and not parsed.ranked
    many = pd.DataFrame({"configuration": "original", "frequency_hz": np.linspace(50, 5000, 10_000)})
    with pytest.raises(MeasurementError, match="has 10000 peaks without mode numbers; at most 60"):
        parse_measurements(many, model)


# --- report folders ---------------------------------------------------------------------


def test_report_into_the_current_folder_is_refused(files, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    one_line_error(
        run(identify_layers, ["fit", files.spec, files.measurements["labelled"], "--report", "."]),
        "is the current folder",
    )
    assert list(tmp_path.iterdir()) == [] and list(tmp_path.parent.glob(f".{tmp_path.name}.*")) == []


def test_two_reports_into_one_folder_at_once(files, tmp_path):
    """Two fits into the same report folder, the second started while the first runs:
    both end cleanly and the folder holds one whole report."""
    folder = tmp_path / "report"
    argv = [
        sys.executable,
        "-m",
        "identify.cli",
        "fit",
        str(files.spec),
        str(files.measurements["labelled"]),
        "--report",
        str(folder),
    ]
    first = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    time.sleep(0.8)
    second = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    errors = [p.communicate(timeout=300)[1].decode() for p in (first, second)]
    assert [first.returncode, second.returncode] == [0, 0], errors
    check_report(folder)
    assert (folder / "report.html").exists() and (folder / REPORT_MARK).exists()


# --- plan-tests -------------------------------------------------------------------------


def test_write_spec_onto_the_input_spec_is_refused(files, tmp_path):
    spec = tmp_path / "plate.toml"
    spec.write_text("# my notes\n" + files.spec.read_text())
    before = spec.read_text()
    one_line_error(run(plan_tests, ["recommend", spec, "--write-spec", spec]), "that is the input spec")
    assert spec.read_text() == before


def test_sweep_with_an_empty_value_list_is_refused(files, tmp_path):
    one_line_error(
        run(plan_tests, ["sweep", files.spec, "--vary", "thickness=", "--out", tmp_path / "sweep"]),
        "no values after '='",
    )


def test_corrupt_cache_entries_are_solved_again(tmp_path):
    store = SolveStore(tmp_path)
    key = ("laminate", 1.0)
    store.put(key, (np.array([100.0]), None, np.eye(1)))
    path = store._path(key)
    for damage in (b"", path.read_bytes()[:40], b"not a zip at all"):
        path.write_bytes(damage)
        assert store.get(key) is None
    assert not zipfile.is_zipfile(path)


def test_a_cache_that_cannot_be_written_is_only_a_lost_speed_up(tmp_path, monkeypatch):
    import designer.store as store_module

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    store = SolveStore(tmp_path)
    monkeypatch.setattr(store_module.tempfile, "mkstemp", refuse)
    store.put(("k",), (np.array([1.0]), None, np.eye(1)))
    assert store.written == 0 and "cannot be written (Permission denied)" in store.failed


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_cache_folder(files, tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    cache.chmod(0o555)
    try:
        result = run(
            plan_tests,
            ["sweep", files.spec, "--cache", cache, "--vary", "thickness=0.5,1", "--out", tmp_path / "sweep"],
        )
        assert result.code == 0 and "is read-only" in result.err
    finally:
        cache.chmod(0o755)


# --- silent results of the fit ----------------------------------------------------------


def test_a_scatter_that_determines_nothing_is_not_converged(files, tmp_path):
    """std_hz = 1000 on every row: the frequencies fit, but every std exceeds its value;
    it once said "converged" with "warnings: none"."""
    table = pd.read_csv(files.measurements["labelled"]).assign(std_hz=1000.0)
    table.to_csv(tmp_path / "std.csv", index=False)
    result = run(identify_layers, ["fit", files.spec, tmp_path / "std.csv"])
    assert result.code == 1
    assert "not identifiable" in result.out and "determines none of the parameters" in result.out


def test_an_overstated_scatter_is_warned_about(files, tmp_path):
    """std_hz 30 x the real scatter: converged, and the warnings say the std are too large."""
    table = pd.read_csv(files.measurements["labelled"])
    table.assign(std_hz=30 * table["std_hz"]).to_csv(tmp_path / "std.csv", index=False)
    result = run(identify_layers, ["fit", files.spec, tmp_path / "std.csv"])
    assert result.code == 0 and "is std_hz overstated?" in result.out


# --- recordings -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def hits(files):
    return [pd.read_csv(path) for path in files.recordings]


def write(tmp_path, frames):
    paths = []
    for i, frame in enumerate(frames):
        paths.append(tmp_path / f"hit{i + 1}.csv")
        frame.to_csv(paths[-1], index=False)
    return paths


def test_an_all_zero_force_channel(hits, tmp_path):
    paths = write(tmp_path, [hits[0].assign(force=0.0)])
    one_line_error(run(identify_layers, ["peaks", *paths]), "the force channel is flat")


def test_time_in_milliseconds(hits, tmp_path):
    paths = write(tmp_path, [hits[0].assign(time_s=1000 * hits[0]["time_s"])])
    one_line_error(run(identify_layers, ["peaks", *paths]), "is the time column in ms?")


def test_the_same_hit_given_several_times_is_refused(files):
    one_line_error(run(identify_layers, ["peaks", *[files.recordings[0]] * 5]), "holds the same samples as")


def test_a_clipped_response_is_refused(hits, tmp_path):
    """A clipped channel is never silently used: every hit whose response holds its limit
    is rejected, naming the channel, and with every hit clipped ``peaks`` stops in one line."""
    clipped = [
        h.assign(
            acceleration=h["acceleration"].clip(
                -0.2 * h["acceleration"].abs().max(), 0.2 * h["acceleration"].abs().max()
            )
        )
        for h in hits
    ]
    one_line_error(run(identify_layers, ["peaks", *write(tmp_path, clipped), "--json"]), "response clipped")
    clean = run(identify_layers, ["peaks", *write(tmp_path, hits), "--json"])
    assert clean.code == 0 and not any("clipped" in note for note in json.loads(clean.out)["notes"])


# --- plan-tests advice --------------------------------------------------------------------


@pytest.mark.parametrize(
    "length,width,cut",
    [(0.300, 0.015, (18.0, 15.0)), (0.150, 0.120, (144.0, 120.0)), (0.150, 0.200, (150.0, 125.0))],
)
def test_poisson_plate_advice_never_needs_a_larger_plate(length, width, cut):
    """Eq. 16 with length/width = 1.2: the plate to cut fits inside the one there is (a
    300 x 15 mm strip was told to become 300 x 299.5 mm)."""
    from designer.scores.poisson import PoissonPlate

    plate = PoissonPlate(length, width, 1.2)
    got = tuple(1e3 * v for v in plate.cut_to)
    assert got == pytest.approx(cut) and got[0] <= 1e3 * length + 1e-9 and got[1] <= 1e3 * width + 1e-9
    assert got[0] / got[1] == pytest.approx(1.2)
    assert f"cut it to {cut[0]:.1f} x {cut[1]:.1f} mm" in plate.report()


def test_a_point_mass_heavier_than_the_plate_is_refused(files):
    """A 1 t 'sensor' on a 141 g plate (the walk plate) was solved without a word."""
    import tomllib

    spec = tomllib.loads(files.spec.read_text())
    spec["effects"] = [{"kind": "point_mass", "mass_g": 1e6, "x_mm": 100.0, "y_mm": 50.0}]
    with pytest.raises(SpecError, match=r"mass_g = 1e\+06 g is more than the plate itself \(141.3 g\)"):
        parse_spec(spec)
    spec["effects"][0]["mass_g"] = 6.0
    assert parse_spec(spec).specimen.attachments[0].mass == pytest.approx(6e-3)


def test_ctrl_c_while_the_command_loads_is_one_line(monkeypatch, capsys):
    """Ctrl-C in the first second of ``fit`` (while its modules load) gave a
    KeyboardInterrupt traceback; the entry points load them inside the interrupt handling."""
    from identify import entry

    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr(entry, "import_module", interrupted)
    assert entry.identify_layers() == 130 and entry.plan_tests() == 130
    assert capsys.readouterr().err == "interrupted\ninterrupted\n"


def _blas_threads() -> list[int]:
    from threadpoolctl import threadpool_info

    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_commands_run_with_one_blas_thread(monkeypatch):
    """A 60-mode fit spent 21 % of its time in shape comparisons whose BLAS product took
    270 ms instead of 35 ms while the other core was busy (a second BLAS thread waits for
    it): the console scripts run the whole command on one BLAS thread."""
    from types import SimpleNamespace

    from identify import entry

    seen = []

    def command():
        seen.extend(_blas_threads())
        return 0

    monkeypatch.setattr(entry, "import_module", lambda name: SimpleNamespace(main=command))
    assert entry.identify_layers() == 0
    assert seen and set(seen) == {1}


def test_fit_and_diagnose_run_with_one_blas_thread():
    """Through the API too (studies, notebooks, the test suite's parallel workers): two
    diagnoses side by side on two cores took 148 s each with BLAS's default threads, 121 s
    with one.  Seen from inside the run (its progress calls), and restored after it."""
    import identify
    from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED

    model = identify.load_spec(COATED_PLATE)
    data = identify.load_measurements(COATED_PLATE_MEASURED, model)
    before, seen = _blas_threads(), []
    identify.fit(model, data, progress=lambda _: seen.extend(_blas_threads()))
    identify.diagnose(model, data, ["rotary_inertia"], progress=lambda _: seen.extend(_blas_threads()))
    assert seen and set(seen) == {1}
    assert _blas_threads() == before


def test_refit_workers_run_with_one_blas_thread():
    """The spawned processes that run a diagnosis's candidates and a point mass's starts
    (``worker_pool``) limit themselves: they are where two processes share the cores."""
    from identify.fitting.driver import worker_pool

    with worker_pool(1) as pool:
        seen = pool.submit(_blas_threads).result()
    assert seen and set(seen) == {1}


@pytest.mark.parametrize("command", [["predict", "--modes", "30"], ["predict"]])
def test_output_into_a_closed_pipe_is_not_a_traceback(command):
    """``identify-layers peaks rec.wav | head -4`` ended in a BrokenPipeError traceback
    (a long output fails in a print, a short one at the interpreter's final flush)."""
    child = subprocess.Popen(
        [sys.executable, "-m", "identify.cli", *command],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    child.stdout.close()  # the reader is gone before the command writes
    err = child.stderr.read().decode()
    assert child.wait(timeout=120) in (0, 1), err
    assert "Traceback" not in err and "Exception ignored" not in err, err


def test_a_huge_poisson_ratio_is_one_line():
    """Found by the property test: nu12 = 1.34e154 overflowed squaring it in the
    positive-definiteness check (OverflowError instead of the spec error)."""
    import tomllib

    from identify.examples import COATED_PLATE

    spec = tomllib.loads(COATED_PLATE.read_text())
    spec["materials"]["adhesive"]["nu12"] = 1.3407807929942597e154
    with pytest.raises(SpecError, match="not positive definite"):
        parse_spec(spec)
