"""Point masses and suspension springs: physics checks and exact derivatives."""

import numpy as np
import pytest

from fem.errors import SpecError
from fem.model import ModelOptions, SpecimenModel, system_coefficients, system_data
from fem.solver import mesh as mesh_module
from fem.solver.attachments import PointMass, Suspension
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


@pytest.mark.parametrize("base", [0.0, 0.03], ids=["point", "base 30 mm"])
@pytest.mark.parametrize(
    "parameter",
    [
        Parameter("mass", "point_mass"),
        Parameter("x", "point_mass"),
        Parameter("y", "point_mass"),
        Parameter("stiffness", "suspension"),
    ],
    ids=lambda p: p.kind,
)
def test_attachment_derivatives_match_central_differences(plate, parameter, base, monkeypatch):
    """Relative step 1e-5 (positions: 1e-5 m): agreement to 1e-4 of the column.  The 30 mm
    footprint spans parts of four elements (19 mm each), whose lines it crosses as it moves;
    the derivatives are those of a fixed mesh, so the mesh's lines that follow a base
    (``FOOTPRINT_ELEMENTS``) are off here."""
    monkeypatch.setattr(mesh_module, "FOOTPRINT_ELEMENTS", 0)
    specimen = plate.with_attachments([PointMass(3e-3, 0.11, 0.04, base=base), Suspension(500.0, CORNERS)])
    exact = SpecimenModel(specimen, OPTIONS).sensitivity_matrix([parameter], relative=False)[:, 0]
    value = specimen.value(parameter)
    h = 1e-5 * abs(value)
    finite = (
        frequencies(specimen.with_values({parameter: value + h}))
        - frequencies(specimen.with_values({parameter: value - h}))
    ) / (2 * h)
    assert np.abs(exact - finite).max() < 1e-4 * np.abs(exact).max()


def test_a_footprint_is_the_mass_spread_evenly_over_its_square(plate, monkeypatch):
    """A 30 mm base over parts of four elements against the same mass as n x n equal masses
    at the centres of a grid over the square (the midpoint rule, an independent quadrature
    whose error falls as 1 / n^2): from n = 20 to 40 the difference falls by 4 (3.6-4.4),
    and the Richardson extrapolation of the two agrees with the footprint to 1e-7 of a
    frequency (the difference at n = 40 is 2.5e-6), while the mass at one point differs
    from it by more than 1e-4.  On one mesh: without the lines that follow a base."""
    monkeypatch.setattr(mesh_module, "FOOTPRINT_ELEMENTS", 0)
    mass, x, y, base = 5e-3, 0.07, 0.08, 0.03
    spread = frequencies(plate.with_attachments([PointMass(mass, x, y, base=base)]))
    midpoint = {}
    for n in (20, 40):
        centres = (np.arange(n) + 0.5) / n * base - base / 2
        grid = [
            PointMass(mass / n**2, x + a, y + b, f"m{i}_{j}")
            for i, a in enumerate(centres)
            for j, b in enumerate(centres)
        ]
        midpoint[n] = frequencies(plate.with_attachments(grid))
    error = {n: np.abs(f / spread - 1).max() for n, f in midpoint.items()}
    assert 3.6 < error[20] / error[40] < 4.4
    extrapolated = (4 * midpoint[40] - midpoint[20]) / 3
    assert np.abs(extrapolated / spread - 1).max() < 1e-7
    point = frequencies(plate.with_attachments([PointMass(mass, x, y)]))
    assert np.abs(point / spread - 1).max() > 1e-4


def test_a_footprint_converges_where_a_point_mass_does_not(monkeypatch):
    """On a foam-core sandwich with first-order shear (the 3-D reference's: 0.5 mm skins,
    6 mm foam of G = 35 MPa), a 6 g mass at one point is singular: halving the elements
    (24 -> 48 along) still moves a mode by more than 1.5 % (the deflection under a point
    load grows as log(1/h)).  Over a 12 mm base it is not: the default mesh, its base
    divided into ``FOOTPRINT_ELEMENTS`` = 4 elements a side, is within 0.03 % of one with
    8 a side and 40 divisions (measured 0.018 %), where the default mesh alone is 0.3 %
    or more off (measured 0.71 %: the plate bends sharply at the base's edges)."""
    import json
    import tomllib

    from fem.spec import parse_spec
    from tests.conftest import DATA

    case = json.loads((DATA / "solid3d" / "foam_sandwich.json").read_text())
    specimen = parse_spec(tomllib.loads(case["spec_toml"])).specimen
    specimen = specimen.with_configurations(specimen.configurations[:1])

    def solved(base, divisions=None, per_side=4):
        monkeypatch.setattr(mesh_module, "FOOTPRINT_ELEMENTS", per_side)
        mass = PointMass(6e-3, 0.3 * specimen.length, 0.6 * specimen.width, base=base)
        options = ModelOptions(modes=8, divisions=divisions, transverse_shear=True)
        return SpecimenModel(specimen.with_attachments([mass]), options).frequencies()["original"]

    point = [solved(0.0, n) for n in (24, 48)]
    assert np.abs(point[0] / point[1] - 1).max() > 0.015
    reference = solved(0.012, 40, per_side=8)
    assert np.abs(solved(0.012) / reference - 1).max() < 3e-4
    assert np.abs(solved(0.012, per_side=0) / reference - 1).max() > 3e-3


