"""Images with the same frequencies, given the way the spec states the axes
(``ambiguity.as_stated``).  A ply material's E1 <-> E2 with every ply of it turned by 90
deg is the same laminate; every angle negated is the plate mirrored about y = W/2.  The
frequencies cannot choose; the spec's stiff direction and lay-up can."""

import math

import numpy as np
import pytest

from fem.solver.attachments import PointMass
from fem.specimen import Parameter
from identify.engine.ambiguity import as_stated, exact_images, images_note, mirror_image, turned_axes
from identify.engine.objective import Objective
from identify.fitting.plausibility import implausible
from identify.recordings.synthetic import synthetic_measurements
from studies.common import true_model

#: The paper's plate with an orthotropic core (E1/E2 = 5) turned 20 deg.
CORE = {
    Parameter("E1", "steel"): 200e9,
    Parameter("E2", "steel"): 40e9,
    Parameter("G12", "steel"): 30e9,
    Parameter("angle", "layer2"): math.radians(20.0),
}
FREE = [Parameter(k, "steel") for k in ("E1", "E2", "G12", "nu12")] + [Parameter("angle", "layer2")]


def _objective(truth, parameters):
    """The fit's objective on noisy data of ``truth``, started at the truth with the core
    turned 23 deg (the orientation refit's start: nominal + 3 deg)."""
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=4)
    start = truth.with_values({Parameter("angle", "layer2"): math.radians(23.0)})
    return Objective(start, data, parameters)


def _tie(objective, values: np.ndarray) -> str:
    """The note a fit ending at ``values`` adds on the images it cannot tell apart (``update``)."""
    return images_note(objective.parameters, values, exact_images(objective, values))


@pytest.fixture(scope="module")
def objective():
    return _objective(true_model().with_values(CORE), FREE)


def _truth(objective):
    return np.array([true_model().with_values(CORE).value(p) for p in objective.parameters])


def test_the_turned_axes_are_the_same_laminate(objective):
    """The physics the rule rests on: E1 <-> E2, nu12 -> nu21 and the core +90 deg give every
    frequency of every configuration to the solver's round-off (1e-9 relative; a turn that
    missed nu21 or the angle would move them by percents)."""
    truth = _truth(objective)
    turned = turned_axes(objective, truth, "steel")
    assert turned[0] == pytest.approx(40e9) and turned[1] == pytest.approx(200e9)
    assert math.degrees(turned[4]) == pytest.approx(-70.0)
    a, b = objective.evaluate(truth, None), objective.evaluate(turned, None)
    assert np.allclose(a.model_hz, b.model_hz, rtol=1e-9, atol=0)


def test_a_fit_ended_across_the_stated_axes_is_given_along_them(objective):
    """A state at the turned twin (E1 40 < E2 200 GPa where the spec says E1 > E2) comes
    back as the truth's values, to round-off, with its misfit unchanged and a note; the
    mirror image of the twin (the angle negated as well) comes back the same way, the angle
    nearer the start's 23 deg, with a second note; the fit's note on its images names the
    mirror image of the answer (-20 deg), which the frequencies cannot tell from it."""
    truth = _truth(objective)
    for state, notes in (
        (turned_axes(objective, truth, "steel"), 1),
        (mirror_image(objective, turned_axes(objective, truth, "steel")), 2),
    ):
        e = objective.evaluate(state, None)
        stated, said, image = as_stated(objective, e)
        assert np.allclose(stated.values, truth, rtol=1e-12, atol=1e-12)
        assert np.allclose(image(state), truth, rtol=1e-12, atol=1e-12)
        assert objective.cost(stated) == pytest.approx(objective.cost(e), rel=1e-6)
        assert len(said) == notes and "axes turned by 90 deg" in said[0]
        assert "mirror image about y = W/2 (layer2.angle = -20 deg)" in _tie(objective, stated.values)


def test_no_image_without_every_ply_free_to_turn():
    """With the core's angle known (not free) the turned twin is another laminate: a state
    with E1 < E2 is given as it is (the fit's answer, whatever the spec says)."""
    objective = _objective(true_model().with_values(CORE), FREE[:4])
    swapped = _truth(objective)[[1, 0, 2, 3]]
    e = objective.evaluate(swapped, None)
    stated, said, _ = as_stated(objective, e)
    assert stated is e and said == []


def test_a_mirror_that_changes_the_frequencies_is_not_taken():
    """A 20 g sensor off the mirror line (y = 30 mm of 150): the core at -20 deg is not the
    plate at +20 deg mirrored, so the state at -20 deg stays, although +20 deg is nearer the
    start (its misfit differs by far more than ``SAME_MISFIT``)."""
    truth = true_model().with_values(CORE).with_attachments([PointMass(20e-3, 0.120, 0.030)])
    objective = _objective(truth, FREE)
    minus = _truth(objective)
    minus[4] = -minus[4]
    e = objective.evaluate(minus, None)
    stated, said, _ = as_stated(objective, e)
    assert stated is e and said == []


def test_a_ply_at_90_deg_keeps_its_state_and_a_180_deg_turn_is_no_turn():
    """blind35 (a cross-ply, every ply free to turn): its 90 deg ply fitted at 90.93 deg
    and the mirror image's -90.93 deg (the ply at 89.07 deg) lie equally near the spec's
    90 deg; on that tie the fit's own state stays (round-off had taken the mirror), a
    note naming the image the frequencies cannot tell from it, and the plausibility rule
    counts the turn modulo 180 deg: -90.93 deg is 0.93 deg from 90 deg, not 181 (which had
    refused a paying orientation as implausible)."""
    at_90 = {**CORE, Parameter("angle", "layer2"): math.radians(90.0)}
    truth = true_model().with_values(at_90)
    objective = Objective(truth, synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=4), FREE)
    state = _truth(objective)
    state[4] = math.radians(90.93)
    e = objective.evaluate(state, None)
    stated, said, _ = as_stated(objective, e)
    assert stated is e and said == []
    assert "about y = W/2 (layer2.angle = 89.07 deg)" in _tie(objective, stated.values)
    nominal = truth.specimen
    angle = [Parameter("angle", "layer2")]
    for degrees, plausible in ((-90.93, True), (270.5, True), (-84.0, False), (96.0, False)):
        fitted = nominal.with_values({angle[0]: math.radians(degrees)})
        assert (implausible(angle, fitted, nominal) == ()) is plausible, degrees
