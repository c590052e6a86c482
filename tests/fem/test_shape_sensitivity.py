"""Exact mode shape sensitivities (the algebraic method, ``eigenvector_derivatives``)
against central differences of full solves, and their eigenvalue derivative against the
modal-energy one (Fox and Kapoor), which shares no code with it."""

import math
from dataclasses import replace

import numpy as np
import pytest

from fem.model import ModelOptions, SpecimenModel
from fem.solver.attachments import PointMass
from fem.solver.mode_shapes import deflection_operator
from fem.solver.sensitivity import eigenvector_derivatives
from fem.specimen import Parameter

#: Central differences err by truncation (~ step^2, the shape's curvature in p) and by the
#: eigen-solve's round-off over the step (~ 1/step): per parameter the better of two
#: relative steps is taken.  Measured, as the norm of the difference over the shape at 81
#: points relative to the derivative's: 3e-6-1.2e-5 (Kirchhoff), 4e-6-4.3e-5 (shear);
#: step 1e-3 alone gives 3e-4 on steel E1 (truncation), 1e-4 alone 8.6e-4 on G13 (round-off).
STEPS = (1e-3, 1e-4)
TOLERANCE = 2e-4
PARAMETERS = [Parameter("E1", "steel"), Parameter("G12", "bottom_coating"), Parameter("E2", "top_coating")]
MODES = [0, 2, 4]


def _points(specimen):
    g = np.linspace(0.05, 0.95, 9)
    x, y = np.meshgrid(g * specimen.length, g * specimen.width)
    return x.ravel(), y.ravel()


def _aligned(shapes: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return shapes * np.sign(np.sum(shapes * reference, axis=0))


def _check(model: SpecimenModel, configuration: str, parameters, modes) -> float:
    """The worst relative difference of the exact derivatives from central differences
    (per parameter the better of ``STEPS``)."""
    solution = model.solve(configuration)
    exact = solution.shape_derivatives(parameters, modes)
    at = deflection_operator(solution.units, *_points(model.specimen))
    reference = solution.modes.shapes[:, modes]
    worst = 0.0
    for k, p in enumerate(parameters):
        value = model.value(p)
        errors = []
        for step in STEPS:
            h = step * abs(value)
            plus = model.with_values({p: value + h}).solve(configuration).modes.shapes[:, modes]
            minus = model.with_values({p: value - h}).solve(configuration).modes.shapes[:, modes]
            finite = (_aligned(plus, reference) - _aligned(minus, reference)) / (2 * h)
            errors.append(
                float(
                    np.max(
                        np.linalg.norm(at @ (exact[:, :, k] - finite), axis=0)
                        / np.linalg.norm(at @ finite, axis=0)
                    )
                )
            )
        worst = max(worst, min(errors))
    return worst


def test_kirchhoff_shape_derivatives_with_a_sensor(paper_model):
    """The paper's plate under bonded brass (unsymmetric) carrying a 3 g sensor, modes 1,
    3 and 5 (one of a pair 0.2 % apart): every derivative within 2e-4 of central
    differences."""
    model = paper_model.with_attachments([PointMass(3e-3, 0.125, 0.110)]).with_options(modes=8)
    assert _check(model, "brass_top", PARAMETERS, MODES) < TOLERANCE


def test_shear_shape_derivatives_on_a_thick_plate(paper_specimen):
    """First-order shear on the paper's stack over 30 x 30 mm (a/h = 27, so shear
    matters), steel with its own G13: E1, G12 and G13 within 2e-4 of central differences."""
    specimen = replace(paper_specimen, length=0.03, width=0.03).with_values({Parameter("G13", "steel"): 70e9})
    model = SpecimenModel(specimen, ModelOptions(modes=6, divisions=6, transverse_shear=True))
    parameters = [Parameter("E1", "steel"), Parameter("G12", "bottom_coating"), Parameter("G13", "steel")]
    assert _check(model, "original", parameters, MODES) < TOLERANCE


def test_eigenvalue_derivative_of_the_bordered_system_is_fox_and_kapoor(paper_model):
    """The bordered system's d(lambda) equals the modal-energy one to round-off (1e-9):
    two formulas, one eigen-solve."""
    solution = paper_model.solve("brass_bottom")
    units = solution.units
    coefficients, inertia = (
        solution.laminate.stiffness,
        solution.laminate.inertia * np.array(solution.inertia_terms),
    )
    stiffness, mass = units.stiffness(coefficients), units.mass(inertia)
    dx, di = (np.array(d) for d in zip(*(solution.laminate.derivative(p.kind, p.target) for p in PARAMETERS)))
    d_stiffness = [units.stiffness(x) for x in dx]
    d_mass = [units.mass(i * np.array(solution.inertia_terms)) for i in di]
    by_energies = solution.derivatives(PARAMETERS) * 8 * math.pi**2 * solution.frequencies_hz[:, None]
    for i in MODES:
        _, d_lambda = eigenvector_derivatives(
            stiffness,
            mass,
            float(solution.modes.eigenvalues[i]),
            solution.modes.shapes[:, i],
            d_stiffness,
            d_mass,
        )
        np.testing.assert_allclose(d_lambda, by_energies[i], rtol=1e-9)


def test_layerwise_and_attachment_parameters_are_refused(paper_model):
    with pytest.raises(Exception, match="layerwise"):
        paper_model.with_options(theory="layerwise").solve("original").shape_derivatives(PARAMETERS[:1], [0])
    with_sensor = paper_model.with_attachments([PointMass(3e-3, 0.125, 0.110)])
    with pytest.raises(Exception, match="attachment"):
        with_sensor.solve("original").shape_derivatives([Parameter("mass", "point_mass")], [0])