@pytest.mark.parametrize(
    "attachment,message",
    [
        (PointMass(-1e-3, 0.05, 0.05), "must not be negative"),
        (PointMass(1e-3, 0.05, 0.05, base=-1e-3), "base = -1 mm"),
        (PointMass(1e-3, 0.05, 0.05, base=0.1), "square footprint"),
        (PointMass(1e-3, 0.20, 0.05), "outside the plate"),
        (Suspension(-5.0, CORNERS), "must not be negative"),
        (Suspension(5.0, ((0.05, -0.01),)), "outside the plate"),
    ],
)
def test_bad_attachments(plate, attachment, message):
    with pytest.raises(SpecError, match=message):
        plate.with_attachments([attachment])


def test_a_base_is_divided_into_equal_elements_without_slivers():
    """Lines at a base's edges and inside it at equal steps; the mesh's own lines closer
    than half a step dropped (no sliver elements), the plate's ends kept."""
    nodes = mesh_module.with_footprints(np.linspace(0.0, 0.2, 11), [(0.033, 0.045), (0.0, 0.012)], 4)
    for lo, hi in ((0.033, 0.045), (0.0, 0.012)):
        assert np.all(np.isin(np.round(np.linspace(lo, hi, 5), 12), np.round(nodes, 12)))
    assert nodes[0] == 0.0 and nodes[-1] == 0.2
    assert np.diff(nodes).min() >= 0.5 * 0.003 - 1e-12


def test_attached_masses_and_springs_are_the_rigid_plate_s_closed_forms(plate):
    """What the attachments add to the system matrices (``add_attachment_data``: only their
    entries, in place) holds the closed forms of a rigid plate: a translation carries the
    attached mass (u and w alike), a rotation w = y the masses' second moment sum m y^2, a
    w translation the springs' total stiffness.  Two masses share an element (their
    entries overlap) and a third sits on a square base (several footprint points); to
    1e-12, the round-off of summing a few hundred terms.  Added to the plate's own data,
    they give bit for bit what adding their whole arrays gives."""
    masses = [
        PointMass(3e-3, 0.070, 0.081),
        PointMass(2e-3, 0.072, 0.083),
        PointMass(4e-3, 0.03, 0.1, base=0.012),
    ]
    springs = Suspension(150.0, CORNERS)
    solution = SpecimenModel(plate, OPTIONS).solve("original")
    units = solution.units
    coefficients, inertia = system_coefficients(solution.laminate, False, solution.inertia_terms)
    # the plate's own matrices weighted by zero: what remains is the attachments' alone
    # (a difference of the two would cancel to the plate's round-off, 1e-9 of 600 N/m)
    nothing = np.zeros_like(coefficients), np.zeros_like(inertia)
    k, m = system_data(units, *nothing, (*masses, springs))
    added_k, added_m = units.matrix(k), units.matrix(m)
    rigid = units.rigid_body_modes
    total = sum(a.mass for a in masses)
    assert rigid[:, 2] @ added_m @ rigid[:, 2] == pytest.approx(total, rel=1e-12)
    assert rigid[:, 0] @ added_m @ rigid[:, 0] == pytest.approx(total, rel=1e-12)
    point_masses = masses[:2]  # the base's second moment is spread: the two points alone
    alone = units.matrix(system_data(units, *nothing, tuple(point_masses))[1])
    assert rigid[:, 3] @ alone @ rigid[:, 3] == pytest.approx(
        sum(a.mass * a.y**2 for a in point_masses), rel=1e-12
    )
    assert rigid[:, 2] @ added_k @ rigid[:, 2] == pytest.approx(4 * 150.0, rel=1e-12)
    # On the plate's own data: the same numbers as adding the attachments' whole arrays
    plain = system_data(units, coefficients, inertia)
    loaded = system_data(units, coefficients, inertia, (*masses, springs))
    assert np.array_equal(loaded[0], plain[0] + k) and np.array_equal(loaded[1], plain[1] + m)
