"""The selection rules that make the diagnosis hold on plates it was not tuned on: an
implausible or singular estimate is never selected, whatever its criterion (it is
reported as a sign), and only an answer may keep another candidate from being refitted."""
from dataclasses import replace

import pytest

from fem.solver.attachments import PointMass
from identify.diagnosis.compare import compare
from identify.diagnosis.diagnose import Candidate, _candidate, _signs
from identify.fitting.driver import add_effect, point_mass_hints
from identify.fitting.precheck import Precheck
from identify.recordings.synthetic import synthetic_measurements
from studies.common import start_model, true_model


@pytest.fixture(scope="module")
def sensor_point_mass():
    """The paper's plate with a hidden 3 g sensor: the baseline and its point-mass
    candidate (plausible, a large BIC gain)."""
    truth = true_model().with_attachments([PointMass(3e-3, 0.125, 0.110)]).with_options(modes=8)
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=8, labels="close")
    model = start_model().with_options(modes=8)
    baseline = compare(model, data).fitted
    added = add_effect(baseline, "point_mass", data, model.specimen, point_mass_hints(baseline))
    return baseline, added


def test_a_plausible_identifiable_candidate_is_selectable(sensor_point_mass):
    baseline, added = sensor_point_mass
    c = _candidate(baseline, added)
    assert c.eligible and c.plausible and not c.singular and c.selectable
    assert c.scaled_gain > 10


def test_an_implausible_candidate_is_a_sign_not_an_answer(sensor_point_mass):
    """The same refit marked implausible: not selectable although its gain is large, and
    named as a sign of what is missing when the round stops or takes another effect."""
    baseline, added = sensor_point_mass
    c = _candidate(baseline, replace(added, implausible=("a point mass of 20 g is 9 % of the plate",)))
    assert c.eligible and not c.selectable
    sign = _signs([c], None)
    assert "point_mass would pay" in sign and "implausible, not taken" in sign and "shear" in sign


def test_a_candidate_singular_at_its_solution_is_not_selectable(sensor_point_mass):
    """A condition number at the solution beyond the paper's limit (1e7) and 1e3 x the
    start's without the effect (the issue's thickness estimate: 5e34) is not identifiable
    there: never selected, even though the start looked well conditioned."""
    baseline, added = sensor_point_mass
    well = Precheck(condition_number=50.0, base_condition_number=20.0, weakest="")
    fit = added.result
    singular_fit = replace(fit, uncertainty=replace(fit.uncertainty, condition_number=5e34))
    c = Candidate("thickness", "", replace(added, result=singular_fit, precheck=well), 100.0, 100.0)
    assert c.eligible and c.plausible and c.singular and not c.selectable
    assert "singular at its solution" in _signs([c], None)
    ok = Candidate("thickness", "", replace(added, precheck=well), 100.0, 100.0)
    assert not ok.singular
