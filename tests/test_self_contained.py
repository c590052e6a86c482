"""The repository documents itself: no tracked file points to a folder outside it (the
team's notes, a sibling checkout) or to a tracker number a user cannot see."""

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent
# Built from parts so that this file does not match itself.
OUTSIDE = re.compile(
    "|".join(
        [
            r"\.\./" + "shared",
            "shared" + " folder",
            "shared" + "/",
            "DESIGN" + r"\.md",
            r"\bissues? #?\d+",
            r"/" + "work/",
        ]
    ),
    re.I,
)


def tracked_files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [ROOT / name for name in out.decode().split("\0") if name]


def test_no_file_refers_outside_the_repository_or_to_a_tracker():
    found = []
    for path in tracked_files():
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue  # binary data
        for number, line in enumerate(text.splitlines(), 1):
            if OUTSIDE.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}")
    assert not found, "references outside the repository:\n" + "\n".join(found)


def test_the_pattern_catches_what_it_should():
    """The check can fail: each kind of reference it looks for is caught."""
    for line in (
        "see DESIGN" + ".md",
        "the team's shared" + " folder",
        "(iss" + "ue 12)",
        "Iss" + "ues 4 and 11",
        "../" + "shared" + "/reference",
        "/" + "work/" + "shared" + "/seed",
    ):
        assert OUTSIDE.search(line), line
    assert not OUTSIDE.search("a shared bond line; tissue 3")
