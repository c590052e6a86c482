"""Shared fixtures: the reference data and the paper's plate (Table 1 properties)."""

import json
from pathlib import Path

import pytest

from fem.spec import load_spec
from fem.specimen import Parameter
from identify.examples import COATED_PLATE

DATA = Path(__file__).parent / "data"
GPA = 1e9


def reference(name: str) -> dict:
    return json.loads((DATA / name).read_text())


PAPER = reference("paper_tables.json")
FREE_PLATES = reference("free_plates.json")
#: Table 1 names -> the example spec's material names.
PAPER_MATERIALS = {"top_coating": "top_coating", "steel": "steel", "bottom_coating": "bottom_coating"}


def table1_values() -> dict:
    """Parameter -> true value (SI) of the paper's Table 1."""
    out = {}
    for name, props in PAPER["table1_layer_properties"].items():
        if name == "units":
            continue
        for kind in ("E1", "E2", "G12"):
            out[Parameter(kind, PAPER_MATERIALS[name])] = props[kind] * GPA
        out[Parameter("nu12", PAPER_MATERIALS[name])] = props["nu12"]
    return out


@pytest.fixture(autouse=True, scope="session")
def private_solve_cache(tmp_path_factory):
    """plan-tests keeps solves in $XDG_CACHE_HOME: the tests' own, not the user's."""
    import os

    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.mktemp("xdg_cache"))
    yield


@pytest.fixture(scope="session")
def example_spec():
    """The bundled example as shipped (Table 6 start values)."""
    return load_spec(COATED_PLATE)


@pytest.fixture(scope="session")
def paper_model(example_spec):
    """The paper's plate with its true (Table 1) properties and three configurations."""
    return example_spec.with_values(table1_values())


@pytest.fixture(scope="session")
def paper_specimen(paper_model):
    return paper_model.specimen
