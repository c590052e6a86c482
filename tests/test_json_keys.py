"""The command lines' JSON documents keep every key they had (new keys are allowed):
the key paths on the bundled example against those recorded in ``data/cli_json_keys.json``
before the package was reorganised."""

import json

import pytest

from designer.cli import main as plan_tests
from identify.cli import main as identify_layers
from tests.conftest import DATA

RECORDED = json.loads((DATA / "cli_json_keys.json").read_text())
COMMANDS = {
    "identify-layers predict": (identify_layers, ["predict"]),
    "identify-layers fit": (identify_layers, ["fit"]),
    "identify-layers compare": (identify_layers, ["compare"]),
    "identify-layers diagnose": (identify_layers, ["diagnose"]),
    "identify-layers fit --effect point_mass": (identify_layers, ["fit", "--effect", "point_mass"]),
    "plan-tests check": (plan_tests, ["check"]),
    "plan-tests recommend": (plan_tests, ["recommend"]),
}


def key_paths(value, prefix: str = "") -> set[str]:
    """Every key of a JSON document as a path: ``a.b`` for nested tables, ``a[].b`` inside lists."""
    if isinstance(value, dict):
        return (
            set().union(
                *(
                    {f"{prefix}.{k}" if prefix else k} | key_paths(v, f"{prefix}.{k}" if prefix else k)
                    for k, v in value.items()
                )
            )
            if value
            else set()
        )
    if isinstance(value, list):
        return set().union(set(), *(key_paths(v, prefix + "[]") for v in value))
    return set()


def test_every_command_is_recorded():
    assert set(RECORDED) == set(COMMANDS)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_json_keys_unchanged(command, capsys):
    main, argv = COMMANDS[command]
    main(argv + ["--json"])
    now = key_paths(json.loads(capsys.readouterr().out))
    missing = sorted(set(RECORDED[command]) - now)
    assert not missing, f"{command} --json lost keys: {missing}"
