"""Laminate transverse shear stiffness: shear correction against closed forms, the
default for missing G13/G23, and exact derivatives against central differences."""

import math
from dataclasses import replace

import numpy as np
import pytest

from fem.laminates.laminate import Laminate, Layer
from fem.laminates.laminate_shear import shear_stiffness
from fem.laminates.material import Material

STEEL = Material("steel", 201e9, 200e9, 78e9, 0.29, 7900, G13=70e9, G23=60e9)
CFRP = Material("cfrp", 140e9, 10e9, 5e9, 0.3, 1600, G13=5e9, G23=3.5e9)
COATING = Material("coating", 70e9, 68e9, 25e9, 0.33, 2700)  # G13, G23 not given


def test_homogeneous_plate_gets_five_sixths():
    """One homogeneous layer, also split into sub-layers at other angles of an isotropic
    material: k44 = k55 = 5/6 (Reissner's value) to rounding (1e-14), and for a rotated
    orthotropic ply A = 5/6 h [Qb44, Qb55, Qb45]."""
    iso = Material("iso", 210e9, 210e9, 210e9 / 2.6, 0.3, 7850)
    for stack in ((Layer(iso, 0.1),), (Layer(iso, 0.03), Layer(iso, 0.05, 0.4), Layer(iso, 0.02, 1.2))):
        k44, k55 = Laminate(stack).shear_correction
        assert k44 == pytest.approx(5 / 6, rel=1e-14) and k55 == pytest.approx(5 / 6, rel=1e-14)
    ply = Layer(CFRP, 2e-3, math.radians(30))
    np.testing.assert_allclose(Laminate((ply,)).shear_stiffness, 5 / 6 * 2e-3 * ply.shear_moduli, rtol=1e-13)
    m, n = math.cos(math.radians(30)), math.sin(math.radians(30))
    np.testing.assert_allclose(
        ply.shear_moduli,
        [3.5e9 * m * m + 5e9 * n * n, 5e9 * m * m + 3.5e9 * n * n, 1.5e9 * m * n],
        rtol=1e-14,
    )


def test_two_layer_stack_against_hand_computation():
    """Two layers of thickness t (unit Qb11 ratio 2 : 1 bottom to top, G ratio 1 : 1/2),
    worked by hand (exact fractions): z_n = -t/6, D* = 11/12 Q t^3, g piecewise quadratic,
    int g^2/G dz = (79/270 + 229/540) Q^2 t^5 / G, hence A55 = 605/516 G t and
    k55 = 605/774 = 0.78165.  Tolerance: rounding (1e-13); the scale must not matter."""
    for t, q, g in ((1.0, 1.0, 1.0), (1e-3, 1e11, 1e10)):
        thickness = np.array([t, t])
        axial = np.array([2 * q, q])
        shear = np.array([[g, g, 0.0], [g / 2, g / 2, 0.0]])
        a44, a55, a45 = shear_stiffness(thickness, axial, axial, shear)
        assert a55 == pytest.approx(605 / 516 * g * t, rel=1e-13)
        assert a44 == pytest.approx(a55, rel=1e-14) and a45 == 0


def test_sandwich_matches_sandwich_theory():
    """Thin stiff faces (0.2 mm, 70 GPa) on a soft core (5 mm foam, E 70 MPa, G 25 MPa):
    the core carries a nearly uniform shear stress and sandwich theory (Allen 1969) gives
    A55 = G_core d^2 / h_core, d = distance between face centroids.  Within 0.5 %, the
    neglected terms (core bending ~0.4 %, face shear compliance); measured 0.06 %.  The
    correction factor relative to int G dz is then far below 5/6 (0.013)."""
    face = Material("face", 70e9, 70e9, 26e9, 0.3, 2700)
    core = Material("core", 70e6, 70e6, 25e6, 0.4, 100)
    lam = Laminate((Layer(face, 0.2e-3), Layer(core, 5e-3), Layer(face, 0.2e-3)))
    assert lam.shear_stiffness[1] == pytest.approx(25e6 * 5.2e-3**2 / 5e-3, rel=5e-3)
    k44, k55 = lam.shear_correction
    assert k55 < 0.02 and k44 == pytest.approx(k55, rel=1e-12)


