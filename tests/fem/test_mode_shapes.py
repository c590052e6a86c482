"""Nodal-pattern labels: the free-free beam basis against its closed form, labels that do
not depend on the mesh or the plate theory, and patterns parsed from a lab's labels."""

import numpy as np
import pytest

from fem.model import ModelOptions, SpecimenModel
from fem.solver.mode_shapes import (
    ORDER,
    _beta,
    _gauss,
    _sign_changes,
    affinity,
    beam_functions,
    label_of,
    pattern,
    single_term,
)


def test_beam_functions_are_the_free_free_modes():
    """Each beta L solves the free-free frequency equation cos(b) cosh(b) = 1 (to 1e-8 of
    cosh b), the functions are orthonormal on [0, 1] (eigenfunctions of a self-adjoint
    problem are orthogonal only with the right end conditions; quadrature error 1e-8) and
    phi_k has k nodes."""
    for k in range(2, ORDER):
        b = _beta(k - 1)
        assert abs(np.cos(b) * np.cosh(b) - 1) < 1e-8 * np.cosh(b)
    xi, weight, phi = _gauss()
    np.testing.assert_allclose((phi * weight) @ phi.T, np.eye(ORDER), atol=1e-8)
    values = beam_functions(np.linspace(1e-4, 1 - 1e-4, 20000))
    assert [int(np.sum(np.diff(np.sign(v)) != 0)) for v in values] == list(range(ORDER))


@pytest.mark.parametrize(
    "options",
    [
        ModelOptions(modes=12, divisions=8),
        ModelOptions(modes=12, divisions=20),
        ModelOptions(modes=12, transverse_shear=True),
    ],
    ids=["coarse", "fine", "shear"],
)
def test_labels_do_not_depend_on_mesh_or_theory(paper_specimen, options):
    """The paper's plate, 12 modes: the same labels on an 8 x 8 and a 20 x 20 mesh and with
    transverse shear; each appears once; the square plate's second and third modes are the
    X and ring modes, (0,2) - (2,0) below (0,2) + (2,0) (Leissa's free square plate)."""
    labels = SpecimenModel(paper_specimen, options).solve("original").labels
    assert labels == (
        "(1,1)",
        "(0,2)-(2,0)",
        "(0,2)+(2,0)",
        "(1,2)",
        "(2,1)",
        "(0,3)",
        "(3,0)",
        "(2,2)",
        "(1,3)-(3,1)",
        "(1,3)+(3,1)",
        "(2,3)",
        "(3,2)",
    )


def test_patterns_and_affinity():
    """A lab's label parses to the pattern the model's label names; a pure mode has
    affinity 1 with its own label, 1/2 with a mixed one containing it, 0 with others."""
    c = np.zeros((1, ORDER, ORDER))
    c[0, 1, 2] = 1.0
    assert label_of(c[0]) == "(1,2)"
    assert affinity(c, pattern("( 1 , 2 )"))[0] == pytest.approx(1.0)
    assert affinity(c, pattern("(1,2)+(2,1)"))[0] == pytest.approx(0.5)
    assert affinity(c, pattern("(2,1)"))[0] == 0.0
    mixed = np.zeros((ORDER, ORDER))
    mixed[0, 2], mixed[2, 0] = 0.7, -0.7
    assert label_of(mixed) == "(0,2)-(2,0)"
    for bad in ("ring", "(1,2", "(1,2)*(2,1)", f"({ORDER},0)"):
        assert pattern(bad) is None


def test_sign_changes_skip_the_points_near_a_line():
    """Zeros (points too near a nodal line to read) are skipped, not counted as a sign."""
    lines = np.array([[1, 1, 0, -1, -1, 0, 0, 1], [0, 0, 1, 0, 1, 1, 0, 0], [-1, 1, -1, 1, 0, 0, 0, 0]])
    assert _sign_changes(lines[:, :, None])[:, 0].tolist() == [2, 0, 3]


@pytest.mark.parametrize(
    "options", [ModelOptions(modes=20), ModelOptions(modes=12, transverse_shear=True)], ids=["thin", "shear"]
)
def test_nodal_lines_count_what_the_pattern_names(paper_specimen, options):
    """Two independent readings of the paper's square plate agree: on every mode the beam
    products name with one term, the nodal lines counted on the plate are that term
    (eight of the first twelve, twelve of the first twenty); the X and ring pairs cross
    lines both ways; in-plane modes count none."""
    solution = SpecimenModel(paper_specimen, options).solve("original")
    counted = [tuple(c) for c in solution.nodal_lines.tolist()]
    single = [(k, single_term(label)) for k, label in enumerate(solution.labels) if single_term(label)]
    assert len(single) == (12 if options.modes == 20 else 8)
    assert all(counted[k] == term for k, term in single)
    assert counted[1] == counted[2] == (2, 2)


def test_single_term_reads_one_term_labels_only():
    assert single_term("( 3 , 1 )") == (3, 1)
    for other in ("(0,2)+(2,0)", "(1,3)-(3,1)", "ring", "(1,2"):
        assert single_term(other) is None
