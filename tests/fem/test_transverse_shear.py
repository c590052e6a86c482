"""First-order shear deformation (transverse_shear) and rotary inertia against 3-D
elasticity, the Kirchhoff model, a beam closed form and mesh refinement."""

import math

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq

from fem.elements import ShearDifferencePlate
from fem.laminates.laminate import Laminate, Layer
from fem.laminates.material import Material
from fem.model import ModelOptions, SpecimenModel, solve_laminate
from fem.solver.assembly import unit_matrices
from fem.solver.mesh import PlateMesh
from tests.conftest import FREE_PLATES


def iso(E, nu, rho, name="iso"):
    return Material(name, E, E, E / (2 * (1 + nu)), nu, rho)


def plate(reference, thickness=None):
    p = reference["plate"]
    return Laminate((Layer(iso(p["E_Pa"], p["nu"], p["rho"]), thickness or p.get("t_m") or p["h_m"]),))


THICK = FREE_PLATES["thick_free_plate_3d"]
FV12 = FREE_PLATES["nafems_fv12_free_square_plate"]
#: The 4 m x 1 m thick plate turned so its long side runs along y: node numbering is x
#: fastest, so the band (and the Cholesky cost) follows the short side.
THICK_MESH = PlateMesh(THICK["plate"]["b_m"], THICK["plate"]["a_m"], 8, 32)


def relative(a, b):
    return np.asarray(a) / np.asarray(b) - 1


def twisting_share(solution):
    """Fraction of each mode's strain energy carried by D66 (twisting)."""
    energies = solution.laminate.stiffness[:, None] * solution.energies.stiffness[:18]
    return energies[15] / energies.sum(axis=0)


def test_thick_free_plate_against_3d_elasticity():
    """4 x 1 x 0.1 m free plate (a/h = 10 on the short side), 8 x 32 mesh (0.125 m, about
    h).  Full FSDT (shear + rotary inertia, k = 5/6) against CalculiX C3D20R: within 0.1 %
    for the first 4 elastic modes (the issue asks 1 %; measured at most 0.016 %: 3-D
    reference +-0.01 %, this mesh 0.02 % above its converged value).  Without rotary
    inertia FSDT is within 1 % (measured 0.12-0.59 %), and Kirchhoff misses modes 2 and 4,
    the twisting modes, by about 4 %."""
    lam = plate(THICK)
    reference = THICK["first6_elastic_hz"][:4]
    full = solve_laminate(lam, THICK_MESH, 4, transverse_shear=True, rotary_inertia=True).frequencies_hz
    shear_only = solve_laminate(lam, THICK_MESH, 4, transverse_shear=True).frequencies_hz
    kirchhoff = solve_laminate(lam, THICK_MESH, 4).frequencies_hz
    assert np.abs(relative(full, reference)).max() < 1e-3, relative(full, reference)
    assert np.abs(relative(shear_only, reference)).max() < 1e-2, relative(shear_only, reference)
    # Our Kirchhoff model reproduces the stored Kirchhoff values (4 digits: 0.03 %) ...
    np.testing.assert_allclose(kirchhoff, THICK["kirchhoff_first4_hz"], rtol=3e-4)
    # ... whose twisting modes (2, 4) are 3.9 % and 4.1 % above 3-D elasticity.
    assert np.all(relative(kirchhoff, reference)[[1, 3]] > 0.035)


def test_rotary_inertia_matches_rayleigh_beam_correction():
    """Kirchhoff + rotary inertia for the beam-like modes (0,2), (0,3), (0,4) of the 4 m
    long plate: the frequency drop agrees with Rayleigh's correction for a free-free beam,
    omega^2 = omega_0^2 / (1 + r^2 int phi'^2 / int phi^2), r^2 = h^2 / 12, with the exact
    Euler-Bernoulli mode shape phi (an independent closed form).  Within 5 % of the
    correction (measured 0.7-2.2 %): the plate adds rotary inertia of anticlastic w_y."""
    lam = plate(THICK)
    length, h = THICK["plate"]["a_m"], THICK["plate"]["h_m"]
    plain = solve_laminate(lam, THICK_MESH, 5)
    rotary = solve_laminate(lam, THICK_MESH, 5, rotary_inertia=True)
    beam_modes = [i for i, label in enumerate(plain.labels) if label.startswith("(0,")]
    assert [plain.labels[i] for i in beam_modes] == ["(0,2)", "(0,3)", "(0,4)"]
    x = np.linspace(0.0, length, 4001)
    expected = []
    for guess in (4.73, 7.85, 11.0):
        beta_l = brentq(lambda b: math.cos(b) * math.cosh(b) - 1, guess - 0.3, guess + 0.3)
        b = beta_l / length
        s = (math.cosh(beta_l) - math.cos(beta_l)) / (math.sinh(beta_l) - math.sin(beta_l))
        phi = np.cosh(b * x) + np.cos(b * x) - s * (np.sinh(b * x) + np.sin(b * x))
        slope = b * (np.sinh(b * x) - np.sin(b * x) - s * (np.cosh(b * x) + np.cos(b * x)))
        ratio = np.trapezoid(slope**2, x) / np.trapezoid(phi**2, x)
        expected.append(1 / math.sqrt(1 + h**2 / 12 * ratio) - 1)
    drop = relative(rotary.frequencies_hz, plain.frequencies_hz)[beam_modes]
    np.testing.assert_allclose(drop, expected, rtol=0.05)
    assert np.all(rotary.frequencies_hz < plain.frequencies_hz), "rotary inertia only adds kinetic energy"


