"""The command walk's inputs and checks: a small plate (one identified steel sheet, a brass
plate bonded on top, 5 modes, a 6-element mesh: each fit takes a second or two) with the
measurement files a lab hands in, and one run of a command line checked for a clean end."""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from fem.io import REPORT_MARK
from fem.spec import load_spec
from fem.specimen import Parameter
from identify.recordings.synthetic import synthetic_measurements
from identify.recordings.tap_simulation import Modes, Session, write_csv

SPEC = """
[specimen]
name = "walk plate"
length_mm = 150.0
width_mm = 120.0
layers = [ { material = "steel", thickness_mm = 1.0 } ]

[materials.steel]
E1_GPa = 190.0
E2_GPa = 185.0
G12_GPa = 75.0
nu12 = 0.3
density_kg_m3 = 7850
identify = true

[materials.brass]
E1_GPa = 100.0
E2_GPa = 100.0
G12_GPa = 37.31
nu12 = 0.34
density_kg_m3 = 8500

[materials.adhesive]
E1_GPa = 3.0
E2_GPa = 3.0
G12_GPa = 1.111
nu12 = 0.35
density_kg_m3 = 1200

[[configurations]]
name = "original"

[[configurations]]
name = "brass_top"
top = [ { material = "adhesive", thickness_mm = 0.05 }, { material = "brass", thickness_mm = 1.0 } ]

[model]
modes = 5
divisions = 6

[design]
materials = ["brass"]
thicknesses_mm = [0.5, 1.0]
placements = ["top", "bottom"]
adhesive = { material = "adhesive", thickness_mm = 0.05 }
configurations = 2
frequency_std_rel = 0.001
"""

#: The steel the virtual measurements come from (the spec starts 2-7 % off).
TRUTH = {"E1": 205e9, "E2": 200e9, "G12": 79e9, "nu12": 0.29}


def _inputs(spec: Path) -> dict[str, pd.DataFrame]:
    """Measurement tables a lab hands in, made from the true steel with 0.05 % scatter."""
    model = load_spec(spec)
    truth = model.with_values({Parameter(kind, "steel"): v for kind, v in TRUTH.items()})
    ranked = synthetic_measurements(truth, modes=5, noise_rel=5e-4, seed=5).table
    ranked = ranked[["configuration", "mode", "frequency_hz", "std_hz"]]
    labels = {c: truth.solve(c).labels for c in ("original", "brass_top")}
    labelled = ranked.assign(
        label=[labels[c][m - 1] for c, m in zip(ranked["configuration"], ranked["mode"])]
    )
    peaks = pd.concat(
        [
            ranked.drop(index=[2, 8]).drop(columns="mode"),  # a node at the sensor: 2 modes missing
            pd.DataFrame(
                {
                    "configuration": ["original", "brass_top"],
                    "frequency_hz": [60.0, 560.0],
                    "std_hz": [0.05, 0.3],
                }
            ),
        ]
    )  # suspension and cable: 2 spurious peaks
    swapped = ranked.assign(
        configuration=ranked["configuration"].map({"original": "brass_top", "brass_top": "original"})
    )
    return {
        "labelled": labelled,
        "gap": ranked.drop(index=[2]),  # original mode 3 not measured
        "peaks": peaks,
        "one_configuration": ranked[ranked["configuration"] == "original"],
        "mixed_up": swapped,  # the two configurations' rows exchanged
        "kHz": ranked.assign(frequency_hz=ranked["frequency_hz"] / 1000, std_hz=ranked["std_hz"] / 1000),
    }


@dataclass(frozen=True)
class Files:
    spec: Path
    measurements: dict[str, Path]
    recordings: list[Path]


