"""The shear theories' stated accuracy against 3-D elasticity (``SHEAR_THEORY_STD_REL``)
is the stored validation's figure, taken from development cases only."""

import json

import numpy as np

from fem.model import SHEAR_THEORY_STD_REL, ModelOptions
from studies import blind_diagnosis as bd
from tests.conftest import DATA

RECORD = json.loads((DATA / "solid3d" / "theory_accuracy.json").read_text())


def test_the_stated_accuracy_is_the_validations_rms():
    """The constant is the RMS over every mode of every development case without a sensor
    of the layerwise theory's error at the true values, to the two digits it is written
    with (a sensor's point mass has errors of its own, kept apart)."""
    plain = [c for c in RECORD["cases"].values() if not c["sensor"]]
    assert len(plain) == RECORD["summary"]["layerwise"]["cases"] > 20
    every = np.concatenate([np.array(c["layerwise"]["errors_pct"]) for c in plain]) / 100
    rms = float(np.sqrt(np.mean(every**2)))
    assert f"{SHEAR_THEORY_STD_REL:.2g}" == f"{rms:.2g}"
    assert RECORD["summary"]["layerwise"]["rms_pct"] == round(100 * rms, 4)


def test_no_held_out_case_calibrates_it():
    """Every development case is in the record, and no held-out one: the held-out halves
    test the std it widens."""
    development = set(bd.case_names("dev")) | set(bd.case_names("dev3"))
    assert set(RECORD["cases"]) == development
    assert all(c["half"] in ("dev", "dev3") for c in RECORD["cases"].values())


def test_only_a_shear_theory_carries_it():
    assert ModelOptions().theory_std_rel == 0.0
    assert ModelOptions(transverse_shear=True).theory_std_rel == SHEAR_THEORY_STD_REL
    assert ModelOptions(theory="layerwise").theory_std_rel == SHEAR_THEORY_STD_REL


def test_the_independent_std_covers_what_the_theory_does():
    """``theory_independence.json`` (made by the script beside it): the theory's own
    per-mode error vectors, propagated through the linear fit of each development case
    without a sensor, shift the properties by this many of the theory's std.  An honest
    std makes them N(0, 1) or tighter: RMS at most 1 and no more beyond 2 than a normal
    variable's 4.6 %.  (Measured: RMS 0.55 over 166 properties, one beyond 2, blind90's E1
    at 2.42.)  The record must be made with the constant as it stands."""
    record = json.loads((DATA / "solid3d" / "theory_independence.json").read_text())
    assert record["theory_std_rel"] == SHEAR_THEORY_STD_REL
    assert set(record["cases"]) == {n for n, c in RECORD["cases"].items() if not c["sensor"]}
    z = np.array([v[0] for c in record["cases"].values() for v in c.values()])
    assert z.size == record["summary"]["properties"] > 100
    assert np.sqrt(np.mean(z**2)) <= 1.0
    assert np.mean(np.abs(z) > 2) <= 0.046
