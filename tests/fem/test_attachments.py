"""Point masses and suspension springs: physics checks and exact derivatives."""
import numpy as np
import pytest

from fem.solver.attachments import PointMass, Suspension
from fem.errors import SpecError
from fem.model import ModelOptions, SpecimenModel
from fem.specimen import Parameter

OPTIONS = ModelOptions(modes=6, divisions=8)
CORNERS = ((0.015, 0.015), (0.135, 0.015), (0.135, 0.135), (0.015, 0.135))


@pytest.fixture(scope="module")
def plate(paper_specimen):
    return paper_specimen.with_configurations(paper_specimen.configurations[:2])


def frequencies(specimen):
    return np.concatenate(list(SpecimenModel(specimen, OPTIONS).frequencies().values()))


def test_mass_on_a_nodal_point_leaves_that_mode(plate):
    """At the centre of the square plate the torsion mode (1,1) has no deflection (and no
    in-plane motion by symmetry): a 5 g mass there leaves it unchanged to solver precision,
    while the (2,0)+(0,2) ring mode, large at the centre, drops by tenths of a percent."""
    free = SpecimenModel(plate, OPTIONS).solve("original")
    loaded = SpecimenModel(plate.with_attachments([PointMass(5e-3, 0.075, 0.075)]), OPTIONS).solve("original")
    assert free.labels[0] == "(1,1)"
    assert loaded.frequencies_hz[0] == pytest.approx(free.frequencies_hz[0], rel=1e-9)
    assert loaded.frequencies_hz[2] / free.frequencies_hz[2] - 1 < -1e-3


def test_springs_first_order_and_suspension_modes_dropped(plate):
    """Weak springs (suspension modes ~ 3 Hz): the elastic frequencies rise by the first-order
    amount k df/dk = k sum w(p)^2 / (8 pi^2 f) to within 1 % of the largest shift (second-order
    terms are (k/K)^2 smaller; modes with nodal lines through the corners barely move),
    and the three suspension modes are not returned as elastic ones."""
    k = 200.0
    free = SpecimenModel(plate, OPTIONS).solve("original")
    held = plate.with_attachments([Suspension(k, CORNERS)])
    solution = SpecimenModel(held, OPTIONS).solve("original")
    shift = solution.frequencies_hz - free.frequencies_hz
    predicted = k * solution.derivatives([Parameter("stiffness", "suspension")])[:, 0]
    assert np.all(shift > 0)
    assert np.abs(shift - predicted).max() < 1e-2 * shift.max()
    assert solution.frequencies_hz[0] > 100  # not a ~Hz suspension mode


@pytest.mark.parametrize("parameter", [Parameter("mass", "point_mass"), Parameter("x", "point_mass"),
                                       Parameter("y", "point_mass"), Parameter("stiffness", "suspension")],
                         ids=lambda p: p.kind)
def test_attachment_derivatives_match_central_differences(plate, parameter):
    """Relative step 1e-5 (positions: 1e-5 m): agreement to 1e-4 of the column."""
    specimen = plate.with_attachments([PointMass(3e-3, 0.11, 0.04), Suspension(500.0, CORNERS)])
    exact = SpecimenModel(specimen, OPTIONS).sensitivity_matrix([parameter], relative=False)[:, 0]
    value = specimen.value(parameter)
    h = 1e-5 * abs(value)
    finite = (frequencies(specimen.with_values({parameter: value + h}))
              - frequencies(specimen.with_values({parameter: value - h}))) / (2 * h)
    assert np.abs(exact - finite).max() < 1e-4 * np.abs(exact).max()


@pytest.mark.parametrize("attachment,message", [
    (PointMass(-1e-3, 0.05, 0.05), "must not be negative"),
    (PointMass(1e-3, 0.20, 0.05), "outside the plate"),
    (Suspension(-5.0, CORNERS), "must not be negative"),
    (Suspension(5.0, ((0.05, -0.01),)), "outside the plate"),
])
def test_bad_attachments(plate, attachment, message):
    with pytest.raises(SpecError, match=message):
        plate.with_attachments([attachment])