def test_thin_plates_bending_modes_match_kirchhoff(paper_specimen):
    """a/h = 200 (NAFEMS FV12, 12 x 12) and 136 (the paper's plate, default mesh for 10
    modes): full FSDT within 0.05 % of Kirchhoff for every mode whose twisting (D66) energy
    share is below 20 %: FV12 modes 2, 3, 6, 7 and the paper's modes 2, 3, 6, 7 (measured at
    most 0.044 %).  Their shear and rotary-inertia terms scale as (h / wavelength)^2.

    The twisting modes (1, 4, 5, 8) are lowered more, by a free-edge boundary layer of
    width ~h whose effect is O(h/a) (``test_free_edge_layer_...``; Arnold and Falk 1990) and
    which 3-D elasticity confirms (``test_thick_free_plate_...``).  Resolved, it is about
    0.40 h/a (0.2 % at a/h = 200); an ordinary mesh captures part of it.  So for those modes
    we check only that FSDT lies below Kirchhoff by less than 0.40 h/a + 0.7 (h/a)^2."""
    cases = [(plate(FV12), PlateMesh(10.0, 10.0, 12, 12), 8, 10.0)]
    model = SpecimenModel(paper_specimen, ModelOptions(modes=10))
    cases.append((paper_specimen.laminate("original"), model.mesh, 10, 0.15))
    bending_modes = []
    for lam, mesh, n, span in cases:
        kirchhoff = solve_laminate(lam, mesh, n)
        fsdt = solve_laminate(lam, mesh, n, transverse_shear=True, rotary_inertia=True)
        difference = relative(fsdt.frequencies_hz, kirchhoff.frequencies_hz)
        bending = twisting_share(kirchhoff) < 0.2
        bending_modes.append(list(np.flatnonzero(bending) + 1))
        assert np.abs(difference[bending]).max() < 5e-4, difference
        ratio = lam.thickness / span
        assert np.all(difference < 0) and np.all(-difference < 0.40 * ratio + 0.7 * ratio**2), difference
    assert bending_modes == [[2, 3, 6, 7], [2, 3, 6, 7]]


def test_free_edge_layer_makes_twisting_modes_scale_with_h():
    """Why twisting modes differ from Kirchhoff at first order in h/a: on a 1 x 1 m free
    plate with elements of size h (resolving the edge layer), halving h from 0.1 to 0.05 m
    shrinks the FSDT - Kirchhoff difference of the twisting mode (1,1) by ~2 (measured 2.16:
    O(h), the edge layer) and of the bending modes 2, 3 by ~4 (measured 3.78, 3.67:
    O(h^2)).  Bands [1.8, 2.6] and [3.4, 4.2] allow for the next-order term."""
    ratio = []
    for h, n in ((0.1, 10), (0.05, 20)):
        lam = Laminate((Layer(iso(200e9, 0.3, 8000), h),))
        mesh = PlateMesh(1.0, 1.0, n, n)
        kirchhoff = solve_laminate(lam, mesh, 3).frequencies_hz
        ratio.append(relative(solve_laminate(lam, mesh, 3, transverse_shear=True).frequencies_hz, kirchhoff))
    shrink = ratio[0] / ratio[1]
    assert 1.8 < shrink[0] < 2.6 and np.all((shrink[1:] > 3.4) & (shrink[1:] < 4.2)), shrink


