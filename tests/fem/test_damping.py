"""Modal loss factors: the spec keys, the first-order (modal strain energy) estimate and
the complex eigenproblem it is checked against."""

import copy
import tomllib
from dataclasses import replace

import numpy as np
import pytest

from fem.errors import SpecError
from fem.solver.complex_modes import complex_loss_factors
from fem.solver.damping import first_order_loss_factors, loss_columns
from fem.spec import parse_spec
from identify.examples import COATED_PLATE

BASE = tomllib.loads(COATED_PLATE.read_text())


def spec(edit=None, **options):
    data = copy.deepcopy(BASE)
    data["model"].update(options)
    if edit:
        edit(data)
    return parse_spec(data)


def with_losses(model, **etas):
    """The model with loss factors per material: name -> (eta_E1, eta_E2, eta_G12)."""
    materials = [
        replace(model.specimen.materials[name], eta_E1=a, eta_E2=b, eta_G12=c)
        for name, (a, b, c) in etas.items()
    ]
    return model.with_specimen(model.specimen.with_materials(materials))


def test_spec_keys():
    def edit(d):
        d["materials"]["brass"].update(eta=0.002)
        d["materials"]["adhesive"].update(eta_E1=0.1, eta_G12=0.3)
        d["materials"]["steel"].update(identify_damping=True)
        d["materials"]["top_coating"].update(identify_damping=["eta_E1", "eta_G12"])
        d["materials"]["bottom_coating"].update(eta=0.01, identify_damping=True)

    m = spec(edit).defined_materials
    assert (m["brass"].eta_E1, m["brass"].eta_E2, m["brass"].eta_G12) == (0.002, 0.002, 0.002)
    assert (m["adhesive"].eta_E1, m["adhesive"].eta_E2, m["adhesive"].eta_G12) == (0.1, None, 0.3)
    assert m["adhesive"].loss_factor("eta_E2") == 0.0
    assert m["steel"].identify_damping == ("eta_E1", "eta_E2", "eta_G12"), "orthotropic: the three"
    assert m["top_coating"].identify_damping == ("eta_E1", "eta_G12")
    assert m["bottom_coating"].identify_damping == ("eta",), "given as eta: one shared loss factor"
    assert spec(lambda d: d["materials"]["brass"].update(identify_damping=True)).defined_materials[
        "brass"
    ].identify_damping == ("eta",), "isotropic: one shared loss factor"


@pytest.mark.parametrize(
    "edit, words",
    [
        (
            lambda d: d["materials"]["brass"].update(eta=-0.1),
            ["[materials.brass].eta = -0.1", "0 <= eta <= 2"],
        ),
        (lambda d: d["materials"]["brass"].update(eta_G12=5.0), ["eta_G12 = 5", "loss factor"]),
        (lambda d: d["materials"]["brass"].update(eta_E1="0.1"), ["eta_E1 = '0.1'", "finite number"]),
        (lambda d: d["materials"]["brass"].update(eta=0.1, eta_E1=0.2), ["eta and eta_E1 are both given"]),
        (
            lambda d: d["materials"]["steel"].update(identify_damping="yes"),
            ["identify_damping = 'yes'", "true, false"],
        ),
        (
            lambda d: d["materials"]["steel"].update(identify_damping=["eta_E3"]),
            ["identify_damping = ['eta_E3']", "eta_G12"],
        ),
        (lambda d: d["materials"]["steel"].update(identify_damping=["eta", "eta_E1"]), ['["eta"] alone']),
    ],
)
def test_bad_spec_keys(edit, words):
    with pytest.raises(SpecError) as error:
        spec(edit)
    message = str(error.value)
    assert "\n" not in message and all(w in message for w in words), message


def single_material(eta, **options):
    """The example plate with every layer and addition of one steel-like material."""
    model = spec(**options)
    steel = model.specimen.materials["steel"]
    one = [
        replace(
            steel,
            name=name,
            E1=200e9,
            E2=200e9,
            G12=200e9 / 2.6,
            nu12=0.3,
            eta_E1=eta,
            eta_E2=eta,
            eta_G12=eta,
        )
        for name in model.specimen.materials
    ]
    return model.with_specimen(model.specimen.with_materials(one))


@pytest.mark.parametrize("options", [{}, {"transverse_shear": True}])
def test_one_material_one_eta_every_mode(options):
    """Every modulus with one eta scales K by (1 + i eta): each complex eigenvalue is
    lambda (1 + i eta) exactly, and the first-order weights sum to 1 (Euler's theorem
    for stiffnesses homogeneous of degree 1 in the moduli).  Solver precision: ARPACK's
    tol 1e-10 bounds the Ritz residual, which gave eta to 1e-9 on equal elements and to
    1.5e-7 on the shear theory's edge-graded mesh (elements from 1.6 mm up, a wider
    spread of element stiffnesses; a tol of 1e-12 does not change it), so 1e-6 for the
    complex solve; the first-order weights (modal energies of the real modes) sum to 1
    within 1.2e-9 there, so 1e-8.  A wrong sign or a term without eta errs by 1e-2."""
    model = single_material(0.3).with_options(modes=8, **options)
    for c in ("original", "brass_top"):
        assert complex_loss_factors(model, c) == pytest.approx(np.full(8, 0.3), rel=1e-6)
        assert first_order_loss_factors(model)[c] == pytest.approx(np.full(8, 0.3), rel=1e-8)


