"""The plate's images that keep its frequencies (``ambiguity.exact_images``): the turn by
180 deg and the mirrors about the mid-lines, named in a fit's notes where a free sensor
or free ply angles make them a different state.  Each image is checked by a full solve."""

import math

import numpy as np
import pytest

from fem.solver.attachments import PointMass, Suspension
from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.engine.ambiguity import PLATE_IMAGES, exact_images
from identify.engine.objective import Objective
from identify.engine.updating import FitOptions, Follow, Settle, update
from identify.reporting.diagnosis_report import refit_lines
from tests.fem.test_reduced_basis import SANDWICH
from tests.identify.engine.test_trial_screen import measured_modes

SENSOR = [Parameter("mass", "sensor"), Parameter("x", "sensor"), Parameter("y", "sensor")]
SKIN_ANGLE = Parameter("angle", "layer1")


def _model(skin_angle_deg: float = 0.0):
    """The first-order-shear sandwich (250 x 200 mm) with a 4 g sensor on a 10 mm base at
    (80, 60) mm, its bottom skin turned by ``skin_angle_deg``."""
    model = (
        parse_spec(SANDWICH)
        .with_options(transverse_shear=True, rotary_inertia=True, modes=8)
        .with_attachments([PointMass(0.004, 0.08, 0.06, "sensor", base=0.01)])
    )
    return model.with_values({SKIN_ANGLE: math.radians(skin_angle_deg)})


@pytest.mark.parametrize(
    "skin_angle_deg, free, expected",
    [
        (0.0, SENSOR, 3),  # a 0/90 lay-up: the turn and both mirrors move the sensor
        (30.0, SENSOR, 1),  # a fixed 30 deg ply: a mirror would turn it; the 180 deg turn does not
        (30.0, SENSOR + [SKIN_ANGLE], 3),  # the ply free: the mirrors negate it
        (0.0, SENSOR[:1], 0),  # the sensor's position known: every image would move it
    ],
    ids=["cross_ply", "fixed_angle", "free_angle", "fixed_sensor"],
)
def test_each_image_has_the_same_frequencies(skin_angle_deg, free, expected):
    """Every image ``exact_images`` names is a full solve away from the state's
    frequencies by round-off only (1e-9 relative; measured 4e-12 to 2e-11: the mesh, its
    sensor base included, is the image of the state's), and it names no other."""
    model = _model(skin_angle_deg)
    hz = model.solve("original").frequencies_hz
    objective = Objective(model, measured_modes(model, hz), free)
    values = np.array([model.value(p) for p in free])
    images = exact_images(objective, values)
    assert len(images) == expected
    for _, image in images:
        moved = model.with_values(dict(zip(free, image))).solve("original").frequencies_hz
        assert moved == pytest.approx(hz, rel=1e-9)
        assert not np.allclose(image, values)


def test_a_fit_names_the_images_of_its_sensor():
    """A point mass fitted from 20 mm off the truth ends at the sensor; its notes name the
    three images with the sensor's coordinates there (170 mm, 140 mm), since the
    frequencies cannot tell them from the state given."""
    truth = _model()
    hz = truth.solve("original").frequencies_hz
    start = truth.with_values({SENSOR[1]: 0.1, SENSOR[2]: 0.07})
    result = update(start, measured_modes(truth, hz), SENSOR, FitOptions(), follow=Follow(settle=Settle.NONE))
    assert result.values[1:] == pytest.approx([0.08, 0.06], abs=1e-4)
    (note,) = [w for w in result.warnings if "by the plate's symmetry" in w]
    assert "turned by 180 deg (sensor.x = 170 mm, sensor.y = 140 mm)" in note
    assert "about y = W/2 (sensor.y = 140 mm)" in note and "about x = L/2 (sensor.x = 170 mm)" in note
    # The result carries them, and the diagnosis's summary and the JSON show them from there.
    images = dict(result.images)
    assert list(images) == [name for name, *_ in PLATE_IMAGES]
    turned = images["the plate turned by 180 deg"]
    assert turned[0] == result.values[0] and turned[1:] == pytest.approx([0.25 - 0.08, 0.2 - 0.06], abs=1e-4)
    assert f"  - {note}" in refit_lines(result, ["point_mass"])
    shown = {entry["image"]: entry["values"] for entry in result.to_dict()["images"]}
    mirrored = {"sensor.x": pytest.approx(80.0, abs=0.1), "sensor.y": pytest.approx(140.0, abs=0.1)}  # mm
    assert shown["its mirror image about y = W/2"] == mirrored  # where the sensor is there; not its mass


@pytest.mark.parametrize(
    "points, expected",
    [
        (((0.05, 0.05), (0.2, 0.15)), "the plate turned by 180 deg"),  # the turn maps each onto the other
        (((0.05, 0.05), (0.2, 0.05)), "its mirror image about x = L/2"),  # only the x mirror does
    ],
)
def test_suspension_points_that_map_onto_themselves_keep_an_image(points, expected):
    """Springs (50 N/m) at two points: only the image that maps the pair onto itself is
    named, and it is a full solve away by round-off (measured 1.5e-11 and 5.6e-11)."""
    model = _model()
    model = model.with_attachments(list(model.specimen.attachments) + [Suspension(50.0, points)])
    hz = model.solve("original").frequencies_hz
    objective = Objective(model, measured_modes(model, hz), SENSOR)
    values = np.array([model.value(p) for p in SENSOR])
    ((name, image),) = exact_images(objective, values)
    assert name == expected
    moved = model.with_values(dict(zip(SENSOR, image))).solve("original").frequencies_hz
    assert moved == pytest.approx(hz, rel=1e-9)
