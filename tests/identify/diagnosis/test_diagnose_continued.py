"""A diagnosis whose best candidate has not converged within its iteration budget
continues it (it once failed there with an UnboundLocalError: a local named like the
``continued`` it called)."""

import importlib
import tomllib

from fem.spec import parse_spec
from identify.measurements import parse_measurements
from identify.recordings.synthetic import synthetic_measurements

from ...walk import SPEC

# the module (the package exports its function)
diagnosis = importlib.import_module("identify.diagnosis.diagnose")

#: The truth the data come from: the walk plate with a 6 g sensor the spec leaves out.
SENSOR = {"kind": "point_mass", "mass_g": 6.0, "x_mm": 120.0, "y_mm": 95.0}


def test_a_best_candidate_stopped_at_its_iteration_limit_is_continued():
    spec = tomllib.loads(SPEC)
    model = parse_spec(spec)
    truth = parse_spec({**spec, "effects": [SENSOR]})
    data = parse_measurements(synthetic_measurements(truth, modes=5, noise_rel=2e-4, seed=1).table, model)
    said = []
    one_iteration = diagnosis.SelectionPolicy(candidate_iterations=1)
    result = diagnosis.diagnose(
        model, data, ["point_mass", "rotary_inertia"], progress=said.append, policy=one_iteration
    )
    assert any(line.strip().startswith("continuing point_mass") for line in said), said
    assert [c.kind for c in result.selected] == ["point_mass"]


def test_every_round_and_refit_reports_its_time():
    """The report and ``--json`` carry each round's wall time and each candidate's refit
    time (where a slow diagnosis spends it), and the rounds' times add up to at most the
    whole (the baseline fit and the final refit are outside them)."""
    spec = tomllib.loads(SPEC)
    truth = parse_spec({**spec, "effects": [SENSOR]})
    model = parse_spec(spec)
    data = parse_measurements(synthetic_measurements(truth, modes=5, noise_rel=2e-4, seed=1).table, model)
    result = diagnosis.diagnose(model, data, ["point_mass", "rotary_inertia"])
    path = result.to_dict()["path"]
    timed = [r for r in path if r["candidates"]]
    assert timed and all(r["seconds"] > 0 for r in timed)
    assert all(c["seconds"] > 0 for r in timed for c in r["candidates"] if c["status"] != "not_applicable")
    assert sum(r["seconds"] for r in timed) <= result.seconds
    report = result.report()
    assert "refit s" in report
    assert (
        f"round 1: from the baseline (RMS {100 * result.baseline.rms_rel_error:.4f} %, "
        f"{path[0]['seconds']:.0f} s)" in report
    )
