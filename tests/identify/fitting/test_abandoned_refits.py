"""A candidate's refit abandoned once it can no longer pay (``FitOptions.abandon_above``,
``add_effect(..., abandon_below=...)``): the start's pruning rule (the linearised bound
against what the candidate must explain) applied at every iterate of the refit."""

import math

import numpy as np
import pytest

from fem.solver.attachments import PointMass
from fem.specimen import Parameter
from identify import fit
from identify.engine.updating import Abandoned, FitOptions, Follow, Settle, update
from identify.fitting.driver import PruneBelow, Refit, add_effect, prepare_effect
from identify.fitting.precheck import Sensitivities
from identify.recordings.synthetic import synthetic_measurements
from studies.common import start_model, true_model

#: The paper's plate with an orthotropic core (E1/E2 = 5), so that a turned core shows.
CORE = {Parameter("E1", "steel"): 200e9, Parameter("E2", "steel"): 40e9, Parameter("G12", "steel"): 30e9}
CORE_ANGLE = Parameter("angle", "layer2")


@pytest.fixture(scope="module")
def turned_core():
    """Core turned by -6 deg, a 20 g sensor at (120, 120) mm (placed in the model): the
    data, the start model and the fit without orientation (the state a candidate adds to)."""
    sensor = [PointMass(20e-3, 0.120, 0.120)]
    truth = true_model().with_values({**CORE, CORE_ANGLE: math.radians(-6.0)}).with_attachments(sensor)
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=3, labels="close")
    model = start_model().with_values(CORE).with_attachments(sensor)
    return data, model, fit(model, data)


def test_a_refit_is_abandoned_where_its_linearised_end_stays_above_the_ceiling(turned_core):
    """After its first step, one Gauss-Newton step would leave the sum of squares that the
    pre-check's linearised refit predicts there (``Sensitivities``, an independent lstsq on
    the same evaluation; nothing is at a bound and no direction is null here, so the two
    agree to round-off, 1e-9 relative).  A ceiling just below it and the start's own
    linearised end abandons the refit at that iterate (1), before its next step is paid
    for: the start itself is not judged (the pre-check judges it).  (Far from the
    solution, the first step's linearised end is above the start's: 1.01e6 against
    8.1e5.)  The start's
    own sum of squares is a ceiling no iterate's linearised end can exceed (every accepted
    step descends): with it the refit is the one made without a ceiling, to the last digit."""
    data, model, _ = turned_core
    start = model.with_values({CORE_ANGLE: math.radians(3.0)})
    parameters = [Parameter(k, "steel") for k in ("E1", "E2", "G12")] + [CORE_ANGLE]
    one = update(start, data, parameters, FitOptions(max_iterations=1), follow=Follow(settle=Settle.NONE))
    there = start.with_values(dict(zip(parameters, one.values, strict=True)))
    predicted = Sensitivities.at_start(there, data, parameters, one.pairings).predicted_sum_squares(
        parameters
    )
    at_start = Sensitivities.at_start(start, data, parameters).predicted_sum_squares(parameters)
    with pytest.raises(Abandoned) as raised:
        update(start, data, parameters, FitOptions(abandon_above=0.999 * min(at_start, predicted)))
    assert raised.value.iteration == 1
    assert raised.value.linearised == pytest.approx(predicted, rel=1e-9)
    free = update(start, data, parameters)
    above = update(start, data, parameters, FitOptions(abandon_above=2 * free.history[0].cost))
    assert np.array_equal(free.values, above.values) and len(free.history) == len(above.history) > 2


def test_a_candidate_that_can_no_longer_pay_is_reported_not_refitted_to_the_end(turned_core):
    """The orientation candidate explains about 90 units of chi^2 here (its start's bound
    is 91).  Asked to explain ten times that, it is abandoned after its first step and
    reported as a pruned candidate (no fit, the reason and the figures in its error); asked
    for a tenth of
    it, its refit is the one made without the rule (every iterate's bound exceeds half of
    that), to the last digit."""
    data, model, state = turned_core
    prepared = prepare_effect(state, "orientation")
    refit = Refit(state, data, model.specimen)
    free = add_effect(refit, "orientation", prepared=prepared)
    explained = state.statistics.sum_squares - free.result.statistics.sum_squares
    assert 60 < explained < 120, explained
    out = add_effect(
        refit, "orientation", prepared=prepared, abandon_below=PruneBelow(10 * explained, "test")
    )
    assert out.result is None and out.pruned
    assert out.error.startswith("not refitted to the end: from its iterate 1 ")
    assert out.error.endswith(f"less than 1/2 of the {10 * explained:.4g} test")
    kept = add_effect(refit, "orientation", prepared=prepared, abandon_below=PruneBelow(0.1 * explained))
    assert np.array_equal(kept.result.values, free.result.values)


def test_a_point_mass_refit_is_never_abandoned(turned_core):
    """A point mass's starts' refits must finish to be told apart (its rivals): the rule does
    not apply to it, whatever the floor (here ten times the whole misfit of the fit it adds
    to: the sensor left out of the model, the core's angle too)."""
    data, model, _ = turned_core
    bare = model.with_attachments([])
    state = fit(bare, data)
    refit = Refit(state, data, bare.specimen, FitOptions(max_iterations=3))
    out = add_effect(refit, "point_mass", abandon_below=PruneBelow(10 * state.statistics.sum_squares))
    assert out.result is not None and not out.pruned


def test_after_an_abandoned_start_each_other_start_is_refitted_once(turned_core, monkeypatch):
    """The screened start's refit abandoned (forced at its first call), the other start (the
    angles turned the other way) is refitted, once, even where it too ends worse than the
    state (forced): the search over the other starts that follows a refit ending worse has
    been made already.  The note says which start and why."""
    from identify.fitting import driver

    data, model, state = turned_core
    prepared = prepare_effect(state, "orientation")
    assert len(prepared.others) == 1
    fitted, real = [], Refit.fit

    def first_abandoned(self, start, parameters, pairings):
        fitted.append(start)
        if len(fitted) == 1:
            raise Abandoned(1, 2 * state.statistics.sum_squares)
        return real(self, start, parameters, pairings)

    monkeypatch.setattr(Refit, "fit", first_abandoned)
    monkeypatch.setattr(driver, "ended_worse", lambda result, state: True)
    floor = PruneBelow(1.0, "test")
    out = add_effect(
        Refit(state, data, model.specimen), "orientation", prepared=prepared, abandon_below=floor
    )
    assert [m is prepared.model for m in fitted] == [True, False] and fitted[1] is prepared.others[0]
    assert out.result is not None and not out.pruned
    assert any(
        n.startswith("the refit from the screened start was abandoned at its iterate 1") for n in out.notes
    )
