"""The spec reference (docs/spec.md) and the spec validator cannot drift apart.

The key sets the validator accepts are recorded where it checks them (every call of
``check_keys`` while a spec that reaches every table is loaded, and every registered
effect's keys); the reference's are read from its tables, one table per section. A key
in one and not the other fails, and so does a key of the bundled spec the reference
does not give.
"""

import re
import sys
import tomllib
from pathlib import Path

import pytest

import fem.design_space
import fem.spec
from fem.effects import REGISTRY
from identify.examples import COATED_PLATE

DOC = Path(__file__).parent.parent / "docs" / "spec.md"


def documented() -> dict[str, set[str]]:
    """Section id (the first `code` of a heading) -> the keys in its table's `key` column.
    The effects table has a `kind` column: its rows go to ``[[effects]] kind = 'KIND'``."""
    out: dict[str, set[str]] = {}
    section = None
    columns: list[str] = []
    for line in DOC.read_text().splitlines():
        heading = re.match(r"#+ .*?`([^`]+)`", line)
        if heading:
            section, columns = heading.group(1), []
            continue
        if section is None or not line.startswith("|"):
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[0] in ("key", "kind"):
            columns = cells
            continue
        if set(cells[0]) <= set("-: "):
            continue
        row = dict(zip(columns, cells, strict=True))
        key = row.get("key", "").strip("`")
        if "kind" in row:
            kind = row["kind"].strip("`")
            out.setdefault(f"[[effects]] kind = '{kind}'", set()).update({"kind"} | ({key} if key else set()))
        else:
            out.setdefault(section, set()).add(key)
    return out


def normalise(where: str) -> str:
    """A validator location as the reference names its table."""
    where = re.sub(r"\[materials\.[^\]]+\]", "[materials.NAME]", where)
    where = re.sub(r"\[\[configurations\]\]\[\d+\]\.(top|bottom)\[\d+\]", "[specimen].layers", where)
    where = re.sub(r"\[\d+\]", "", where)
    return where


def accepted(monkeypatch) -> dict[str, set[str]]:
    """Every key set the validator checks while loading a spec that reaches every table
    (the bundled spec with bounds and target_std_rel added), plus the effects' keys."""
    seen: dict[str, set[str]] = {}

    def recording(original):
        def check_keys(table, allowed, where, *args):
            seen.setdefault(normalise(where), set()).update(allowed)
            return original(table, allowed, where, *args)

        return check_keys

    for module in (fem.spec, fem.design_space):
        monkeypatch.setattr(module, "check_keys", recording(module.check_keys))
    data = tomllib.loads(Path(COATED_PLATE).read_text())
    data["materials"]["steel"]["bounds"] = {"nu12": [0.0, 0.6]}
    data["design"]["target_std_rel"] = {"E": 0.02}
    fem.spec.parse_spec(data)
    for kind, effect in REGISTRY.items():
        seen[f"[[effects]] kind = '{kind}'"] = set(effect.keys) | {"kind"}
    return seen


def test_every_table_of_the_validator_is_documented_key_for_key(monkeypatch):
    validator, reference = accepted(monkeypatch), documented()
    expected_tables = {
        "spec",
        "[specimen]",
        "[specimen].layers",
        "[materials.NAME]",
        "[materials.NAME].bounds",
        "[[configurations]]",
        "[model]",
        "[design]",
        "[design].target_std_rel",
    }
    assert expected_tables <= set(validator), (
        f"the spec used here no longer reaches: {expected_tables - set(validator)}"
    )
    for table in sorted(set(validator) | set(reference)):
        assert table in reference, f"{table} is validated but has no section in docs/spec.md"
        assert table in validator, f"docs/spec.md documents {table}, which the validator does not check"
        missing, extra = validator[table] - reference[table], reference[table] - validator[table]
        assert not missing, f"{table}: keys accepted but not documented in docs/spec.md: {sorted(missing)}"
        assert not extra, (
            f"{table}: keys documented in docs/spec.md but refused by the validator: {sorted(extra)}"
        )


def test_every_key_of_the_bundled_spec_is_documented():
    reference = documented()
    data = tomllib.loads(Path(COATED_PLATE).read_text())
    used: set[tuple[str, str]] = {("spec", key) for key in data}
    used |= {("[specimen]", key) for key in data["specimen"]}
    used |= {("[specimen].layers", key) for layer in data["specimen"]["layers"] for key in layer}
    for table in data["materials"].values():
        used |= {("[materials.NAME]", key) for key in table}
    for configuration in data["configurations"]:
        used |= {("[[configurations]]", key) for key in configuration}
        used |= {
            ("[specimen].layers", key)
            for side in ("top", "bottom")
            for layer in configuration.get(side, [])
            for key in layer
        }
    used |= {("[model]", key) for key in data["model"]} | {("[design]", key) for key in data["design"]}
    missing = sorted(f"{table}.{key}" for table, key in used if key not in reference.get(table, set()))
    assert not missing, f"keys of the bundled spec missing from docs/spec.md: {missing}"


def test_the_check_fails_on_a_missing_key(monkeypatch, tmp_path):
    """The comparison can fail: a reference without one key is caught."""
    text = DOC.read_text()
    monkeypatch.setattr(sys.modules[__name__], "DOC", tmp_path / "spec.md")
    (tmp_path / "spec.md").write_text(text.replace("| `E3_GPa` |", "| `E3_GPa_typo` |"))
    with pytest.raises(AssertionError, match="E3_GPa"):
        test_every_table_of_the_validator_is_documented_key_for_key(monkeypatch)


@pytest.mark.parametrize(
    "key",
    ["bounds", "E1_GPa_std", "thickness_mm_std", "theory", "layer_groups", "E3_GPa", "identify", "mass_g"],
)
def test_keys_added_since_the_first_release_are_described(key):
    assert f"| `{key}` |" in DOC.read_text()
