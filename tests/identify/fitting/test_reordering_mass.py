"""A point mass heavy enough to reorder the plate's modes: the measured mode numbers are
the real plate's ranks, so its refit must not only follow the modes by shape from the
plate without it."""

import pytest

from fem.effects import effect
from fem.solver.attachments import PointMass
from identify.diagnosis.compare import compare
from identify.fitting.driver import Refit, _reorders, add_effect
from identify.recordings.synthetic import synthetic_measurements
from studies.common import true_model

#: 10 g (6.8 % of the paper's plate: heavier than plausible, which does not matter here)
#: near an edge: its modes 4 and 5 change places and modes 6-8 reorder (by MAC against the
#: plate without it).
SENSOR = PointMass(0.010, 0.075, 0.03)


@pytest.fixture(scope="module")
def without_the_sensor():
    """The paper's plate with the sensor, measured by rank (10 modes, 0.05 % scatter), and
    its layers fitted without it."""
    truth = true_model().with_attachments([SENSOR]).with_options(modes=10)
    data = synthetic_measurements(truth, modes=10, noise_rel=5e-4, seed=3)
    return compare(true_model().with_options(modes=10), data).fitted, data


def test_a_start_that_reorders_the_modes_is_seen(without_the_sensor):
    """At a start with the sensor's mass at its place, the modes followed by shape from the
    fit without it pair otherwise than by the measured ranks."""
    state, data = without_the_sensor
    hint = {"xy": (SENSOR.x, SENSOR.y), "mass_kg": SENSOR.mass}
    on = effect("point_mass").free(state.model, hint)[0]
    assert _reorders(on, list(state.parameters), state.pairings, data)
    assert not _reorders(
        effect("point_mass").free(state.model, {**hint, "mass_kg": 1e-6})[0],
        list(state.parameters),
        state.pairings,
        data,
    ), "a vanishing mass reorders nothing"


def test_the_point_mass_refit_finds_a_sensor_that_reorders_the_modes(without_the_sensor):
    """From the fit without it, the point-mass refit ends at the sensor or one of its
    images (the plate is square and its frequencies barely tell x from y: the mirror
    images and the diagonal's), its mass within 3 % (the scatter is 0.05 %).  A guard:
    the refit found it before the fresh pairing as well, from another start."""
    state, data = without_the_sensor
    added = add_effect(Refit(state, data, state.model.specimen), "point_mass", ())
    result = added.result
    values = {p.kind: result.value(p) for p in added.added}
    a, b = result.model.specimen.length, result.model.specimen.width
    images = [(x, y) for x in (SENSOR.x, a - SENSOR.x) for y in (SENSOR.y, b - SENSOR.y)]
    images += [(y, x) for x, y in images]
    assert values["mass"] == pytest.approx(SENSOR.mass, rel=0.03)
    assert min(abs(values["x"] - x) + abs(values["y"] - y) for x, y in images) < 0.005
