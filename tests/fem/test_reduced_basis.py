"""Reanalysis on a reduced basis (``fem.solver.reduced_basis``) against full solves: on a
thin (Kirchhoff), a thick (first-order shear) and a layerwise model, each with a sensor
whose mass and position are parameters too; and the screens' reach on a long spruce plate."""

import numpy as np
import pytest

from fem.laminates.layerwise import SOFT_SHEAR_RATIO
from fem.solver.attachments import PointMass
from fem.solver.reduced_basis import Reanalysis
from fem.spec import parse_spec
from fem.specimen import Parameter
from studies.long_plates import handbook_model

#: A foam-core sandwich (skins 0.5 mm, core 6 mm; the layerwise benchmark's, smaller and
#: on a coarse mesh so a full solve takes a fraction of a second).
SANDWICH = {
    "specimen": {
        "length_mm": 250.0,
        "width_mm": 200.0,
        "layers": [
            {"material": "skin", "thickness_mm": 0.5},
            {"material": "foam", "thickness_mm": 6.0},
            {"material": "skin", "thickness_mm": 0.5},
        ],
    },
    "materials": {
        "skin": {
            "E1_GPa": 62.0,
            "E2_GPa": 60.0,
            "G12_GPa": 4.8,
            "nu12": 0.05,
            "density_kg_m3": 1500.0,
            "G13_GPa": 3.5,
            "G23_GPa": 3.5,
            "identify": True,
        },
        "foam": {
            "E1_GPa": 0.1,
            "E2_GPa": 0.1,
            "G12_GPa": 0.035,
            "nu12": 0.4286,
            "density_kg_m3": 80.0,
            "G13_GPa": 0.035,
            "G23_GPa": 0.035,
            "identify": ["G13", "G23"],
        },
    },
    "configurations": [{"name": "original"}],
    "model": {"modes": 6, "divisions": 8},
}
THEORIES = {
    "thin": {},
    "thick": {"transverse_shear": True, "rotary_inertia": True},
    "layerwise": {"theory": "layerwise"},
}
PARAMETERS = [
    Parameter("E1", "skin"),
    Parameter("G12", "skin"),
    Parameter("nu12", "skin"),
    Parameter("G13", "foam"),
    Parameter("mass", "sensor"),
    Parameter("x", "sensor"),
    Parameter("y", "sensor"),
]
#: A fit's step: the skins' E1 +5 %, the core's G13 -5 %, the sensor 4 -> 4.4 g and 10 mm along.
STEP = {PARAMETERS[0]: 1.05, PARAMETERS[3]: 0.95, PARAMETERS[4]: 1.1, PARAMETERS[5]: 1.125}


def _model(theory: str):
    return (
        parse_spec(SANDWICH)
        .with_options(**THEORIES[theory])
        .with_attachments([PointMass(0.004, 0.08, 0.06, "sensor")])
    )


def _moved(model, scale: float = 1.0):
    """The model moved by ``scale`` x ``STEP`` (relative changes)."""
    return model.with_values({p: model.value(p) * (1 + scale * (f - 1)) for p, f in STEP.items()})


@pytest.mark.parametrize("theory", THEORIES)
def test_exact_at_the_basis_point(theory):
    """At its basis point the basis holds the exact modes: frequencies and sensitivities
    (layer moduli, the core's shear, the sensor's mass and position) are the full solve's
    to round-off (measured 1e-11 relative; 1e-8 leaves round-off of the projections and
    of the dense eigenproblem a factor 1000)."""
    model = _model(theory)
    full = model.solve("original")
    ritz = Reanalysis.of(model, "original").solve(model.specimen)
    assert ritz.frequencies_hz == pytest.approx(full.frequencies_hz, rel=1e-8)
    exact = full.derivatives(PARAMETERS)
    scale = np.maximum(np.abs(exact).max(axis=0), 1e-300)
    assert np.max(np.abs(ritz.derivatives(PARAMETERS) - exact) / scale) < 1e-8


@pytest.mark.parametrize("theory", THEORIES)
def test_sensitivities_are_the_ritz_values_derivatives(theory):
    """Away from the basis point the sensitivities are the exact derivatives of the Ritz
    frequencies (what keeps a Gauss-Newton fit on them convergent): central differences
    of the Ritz model, step 1e-4 relative, agree within 1e-5 of each column's largest
    (truncation O(step^2) ~ 1e-8, round-off ~ 1e-12 / 1e-4)."""
    model = _model(theory)
    reanalysis = Reanalysis.of(model, "original")
    moved = _moved(model)
    analytic = reanalysis.solve(moved.specimen).derivatives(PARAMETERS)
    for j, p in enumerate(PARAMETERS):
        h = 1e-4 * moved.value(p)
        up, down = (
            reanalysis.solve(moved.with_values({p: moved.value(p) + s * h}).specimen).frequencies_hz
            for s in (1, -1)
        )
        numeric = (up - down) / (2 * h)
        scale = max(np.abs(numeric).max(), 1e-300)
        assert np.max(np.abs(analytic[:, j] - numeric)) < 1e-5 * scale, p


@pytest.mark.parametrize("theory", THEORIES)
def test_upper_bounds_that_an_enlarged_basis_tightens(theory):
    """Half a step away the Ritz frequencies bound the full solve's from above; a basis
    on both ends of the step (what a fit's trial screen holds) lies
    closer than the start's alone (measured: 0.3 % off with the start's modes on the
    shear models, 0.004 % with both), within 0.02 %.  The screen only decides which
    trials are solved in full, so this is its reach, not a result."""
    model = _model(theory)
    start = Reanalysis.of(model, "original")
    enlarged = Reanalysis.of(_moved(model), "original", model.solve("original").modes.shapes)
    halfway = _moved(model, 0.5)
    full = halfway.solve("original").frequencies_hz
    one, both = (r.solve(halfway.specimen).frequencies_hz for r in (start, enlarged))
    assert np.all(one >= full * (1 - 1e-9)) and np.all(both >= full * (1 - 1e-9))
    assert np.max(both / full - 1) < np.max(one / full - 1)
    assert np.max(both / full - 1) < 2e-4


