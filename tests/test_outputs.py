"""Outputs that never half-exist: report folders written whole, interrupted
runs that leave the previous report or none, a resumable sweep, and bad output paths
refused in one line before any work."""

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from designer import problem as planner
from designer.cli import main as plan_tests
from designer.store import SolveStore
from fem.io import REPORT_MARK
from identify.cli import main as identify_layers

ROOT = Path(__file__).parent.parent


def spawn(tool: str, *argv, env=None) -> subprocess.Popen:
    module = {"identify-layers": "identify.cli", "plan-tests": "designer.cli"}[tool]
    return subprocess.Popen(
        [sys.executable, "-m", module, *map(str, argv)],
        cwd=ROOT,
        env={**os.environ, **(env or {})},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )


def wait_for(condition, process, timeout=120.0):
    """Poll until ``condition()`` holds (or the process ends or time runs out)."""
    start = time.monotonic()
    while time.monotonic() - start < timeout and process.poll() is None:
        if condition():
            return True
        time.sleep(0.01)
    return False


def contents(folder: Path) -> dict[str, str]:
    """File name -> SHA-256 of every file of a report folder (cheap to compare and to show)."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()}


def temporaries(folder: Path) -> list[Path]:
    return list(folder.parent.glob(f".{folder.name}.tmp-*")) + list(
        folder.parent.glob(f".{folder.name}.old-*")
    )


@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_interrupted_fit_report_leaves_the_previous_one(tmp_path, signal_number):
    """A complete report, then a second fit --report into the same folder interrupted
    while it writes: the previous report is still there, whole (its files unchanged); after
    SIGINT no temporary folder is left, after SIGKILL the next clean run clears them."""
    folder = tmp_path / "report"
    assert identify_layers(["fit", "--report", str(folder)]) == 0
    before = contents(folder)
    assert REPORT_MARK in before and "report.html" in before
    process = spawn("identify-layers", "fit", "--report", folder)
    assert wait_for(lambda: temporaries(folder), process), "the run reached its report"
    process.send_signal(signal_number)
    process.wait(timeout=60)
    now = contents(folder)
    # The previous report, whole; or, when the signal came after the swap had begun (SIGINT
    # waits for its two renames), the new one, whole: never a half or a missing report.
    assert now == before or (set(now) == set(before) and process.returncode in (0, 130)), sorted(now)
    if signal_number == signal.SIGINT:
        assert process.returncode in (0, 130) and temporaries(folder) == []
    assert identify_layers(["fit", "--report", str(folder)]) == 0
    assert temporaries(folder) == [] and (folder / "report.html").exists()


def test_a_second_report_replaces_the_first_whole(tmp_path, capsys):
    """A file an earlier report wrote (listed in its mark) does not survive the next one;
    a file the user put in the folder makes the next run refuse, and it is kept."""
    folder = tmp_path / "report"
    assert identify_layers(["fit", "--report", str(folder)]) == 0
    (folder / "stale.png").write_bytes(b"old")
    with open(folder / REPORT_MARK, "a") as mark:  # as if an earlier run (with --effect) had written it
        mark.write("- stale.png\n")
    assert identify_layers(["fit", "--report", str(folder)]) == 0
    assert not (folder / "stale.png").exists()
    (folder / "notes.txt").write_text("mine")
    capsys.readouterr()
    assert identify_layers(["fit", "--report", str(folder)]) == 2
    assert "holds files this tool did not write (notes.txt)" in capsys.readouterr().err
    assert (folder / "notes.txt").read_text() == "mine" and (folder / "report.html").exists()


def test_killed_sweep_resumes_solving_only_what_is_missing(tmp_path, monkeypatch):
    """SIGKILL while a sweep solves (serially, storing each solve as it completes); the
    rerun solves only the configurations missing from the store, and a third run none."""
    cache, out = tmp_path / "cache", tmp_path / "sweep"
    argv = ["sweep", "--out", out, "--vary", "thickness=0.5:3:40", "--workers", "1", "--cache", cache]
    process = spawn("plan-tests", *argv)
    assert wait_for(lambda: len(list(cache.glob("*.npz"))) >= 8, process), process.stderr.read().decode()
    process.kill()
    process.wait(timeout=60)
    stored = len(list(cache.glob("*.npz")))
    assert not out.exists(), "the sweep was killed while solving, before its report"
    solved = []
    original = planner.solve_pairs

    def counting(*args):
        solved.extend(args[-1])
        return original(*args)

    monkeypatch.setattr(planner, "solve_pairs", counting)
    planner._CACHE.clear()
    assert plan_tests([str(a) for a in argv]) == 0
    total = len(list(cache.glob("*.npz")))
    assert 0 < stored < total and len(solved) == total - stored
    assert temporaries(out) == [] and (out / "sweep.csv").exists()
    assert list(cache.glob(".*.tmp")) == []
    planner._CACHE.clear()
    solved.clear()
    assert plan_tests([str(a) for a in argv]) == 0 and solved == []


@pytest.mark.parametrize("target", ["file", "foreign", "below_a_file"])
def test_bad_report_paths_are_refused_before_work(tmp_path, capsys, target):
    """An existing file, a folder that is not a report of this tool (its files are left
    alone), and a path below a file: one line, exit 2, nothing touched."""
    path = tmp_path / "out"
    if target == "file":
        path.write_text("keep")
    elif target == "foreign":
        path.mkdir()
        (path / "notes.txt").write_text("keep")
    else:
        (tmp_path / "file").write_text("keep")
        path = tmp_path / "file" / "report"
    for tool, argv in (
        (identify_layers, ["fit", "--report", str(path)]),
        (plan_tests, ["sweep", "--out", str(path), "--no-cache"]),
    ):
        assert tool(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: report folder") and err.count("\n") == 1
    if target == "file":
        assert path.read_text() == "keep"
    if target == "foreign":
        assert (path / "notes.txt").read_text() == "keep" and len(list(path.iterdir())) == 1


def test_store_entries_round_trip(tmp_path):
    import numpy as np

    store = SolveStore(tmp_path)
    key = ("laminate", 1.5, ("brass",))
    result = (np.array([100.0, 200.0]), ("(1,1)", "(0,2)-(2,0)"), np.eye(2))
    store.put(key, result)
    f, labels, s = SolveStore(tmp_path).get(key)
    assert labels == result[1] and np.array_equal(f, result[0]) and np.array_equal(s, result[2])
    assert store.get(("another",)) is None