def test_default_shear_moduli_are_stated():
    """G13, G23 not given default to G12 (exact for isotropic materials); reports can ask
    which materials used the default, and a given modulus is kept."""
    assert COATING.transverse_shear_moduli == (25e9, 25e9)
    assert COATING.defaulted_shear_moduli == ("G13", "G23")
    assert COATING.value("G13") == 25e9
    partial = replace(COATING, name="partial", G13=20e9)
    assert partial.transverse_shear_moduli == (20e9, 25e9) and partial.defaulted_shear_moduli == ("G23",)
    lam = Laminate((Layer(COATING, 2e-4), Layer(STEEL, 7e-4), Layer(partial, 2e-4)))
    assert lam.defaulted_shear_moduli == {"coating": ("G13", "G23"), "partial": ("G23",)}


def rebuilt(laminate, kind, target, value):
    """The laminate with one parameter set (material kinds by name, layer kinds by label)."""
    layers = []
    for layer in laminate.layers:
        if layer.material.name == target and kind not in ("thickness", "angle"):
            layer = replace(layer, material=layer.material.with_values(**{kind: value}))
        elif layer.label == target and kind in ("thickness", "angle"):
            layer = replace(layer, **{kind: value})
        layers.append(layer)
    return Laminate(tuple(layers))


STACK = Laminate(
    (
        Layer(COATING, 2e-4, label="a"),
        Layer(STEEL, 7e-4, math.radians(10), label="b"),
        Layer(CFRP, 3e-4, math.radians(-35), label="c"),
    )
)
CASES = [(k, "steel") for k in ("E1", "E2", "G12", "nu12", "G13", "G23")] + [
    ("G12", "coating"),
    ("G13", "coating"),
    ("E2", "cfrp"),
    ("G23", "cfrp"),
    ("thickness", "a"),
    ("thickness", "c"),
    ("angle", "b"),
    ("angle", "c"),
]


@pytest.mark.parametrize("kind,target", CASES, ids=lambda x: str(x))
def test_shear_derivatives_match_central_differences(kind, target):
    """Unsymmetric stack with rotated orthotropic plies and a defaulted material: every
    d[A44, A55, A45]/dp agrees with central differences (relative step 1e-6: truncation
    ~1e-12, rounding ~1e-10 of the column) to 1e-7 of the column's largest entry.  A
    defaulted G13, G23 follows G12; density leaves the shear stiffness unchanged."""
    if kind in ("thickness", "angle"):
        value = next(getattr(layer, kind) for layer in STACK.layers if layer.label == target)
    else:
        value = next(layer.material.value(kind) for layer in STACK.layers if layer.material.name == target)
    h = 1e-6 * abs(value)
    finite = (
        rebuilt(STACK, kind, target, value + h).shear_stiffness
        - rebuilt(STACK, kind, target, value - h).shear_stiffness
    ) / (2 * h)
    exact = STACK.shear_derivative(kind, target)
    assert np.abs(exact).max() > 0
    assert np.abs(exact - finite).max() < 1e-7 * np.abs(exact).max(), (exact, finite)
    assert not np.any(STACK.shear_derivative("density", "steel"))


def test_a_batch_of_stacks_is_each_stack_alone():
    """The shear stiffness of several stacks at once (a leading batch axis, what the
    derivatives of every parameter in one complex-step pass use) equals each stack's own,
    to rounding (1e-14): three-layer stacks with random thicknesses and moduli."""
    rng = np.random.default_rng(3)
    thickness = rng.uniform(1e-4, 1e-3, (5, 3))
    q11, q22 = rng.uniform(5e9, 150e9, (5, 3)), rng.uniform(5e9, 150e9, (5, 3))
    shear = rng.uniform(1e9, 30e9, (5, 3, 3)) * [1, 1, 0.1]
    batch = shear_stiffness(thickness, q11, q22, shear)
    alone = np.array([shear_stiffness(*x) for x in zip(thickness, q11, q22, shear, strict=True)])
    assert batch.shape == (5, 3)
    assert np.allclose(batch, alone, rtol=1e-14, atol=0)


def test_every_derivative_at_once_is_each_alone():
    """``shear_derivatives`` (one complex-step pass for all of them) gives the rows of
    ``shear_derivative`` taken one at a time (the central-difference test checks those)."""
    together = STACK.shear_derivatives(CASES)
    for row, (kind, target) in zip(together, CASES, strict=True):
        alone = STACK.shear_derivative(kind, target)
        assert np.allclose(row, alone, rtol=1e-14, atol=1e-14 * np.abs(alone).max())