@pytest.mark.parametrize("theory", THEORIES)
def test_assembled_and_projected_reanalyses_agree(theory):
    """An assembled reanalysis (each point's K and M projected, what the trial screen
    uses) is the projected one by another road: at a moved point, on a basis of both
    ends, the frequencies agree to 1e-10 (measured 2e-12 to 6e-12 on a 12,672-DOF
    sandwich: the round-off of two summation orders) and the sensitivities, which the
    assembled one takes from its expanded shapes, to 1e-7 of each column's largest
    (measured 1e-10 to 2e-9: the quadrature of expanded shapes against projected
    quadratures)."""
    model = _model(theory)
    extra = model.solve("original").modes.shapes
    projected, assembled = (
        Reanalysis.of(_moved(model), "original", extra, assembled=a) for a in (False, True)
    )
    halfway = _moved(model, 0.5).specimen
    assert assembled.frequencies_hz(halfway) == pytest.approx(projected.frequencies_hz(halfway), rel=1e-10)
    one, other = (r.solve(halfway).derivatives(PARAMETERS) for r in (projected, assembled))
    scale = np.maximum(np.abs(one).max(axis=0), 1e-300)
    assert np.max(np.abs(other - one) / scale) < 1e-7


@pytest.mark.parametrize(
    "options", [{}, {"transverse_shear": True, "rotary_inertia": True}], ids=["kirchhoff", "shear_and_mass"]
)
def test_the_screens_reach(options):
    """The peak-list screen's range on a long spruce plate: 30 basis modes (1.5 x the 20
    compared), E1 +15 %, E2 -5 %, G12 +5 %, nu12 0.40 -> 0.35.  The Ritz frequencies
    bound the full solve's from above and lie within 0.1 % (measured 0.01-0.04 %; the
    screen matches peaks at 1 %, so 0.1 % leaves it a factor 10)."""
    start = handbook_model()  # a long spruce plate (the shape of a public tap-test data set's)
    divisions = start.with_options(modes=20).options.divisions_for(start.specimen)
    start = start.with_options(modes=30, divisions=divisions, **options)
    if options:
        start = start.with_attachments([PointMass(0.004, 0.4, 0.15, "sensor")])
    moved = {
        Parameter(k, "spruce"): start.value(Parameter(k, "spruce")) * f
        for k, f in {"E1": 1.15, "E2": 0.95, "G12": 1.05}.items()
    }
    moved = start.with_values({**moved, Parameter("nu12", "spruce"): 0.35}).with_options(modes=20)
    ritz = Reanalysis.of(start, "original").frequencies_hz(moved.specimen)[:20]
    full = moved.solve("original").frequencies_hz[:20]
    assert np.all(ritz >= full * (1 - 1e-9))
    assert np.max(ritz / full - 1) < 1e-3


def test_a_fit_across_a_rule_threshold_keeps_one_theory():
    """The layerwise structure is pinned when the model is made
    (``fem.laminates.layerwise``, "Pinned structure").  A core made just softer than
    ``SOFT_SHEAR_RATIO`` x the skins' shear modulus stretches; moved 3 % past the threshold
    in a fit it still does, so the misfit stays continuous: frequencies 1e-5 either side of
    the threshold differ by less than 1e-5 (measured 1.2e-6: df/f <= dG/G / 2), where a
    model made afresh past it has no stretching layer and jumps by more than 2e-4
    (measured 4.6e-4).  A Ritz basis at the start reaches the moved point (before the pin
    it refused it, OutsideBasis) and bounds its frequencies from above within 0.05 %
    (measured 0.006-0.018 %, a 6 % step in the core's moduli).  A change of theory pins
    afresh; a change of modes keeps the pin."""
    threshold = SOFT_SHEAR_RATIO * 3.5e9  # the skins' G13, G23 [Pa]

    def core(model, shear_modulus):
        return model.with_values({Parameter(k, "foam"): shear_modulus for k in ("G13", "G23")})

    pinned = core(parse_spec(SANDWICH), 0.97 * threshold).with_options(theory="layerwise")
    assert pinned.solve("original").layerwise.stretch == (1,)
    moved = core(pinned, 1.03 * threshold)
    assert moved.solve("original").layerwise.stretch == (1,)
    below, above = (
        core(pinned, threshold * (1 + s * 1e-5)).solve("original").frequencies_hz for s in (-1, 1)
    )
    assert np.max(np.abs(above / below - 1)) < 1e-5
    afresh = core(parse_spec(SANDWICH), threshold * (1 + 1e-5)).with_options(theory="layerwise")
    assert afresh.solve("original").layerwise.stretch == ()
    assert np.max(np.abs(afresh.solve("original").frequencies_hz / above - 1)) > 2e-4
    ritz = Reanalysis.of(pinned, "original").solve(moved.specimen).frequencies_hz
    full = moved.solve("original").frequencies_hz
    assert np.all(ritz >= full * (1 - 1e-9)) and np.max(ritz / full - 1) < 5e-4
    assert moved.with_options(modes=8).options.layerwise_structure == pinned.options.layerwise_structure
    repinned = moved.with_options(theory="single_layer").with_options(theory="layerwise")
    assert repinned.solve("original").layerwise.stretch == ()