def contrast(scale):
    """Steel between two lossy aluminium-like coatings (the paper's Table 1 stiffness):
    the coatings' loss factor is ``scale``, the steel's 0.001."""
    model = spec()
    soft = {"E1": 70e9, "E2": 70e9, "G12": 70e9 / 2.7, "nu12": 0.35}
    materials = [
        replace(model.specimen.materials[n], **soft, eta_E1=scale, eta_E2=0.6 * scale, eta_G12=1.5 * scale)
        for n in ("top_coating", "bottom_coating")
    ]
    materials.append(
        replace(
            model.specimen.materials["steel"],
            E1=200e9,
            E2=200e9,
            G12=77e9,
            nu12=0.3,
            eta_E1=0.001,
            eta_E2=0.001,
            eta_G12=0.001,
        )
    )
    return model.with_specimen(model.specimen.with_materials(materials))


def isolated(frequencies, gap=0.03):
    """Modes at least ``gap`` (relative) from their neighbours: damping does not mix them."""
    f = np.asarray(frequencies)
    apart = np.diff(f) / f[1:] > gap
    return np.concatenate([[True], apart]) & np.concatenate([apart, [True]])


@pytest.mark.parametrize("configuration", ["original", "brass_top"])
def test_first_order_error_shrinks_as_eta_squared(configuration):
    """First order vs the complex eigenproblem for isolated modes: Im(lambda*) has only odd
    powers of eta and Re only even ones, so the relative difference of the loss factors is
    O(eta^2).  The slope of log|relative difference| on log(eta), fitted over four loss
    factors of the coatings (0.1-0.4), is 2 +- 0.2 for every isolated mode (an error of
    first order would give 1)."""
    scales = np.array([0.1, 0.2, 0.3, 0.4])
    errors = []
    for s in scales:
        model = contrast(s).with_options(modes=10)
        exact = complex_loss_factors(model, configuration)
        errors.append(np.abs(first_order_loss_factors(model)[configuration] / exact - 1))
    keep = isolated(model.solve(configuration).frequencies_hz)
    errors = np.array(errors)[:, keep]
    assert keep.sum() >= 5 and errors.min() > 1e-6, "the differences must stand above solver precision"
    slopes = [np.polyfit(np.log(scales), np.log(errors[:, i]), 1)[0] for i in range(errors.shape[1])]
    assert slopes == pytest.approx([2.0] * len(slopes), abs=0.2)


def test_close_modes_keep_their_sum():
    """Degenerate pairs (the square plate of isotropic layers) are mixed by non-uniform
    damping: mode by mode the first-order estimate depends on the real basis the eigen-
    solver happens to return for the pair (the same pair came out 12 % off with the
    generalised shift-invert Lanczos and 1.4 % off with the standard-form one), but the
    pair's sum of Im(lambda) is a trace, invariant to the basis, and agrees to O(eta^2)
    like an isolated mode's (0.4 %, against 1 % at eta = 0.4)."""
    model = contrast(0.1).with_options(modes=10)
    lam = model.solve("original").modes.eigenvalues
    exact, first = complex_loss_factors(model, "original"), first_order_loss_factors(model)["original"]
    for pair in ([3, 4], [5, 6]):
        assert lam[pair[1]] / lam[pair[0]] - 1 < 1e-10
        assert exact[pair] @ lam[pair] == pytest.approx(first[pair] @ lam[pair], rel=4e-3)


def test_first_order_within_the_damping_scatter():
    """The range of the first-order estimate: with the coatings' loss factor up to 0.8
    (modal loss factors up to 0.12) every isolated mode is within 1.5 % of the complex
    solution, half a 3 % damping scatter."""
    model = contrast(0.8).with_options(modes=10)
    keep = isolated(model.solve("brass_top").frequencies_hz)
    ratio = first_order_loss_factors(model)["brass_top"] / complex_loss_factors(model, "brass_top")
    assert np.abs(ratio[keep] - 1).max() < 0.015


def test_columns_are_relative_eigenvalue_sensitivities():
    """d eta_i / d eta_p = d ln(lambda_i) / d ln(p), checked against central differences of
    the frequencies (lambda = (2 pi f)^2), step 1e-4 relative: truncation ~1e-8."""
    model = spec()
    col = loss_columns(model, [("steel", "eta_E1")])[:5, 0]
    steel = model.specimen.materials["steel"]
    h = 1e-4
    up, down = (
        model.with_specimen(model.specimen.with_materials([replace(steel, E1=steel.E1 * (1 + s))]))
        for s in (h, -h)
    )
    fd = (
        2 * np.log(up.solve("original").frequencies_hz) - 2 * np.log(down.solve("original").frequencies_hz)
    ) / (np.log1p(h) - np.log1p(-h))
    assert col == pytest.approx(fd, rel=1e-5, abs=1e-8)
