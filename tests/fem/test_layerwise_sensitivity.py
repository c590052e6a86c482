"""Exact frequency sensitivities of the layerwise model against central differences of
full solves, for every parameter kind, on a sandwich with a bonded plate."""

import math

import numpy as np
import pytest

from fem.laminates.laminate import Layer
from fem.laminates.layerwise import LayerwiseLaminate, _layer_inputs, coefficients
from fem.laminates.material import Material
from fem.model import ModelOptions, SpecimenModel
from fem.specimen import Configuration, Parameter, Specimen

GPA = 1e9
#: Relative step 1e-4: truncation (1e-4)^2 = 1e-8 of the column; eigenvalues are good to
#: ~1e-12, so round-off is 1e-12 / 1e-4 = 1e-8 of f / p, i.e. <= 1e-5 of a column whose
#: relative sensitivity is >= 1e-3 (the foam's E1, the weakest checked here).
STEP = 1e-4
#: The issue's tolerance: 1e-4 of the column's largest entry.
TOLERANCE = 1e-4

SKIN = Material("skin", 62 * GPA, 60 * GPA, 4.8 * GPA, 0.05, 1500.0, G13=3.5 * GPA, G23=3.0 * GPA)
#: G23 not given: it follows G12, so G12 acts through the shear too.
FOAM = Material("foam", 0.1 * GPA, 0.1 * GPA, 0.035 * GPA, 0.43, 80.0, G13=0.03 * GPA)
ADHESIVE = Material("adhesive", 1.0 * GPA, 1.0 * GPA, 1.0 / 2.8 * GPA, 0.4, 1150.0)  # G13 = G23 = G12
ALUMINIUM = Material("aluminium", 70 * GPA, 70 * GPA, 70 / 2.66 * GPA, 0.33, 2700.0)


def sandwich() -> Specimen:
    """An 80 x 60 mm sandwich (0.5 mm skins, the bottom one at 10 degrees so the angle and
    the Qb45 terms are live; 4 mm foam, stretching), and a bonded configuration (0.1 mm
    bond line and 1 mm aluminium underneath): 2 shear groups unbonded, 3 bonded ("auto")."""
    layers = (
        Layer(SKIN, 0.5e-3, math.radians(10), "layer1"),
        Layer(FOAM, 4e-3, 0.0, "layer2"),
        Layer(SKIN, 0.5e-3, 0.0, "layer3"),
    )
    bonded = Configuration(
        "al_bottom",
        bottom=(
            Layer(ADHESIVE, 0.1e-3, 0.0, "al_bottom.bottom1"),
            Layer(ALUMINIUM, 1e-3, 0.0, "al_bottom.bottom2"),
        ),
    )
    return Specimen("sandwich", 0.08, 0.06, layers, (Configuration("original"), bonded))


PARAMETERS = [
    *(Parameter(kind, "skin") for kind in ("E1", "E2", "G12", "nu12", "density", "G13", "G23")),
    *(Parameter(kind, "foam") for kind in ("E1", "E2", "G12", "G13", "density")),  # E2: also its E3
    Parameter("G12", "adhesive"),
    Parameter("G23", "aluminium"),
    Parameter("thickness", "layer2"),
    Parameter("thickness", "al_bottom.bottom1"),
    Parameter("angle", "layer1"),
]
GROUPINGS = ("auto", "layers")
CASES = [(p, g) for g in GROUPINGS for p in PARAMETERS]


def model(specimen, grouping):
    return SpecimenModel(
        specimen, ModelOptions(modes=5, divisions=6, theory="layerwise", layer_groups=grouping)
    )


def stacked(specimen, grouping):
    return np.concatenate(list(model(specimen, grouping).frequencies().values()))


def test_groups_of_the_sandwich():
    """The soft foam and bond line get shear groups of their own; skins and aluminium
    share one."""
    specimen = sandwich()
    solutions = {c.name: model(specimen, "auto").solve(c.name) for c in specimen.configurations}
    assert solutions["original"].layerwise.groups == (0, 1, 0)
    assert solutions["al_bottom"].layerwise.groups == (0, 1, 0, 2, 0)
    assert model(specimen, "layers").solve("al_bottom").layerwise.groups == (0, 1, 2, 3, 4)
    assert all(
        s.layerwise.stretch == (specimen.laminate(n).layers.index(specimen.layers[1]),)
        for n, s in solutions.items()
    )  # the foam


