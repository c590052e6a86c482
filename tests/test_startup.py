"""A fast start: the command lines import the heavy libraries only where a command uses
them (the times themselves are measured by ``benchmarks/startup.py``, not here)."""

import json
import subprocess
import sys

from fem.effect_kinds import BUILT_IN
from fem.effects import REGISTRY

HEAVY = (
    "scipy.stats",
    "scipy.sparse",
    "pandas",
    "matplotlib",
    "cvxpy",
    "sdypy",
    "pyuff",
    "nlopt",
    "distributed",
)


def loaded_after(code: str) -> dict:
    """The heavy libraries and project modules loaded in a fresh interpreter after ``code``."""
    probe = (
        f"{code}\nimport json, sys\n"
        f"print(json.dumps({{'heavy': [m for m in {HEAVY!r} if m in sys.modules], "
        "'project': sorted(m for m in sys.modules if m.split('.')[0] in ('fem', 'identify', 'designer'))}))"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    return json.loads(out.splitlines()[-1])


def test_version_and_help_load_no_heavy_library():
    loaded = loaded_after("import identify.cli, designer.cli")
    assert loaded["heavy"] == []
    assert (
        "identify.fitting.driver" not in loaded["project"]
        and "designer.search.ranking" not in loaded["project"]
    )


def test_predict_loads_only_the_solver():
    """``predict`` solves (scipy.sparse) but needs no statistics, tables or plots."""
    loaded = loaded_after("from identify.cli import main\nmain(['predict', '--json'])")
    assert loaded["heavy"] == ["scipy.sparse"]


def test_the_help_lists_every_built_in_effect():
    """The command lines' help names the effect kinds without importing them: the same
    kinds, in the same order, as the registry."""
    assert tuple(REGISTRY)[: len(BUILT_IN)] == BUILT_IN
