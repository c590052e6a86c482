"""The JSON reference (docs/json.md) and the commands' `--json` cannot drift apart: each
command runs on the bundled example, and every key path it prints must be on the page,
and every top-level key the page gives must be printed. (Nested keys of lists that are
empty on the bundled example, e.g. the rounds of a diagnosis at the noise level, are
checked where a test produces them.)"""

import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from designer.cli import main as plan_tests
from identify.cli import main as identify_layers
from identify.examples import COATED_PLATE
from identify.recordings.tap_simulation import (
    Modes,
    RovingSetup,
    Session,
    TapOptions,
    roving_hits,
    write_csv,
    write_roving,
)

DOC = Path(__file__).parent.parent / "docs" / "json.md"
MATERIALS = set(tomllib.loads(Path(COATED_PLATE).read_text())["materials"])
PROPERTY = re.compile(r"^(E1|E2|E3|G12|G13|G23|nu12|density)(_GPa|_kg_m3|_-)?$")


def documented() -> dict[str, set[str]]:
    """Command (the heading's code, without --json) -> the key paths of its table."""
    out: dict[str, set[str]] = {}
    command = None
    for line in DOC.read_text().splitlines():
        heading = re.match(r"## `(.+?) --json`", line)
        if heading:
            command = heading.group(1)
            out[command] = set()
        elif command and re.match(r"\| `[^`]+` \|", line):
            out[command].add(line.split("`")[1])
    return out


def paths(value, prefix: str = "") -> set[str]:
    """Every key path of a JSON document, names replaced as the page writes them."""
    found = set()
    if isinstance(value, dict):
        for key, item in value.items():
            if key in MATERIALS or prefix.endswith("effects"):
                key = "NAME"
            elif prefix.endswith("excluded"):
                key = "CANDIDATE"
            elif PROPERTY.match(key):
                key = "KEY"
            elif "." in key and key.split(".")[0] in MATERIALS:  # history[]: "steel.E1_GPa"
                key = "NAME.KEY"
            path = f"{prefix}.{key}" if prefix else key
            found |= {path} | paths(item, path)
    elif isinstance(value, list):
        for item in value:
            found |= paths(item, prefix + "[]")
    return found


def _roving_test(folder: Path) -> list[str]:
    """A small roving-hammer test on disk (two modes of a 100 x 60 mm plate, 3 x 2 points,
    two hits each): the arguments of ``peaks --points``."""
    points = pd.DataFrame(
        {
            "point": [f"P{k}" for k in range(6)],
            "x_mm": [10.0, 50.0, 90.0] * 2,
            "y_mm": [10.0] * 3 + [50.0] * 3,
        }
    )
    shapes = [lambda x, y: np.cos(np.pi * x / 100), lambda x, y: np.cos(np.pi * y / 60) + 0.2 * x / 100]
    hits = roving_hits(
        [300.0, 520.0],
        [0.01, 0.01],
        shapes,
        points,
        RovingSetup((20.0, 15.0), hits=2, seed=1, options=TapOptions(sample_rate=4000.0, duration_s=1.0)),
    )
    write_roving(hits, folder)
    points.to_csv(folder / "points.csv", index=False)
    return ["--points", str(folder / "points.csv"), "--band", "150", "900"]


def run(command: str, tmp_path, capsys) -> dict:
    program, *args = command.split()
    if args == ["peaks", "--points"]:
        args = ["peaks", *_roving_test(tmp_path)]
    if args == ["peaks"]:
        modes = Modes(
            np.array([129.2, 191.6, 238.8]), np.array([0.005, 0.006, 0.008]), np.array([1.0, -0.7, 0.4])
        )
        for i, hit in enumerate(Session(modes, n_hits=3, seed=3, double_hits=(1,)).hits()):
            write_csv(hit, tmp_path / f"hit{i + 1}.csv")
            args.append(str(tmp_path / f"hit{i + 1}.csv"))
    main = identify_layers if program == "identify-layers" else plan_tests
    main([*args, "--json"])
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("command", sorted(documented()))
def test_every_key_printed_is_documented_and_back(command, tmp_path, capsys):
    doc = documented()[command]
    printed = paths(run(command, tmp_path, capsys))
    implied = {p[: m.start()] for p in doc for m in re.finditer(r"\.|\[\]", p)}  # a.b.c documents a.b
    missing = sorted(printed - doc - implied)
    assert not missing, f"{command} --json prints keys docs/json.md does not give: {missing}"
    top_doc = {p for p in doc if "." not in p and "[]" not in p}
    top_printed = {p for p in printed if "." not in p and "[]" not in p}
    assert top_doc == top_printed, f"{command}: documented only {sorted(top_doc - top_printed)}"


def test_every_command_is_documented():
    assert set(documented()) == {
        "identify-layers predict",
        "identify-layers peaks",
        "identify-layers peaks --points",
        "identify-layers fit",
        "identify-layers compare",
        "identify-layers diagnose",
        "plan-tests check",
        "plan-tests recommend",
    }
