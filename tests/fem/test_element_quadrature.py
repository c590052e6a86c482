"""The element integrals without element matrices (``EnergyQuadrature``,
``ProjectionQuadrature``: each operator applied only to the DOFs it reads) against the
element matrices themselves (``MatrixQuadrature``), for every element type."""

import numpy as np
import pytest

from fem.elements import HermitePlate, LayerwisePlate, ShearDifferencePlate
from fem.elements.hermite_plate import EnergyQuadrature, ProjectionQuadrature, _applied
from fem.laminates.laminate import VOIGT_PAIRS

ELEMENTS = [HermitePlate, ShearDifferencePlate, LayerwisePlate.with_groups(2, 1)]


def _element(kind):
    return kind(0.012, 0.008)  # a rectangle [m]: hx != hy exercises both directions


@pytest.mark.parametrize("kind", ELEMENTS, ids=lambda k: k.__name__)
def test_quadratic_forms_and_projections_are_the_element_matrices(kind):
    """x^T K x and sum_e X_e^T K X_e of random fields from the quadratures equal those
    of the assembled element matrices, for every unit stiffness and mass matrix.  1e-12
    relative: the same products summed in another order (measured 1e-15)."""
    element = _element(kind)
    stiffness, mass = element.unit_stiffness(VOIGT_PAIRS), element.unit_mass()
    n = stiffness.shape[-1]
    rng = np.random.default_rng(7)
    fields = rng.standard_normal((n, 5))
    energy = EnergyQuadrature(element.weights, fields)
    for matrices, forms in (
        (stiffness, element.unit_stiffness(VOIGT_PAIRS, energy)),
        (mass, element.unit_mass(energy)),
    ):
        expected = np.einsum("nk,cnm,mk->ck", fields, matrices, fields)
        np.testing.assert_allclose(forms, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
    elements, rank = 3, 4
    local = rng.standard_normal((elements, n, rank))
    gathered = local.transpose(1, 0, 2).reshape(n, -1)  # element-major, as UnitMatrices gathers
    projection = ProjectionQuadrature(element.weights, gathered, rank)
    for matrices, projected in (
        (stiffness, element.unit_stiffness(VOIGT_PAIRS, projection)),
        (mass, element.unit_mass(projection)),
    ):
        expected = np.einsum("enr,cnm,ems->crs", local, matrices, local)
        np.testing.assert_allclose(projected, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


def test_an_operator_reads_only_its_fields_dofs():
    """The Kirchhoff element's curvature reads the 16 w DOFs of its 48, the membrane
    strains the 32 of u and v: ``_applied`` skips the rest and gives the full product."""
    element = HermitePlate(0.01, 0.01)
    membrane, curvature = element.strain_operators()
    local = np.random.default_rng(3).standard_normal((48, 6))
    for op, reads in ((membrane, 32), (curvature, 16)):
        assert np.count_nonzero(np.any(op.reshape(-1, 48) != 0, axis=0)) == reads
        np.testing.assert_allclose(_applied(op, local), op @ local, rtol=1e-14, atol=1e-14 * np.abs(op).max())