def write_files(folder: Path) -> Files:
    spec = folder / "plate.toml"
    spec.write_text(SPEC)
    measurements = {}
    for name, table in _inputs(spec).items():
        measurements[name] = folder / f"{name}.csv"
        table.to_csv(measurements[name], index=False)
    modes = Modes(
        np.array([183.8, 232.2, 376.6]), np.array([0.005, 0.006, 0.008]), np.array([1.0, -0.7, 0.4])
    )
    recordings = []
    for i, hit in enumerate(Session(modes, n_hits=3, seed=3).hits()):
        recordings.append(folder / f"hit{i + 1}.csv")
        write_csv(hit, recordings[-1])
    return Files(spec, measurements, recordings)


def _reject_constant(name: str):
    raise ValueError(f"{name} in JSON output")


def strict_json(text: str):
    """Parse JSON, refusing NaN and Infinity (which Python's json module accepts)."""
    return json.loads(text, parse_constant=_reject_constant)


#: 'nan' or 'inf' printed as a word (not inside 'information' or 'infinite').
NON_FINITE_WORD = re.compile(r"(?<![\w.])-?(nan|inf)(?!\w)", re.IGNORECASE)


@dataclass(frozen=True)
class Run:
    code: int
    out: str
    err: str


def run(main, argv: list) -> Run:
    """A command line run in this process: exit code, stdout, stderr.  Any exception that
    escapes (a traceback for the user) fails the test with it."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse: --help, usage errors
            code = exc.code if isinstance(exc.code, int) else 2
    return Run(code, out.getvalue(), err.getvalue())


def check_clean_end(result: Run, argv: list, report: Path | None = None, json_out: bool = False) -> None:
    """A clean end: exit 0, 1 or 2; no traceback; a bad input is one line 'error: ...';
    JSON that a strict parser reads; a report folder complete (marked, its JSON strict,
    its CSV without NaN) or not there at all, with no leftovers beside it."""
    where = " ".join(map(str, argv))
    assert result.code in (0, 1, 2), (where, result.code, result.err[-2000:])
    assert "Traceback" not in result.err, (where, result.err[-2000:])
    if result.code == 2:
        errors = [line for line in result.err.splitlines() if line.startswith("error:")]
        assert len(errors) == 1 and result.err.rstrip().endswith(errors[0]), (where, result.err[-2000:])
    elif json_out:
        strict_json(result.out)
    else:  # the text a user reads: a missing value is '-' or blank, with its reason beside it
        assert not NON_FINITE_WORD.search(result.out), (
            where,
            NON_FINITE_WORD.search(result.out),
            result.out[-3000:],
        )
    if report is not None:
        check_report(report, where)


def check_report(folder: Path, where: str = "") -> None:
    leftovers = list(folder.parent.glob(f".{folder.name}.*"))
    assert not leftovers, (where, leftovers)
    if not folder.exists():
        return
    assert (folder / REPORT_MARK).exists(), (where, sorted(p.name for p in folder.iterdir()))
    for path in folder.iterdir():
        if path.suffix == ".json":
            strict_json(path.read_text())
        if path.suffix == ".csv":
            assert not finite_csv_problems(path), (where, path.name, finite_csv_problems(path))
        if path.suffix == ".txt":
            assert not NON_FINITE_WORD.search(path.read_text()), (where, path)
        if path.suffix == ".html":
            text = path.read_text()
            assert not re.search(r">\s*-?(nan|inf|infinity)\s*<", text, re.IGNORECASE), (where, path)
            assert not re.search(r">\s*None\s*<", text), (where, path)


def finite_csv_problems(path: Path) -> list[str]:
    """Cells of a CSV that read as NaN or infinity (blank cells are allowed: a value that
    does not exist)."""
    table = pd.read_csv(path, keep_default_na=False, dtype=str)
    bad = []
    for column in table.columns:
        for cell in table[column]:
            try:
                value = float(cell)
            except ValueError:
                if cell.strip().lower() in ("nan", "inf", "-inf", "infinity", "none", "null"):
                    bad.append(f"{column}={cell}")
                continue
            if not math.isfinite(value):
                bad.append(f"{column}={cell}")
    return bad