@pytest.mark.parametrize("parameter,grouping", CASES, ids=[f"{p.name}-{g}" for p, g in CASES])
def test_sensitivities_match_central_differences(parameter, grouping):
    """Both configurations, 5 modes each: every derivative within 1e-4 of its column's
    largest entry of central differences (stiffness, inertia, the groups' shear correction
    and the stretching foam's E3 = E2 all depend on the parameters; measured at most
    1.3e-6)."""
    specimen = sandwich()
    exact = model(specimen, grouping).sensitivity_matrix([parameter], relative=False)[:, 0]
    value = specimen.value(parameter)
    h = STEP * abs(value)
    plus = stacked(specimen.with_values({parameter: value + h}), grouping)
    minus = stacked(specimen.with_values({parameter: value - h}), grouping)
    finite = (plus - minus) / (2 * h)
    assert np.abs(exact).max() > 0
    assert np.abs(exact - finite).max() < TOLERANCE * np.abs(exact).max(), (exact, finite)


@pytest.mark.parametrize("grouping", GROUPINGS)
def test_relative_sensitivities_keep_homogeneity(grouping):
    """Euler's theorem: every generalised coefficient (shear corrections included) is of
    degree one in the moduli, so the relative sensitivities to all moduli (E1, E2, G12 and
    the given G13, G23) sum to 1/2 per mode, to all densities to -1/2.  Tolerance 1e-9:
    rounding of the modal energies."""
    specimen = sandwich()
    m = model(specimen, grouping)
    names = list(specimen.materials)
    moduli = [Parameter(k, n) for n in names for k in ("E1", "E2", "G12")]
    moduli += [
        Parameter(k, n)
        for n in names
        for k in ("G13", "G23")
        if k not in specimen.materials[n].defaulted_shear_moduli
    ]
    densities = [Parameter("density", n) for n in names]
    np.testing.assert_allclose(m.sensitivity_matrix(moduli).sum(axis=1), 0.5, atol=1e-9)
    np.testing.assert_allclose(m.sensitivity_matrix(densities).sum(axis=1), -0.5, atol=1e-9)


@pytest.mark.parametrize("grouping", GROUPINGS)
def test_a_batch_of_stacks_is_each_stack_alone(grouping):
    """The generalised coefficients of several stacks at once (a leading batch axis: the
    derivatives of every parameter come from one complex-step pass) equal each stack's
    own to rounding (1e-13 of the largest coefficient of its kind): the bonded sandwich
    with its layers' thicknesses, stiffnesses and densities scattered by +-30 %."""
    stack = LayerwiseLaminate.of(sandwich().laminate("al_bottom"), grouping)
    inputs = _layer_inputs(stack.laminate)
    rng = np.random.default_rng(7)
    batch = [x * rng.uniform(0.7, 1.3, (4,) + x.shape) for x in inputs]
    stiffness, inertia = coefficients(stack.groups, stack.stretch, *batch)
    for i in range(4):
        alone = coefficients(stack.groups, stack.stretch, *(x[i] for x in batch))
        assert np.allclose(stiffness[i], alone[0], rtol=1e-13, atol=1e-13 * np.abs(alone[0]).max())
        assert np.allclose(inertia[i], alone[1], rtol=1e-13, atol=1e-13 * np.abs(alone[1]).max())
    assert stack.stretch, "the foam core stretches: the normal-strain terms are in the batch"


def test_every_derivative_at_once_is_each_alone():
    """``LayerwiseLaminate.derivatives`` (one pass for every parameter) gives the rows of
    ``derivative`` one at a time, which the central-difference test checks."""
    stack = LayerwiseLaminate.of(sandwich().laminate("al_bottom"))
    kinds = [(p.kind, p.target) for p in PARAMETERS]
    stiffness, inertia = stack.derivatives(kinds)
    for i, kind in enumerate(kinds):
        ds, di = stack.derivative(*kind)
        assert np.allclose(stiffness[i], ds, rtol=1e-14, atol=1e-14 * np.abs(ds).max())
        assert np.allclose(inertia[i], di, rtol=1e-14, atol=1e-14 * max(np.abs(di).max(), 1e-300))