def test_no_shear_locking():
    """FV12 geometry at a/h = 1000 on an ordinary 12 x 12 mesh: FSDT (shear only) within
    0.005 % of Kirchhoff for the first 8 modes (measured <= 0.0031 %; the issue asks 0.05 %),
    and never above it (a locking element is too stiff).  Between a/h = 200 and 1000 the
    difference shrinks as (h/a)^2 on the same mesh (ratio 25; measured 24.5-24.9), whereas
    locking makes it grow: the Kirchhoff limit g = 0 is in the discrete space."""
    mesh = PlateMesh(10.0, 10.0, 12, 12)
    difference = {}
    for ratio in (200, 1000):
        lam = plate(FV12, thickness=10.0 / ratio)
        kirchhoff = solve_laminate(lam, mesh, 8).frequencies_hz
        difference[ratio] = relative(
            solve_laminate(lam, mesh, 8, transverse_shear=True).frequencies_hz, kirchhoff
        )
    assert np.all(difference[1000] < 0) and np.abs(difference[1000]).max() < 5e-5, difference[1000]
    np.testing.assert_allclose(difference[200] / difference[1000], 25.0, rtol=0.1)


def test_convergence_under_mesh_refinement():
    """1 x 1 x 0.1 m free plate, full FSDT, nested meshes 5, 10, 20 (elements 2h .. h/2):
    every one of the first 8 frequencies decreases under refinement (a conforming
    Rayleigh-Ritz discretisation, nested spaces), and the observed order
    log2((f5 - f10) / (f10 - f20)) is at least 3.5 (the element's O(h^4); measured 3.8-5.7)."""
    lam = Laminate((Layer(iso(200e9, 0.3, 8000), 0.1),))
    f = [
        solve_laminate(
            lam, PlateMesh(1.0, 1.0, n, n), 8, transverse_shear=True, rotary_inertia=True
        ).frequencies_hz
        for n in (5, 10, 20)
    ]
    assert np.all(f[0] > f[1]) and np.all(f[1] > f[2])
    order = np.log2((f[0] - f[1]) / (f[1] - f[2]))
    assert np.all(order > 3.5), order


@pytest.mark.parametrize("thickness,E", [(1e-4, 200e9), (1.1e-3, 200e9), (0.02, 200e9), (1.1e-3, 1200e9)])
@pytest.mark.parametrize("rotary_inertia", [False, True])
def test_exactly_six_rigid_body_modes_with_shear_element(thickness, E, rotary_inertia):
    """Dense check of the deflated solve with the FSDT element, a/h from 1500 to 7.5.
    Without rotary inertia the shear-strain DOFs carry no mass (M singular), so the dense
    reference is the definite pencil M x = mu (K - sigma M) x, mu = 1 / (lambda - sigma),
    sigma < 0: rigid-body modes have mu = 1/|sigma|, the largest, computed to ~eps
    relative.  Exactly six lie within 1e-8 of it (the next is 1/11 of it), and the deflated
    Lanczos solve returns the 7th to 12th eigenvalues to 1e-6."""
    lam = Laminate((Layer(iso(E, 0.3, 7800), thickness),))
    mesh = PlateMesh(0.15, 0.1, 4, 3)
    ours = solve_laminate(
        lam, mesh, 6, transverse_shear=True, rotary_inertia=rotary_inertia
    ).modes.eigenvalues
    units = unit_matrices(mesh, ShearDifferencePlate)
    coefficients = np.concatenate([lam.stiffness, lam.shear_stiffness])
    K = units.matrix(units.combined_data(coefficients, units.element_stiffness)).toarray()
    inertia = lam.inertia * ([1, 1, 1] if rotary_inertia else [1, 0, 0])
    M = units.matrix(units.combined_data(inertia, units.element_mass)).toarray()
    sigma = -0.1 * ours[0]
    mu = sla.eigh(M, K - sigma * M, eigvals_only=True)[::-1]
    assert np.sum(np.abs(mu * abs(sigma) - 1) < 1e-8) == 6
    np.testing.assert_allclose(sigma + 1 / mu[6:12], ours, rtol=1e-6)


def test_model_options_switch_the_effects(paper_specimen):
    """ModelOptions' fields reach the solve: each effect lowers every frequency of the
    bonded configuration, and the solution records what it modelled."""
    frequencies = {}
    for shear, rotary in ((False, False), (True, False), (False, True), (True, True)):
        options = ModelOptions(modes=5, divisions=8, transverse_shear=shear, rotary_inertia=rotary)
        solution = SpecimenModel(paper_specimen, options).solve("brass_top")
        assert solution.transverse_shear == shear and solution.inertia_terms == (
            (1, 1, 1) if rotary else (1, 0, 0)
        )
        frequencies[shear, rotary] = solution.frequencies_hz
    base = frequencies[False, False]
    for key in ((True, False), (False, True), (True, True)):
        assert np.all(frequencies[key] < base)
    assert np.all(frequencies[True, True] < frequencies[True, False])
