"""Classical lamination theory against closed forms, and its derivatives against
central differences."""

import math

import numpy as np
import pytest

from fem.laminates.laminate import COEFFICIENTS, Laminate, Layer, reduced_stiffness, transformation
from fem.laminates.material import Material

STEEL = Material("steel", 201e9, 200e9, 78e9, 0.29, 7900)
CFRP = Material("cfrp", 140e9, 10e9, 5e9, 0.3, 1600)


def test_isotropic_single_layer_closed_form():
    """A = E h / (1 - nu^2), D = E h^3 / 12 (1 - nu^2), B = 0; I0 = rho h (textbook CLT)."""
    E, nu, h = 200e9, 0.3, 2e-3
    iso = Material("iso", E, E, E / (2 * (1 + nu)), nu, 7800)
    lam = Laminate((Layer(iso, h),))
    m = lam.matrices()
    assert m["A"][0, 0] == pytest.approx(E * h / (1 - nu**2), rel=1e-14)
    assert m["A"][0, 1] == pytest.approx(nu * E * h / (1 - nu**2), rel=1e-14)
    assert m["A"][2, 2] == pytest.approx(E * h / (2 * (1 + nu)), rel=1e-14)
    assert m["D"][0, 0] == pytest.approx(E * h**3 / (12 * (1 - nu**2)), rel=1e-12)
    assert np.abs(m["B"]).max() < 1e-12 * m["A"].max() * h
    assert lam.inertia[0] == pytest.approx(7800 * h)
    assert lam.inertia[1] == pytest.approx(0, abs=1e-18)
    assert lam.inertia[2] == pytest.approx(7800 * h**3 / 12)


def test_off_axis_transformation_known_cases():
    """At 90 deg the axes swap; at 45 deg Q16 = (Q11 - Q22)/4 ... checked via invariants:
    Q11 + Q22 + 2 Q12 and Q66 - Q12 are rotation invariant (Tsai-Pagano U1..U5)."""
    q, _ = reduced_stiffness(CFRP)
    q90 = transformation(math.pi / 2) @ q
    assert q90[0] == pytest.approx(q[2]) and q90[2] == pytest.approx(q[0])
    assert abs(q90[4]) < 1e-6 * q[0] and abs(q90[5]) < 1e-6 * q[0]
    for angle in np.radians([0, 17, 30, 45, 71, 120]):
        qb = transformation(angle) @ q
        assert qb[0] + qb[2] + 2 * qb[1] == pytest.approx(q[0] + q[2] + 2 * q[1], rel=1e-13)
        assert qb[3] - qb[1] == pytest.approx(q[3] - q[1], rel=1e-12)


def test_mirrored_stack_flips_B_only():
    stack = (Layer(STEEL, 7e-4, label="a"), Layer(CFRP, 3e-4, 0.4, label="b"), Layer(STEEL, 1e-4, label="c"))
    lam, mirror = Laminate(stack), Laminate(stack[::-1])
    x, xm = lam.stiffness, mirror.stiffness
    np.testing.assert_allclose(xm[:6], x[:6], rtol=1e-13)
    np.testing.assert_allclose(xm[6:12], -x[6:12], rtol=1e-12)
    np.testing.assert_allclose(xm[12:], x[12:], rtol=1e-12)
    assert COEFFICIENTS[6] == "B11"


@pytest.mark.parametrize(
    "kind,target",
    [
        ("E1", "cfrp"),
        ("E2", "cfrp"),
        ("G12", "cfrp"),
        ("nu12", "cfrp"),
        ("density", "cfrp"),
        ("E1", "steel"),
        ("nu12", "steel"),
        ("thickness", "b"),
        ("thickness", "c"),
        ("angle", "b"),
    ],
)
def test_stiffness_derivatives_match_central_differences(kind, target):
    """Analytic dX/dp and dI/dp against central differences (step 1e-6 relative:
    truncation ~1e-12, round-off ~1e-10; tolerance 1e-7 of the largest entry)."""

    def build(value):
        mats = {"steel": STEEL, "cfrp": CFRP}
        if kind in ("E1", "E2", "G12", "nu12", "density"):
            mats[target] = mats[target].with_values(**{kind: value})
        layers = [
            Layer(mats["steel"], 7e-4, label="a"),
            Layer(mats["cfrp"], 3e-4, 0.4, label="b"),
            Layer(mats["steel"], 1e-4, label="c"),
        ]
        if kind in ("thickness", "angle"):
            layers = [
                Layer(
                    l.material,
                    value if (l.label == target and kind == "thickness") else l.thickness,
                    value if (l.label == target and kind == "angle") else l.angle,
                    l.label,
                )
                for l in layers
            ]
        return Laminate(tuple(layers))

    mats = {"steel": STEEL, "cfrp": CFRP}
    if kind in ("thickness", "angle"):
        value = {"a": (7e-4, 0.0), "b": (3e-4, 0.4), "c": (1e-4, 0.0)}[target][
            0 if kind == "thickness" else 1
        ]
    else:
        value = getattr(mats[target], kind)
    lam = build(value)
    dx, di = lam.derivative(kind, target)
    h = 1e-6 * abs(value)
    fd_x = (build(value + h).stiffness - build(value - h).stiffness) / (2 * h)
    fd_i = (build(value + h).inertia - build(value - h).inertia) / (2 * h)
    scale_x = np.abs(dx).max() or 1.0
    assert np.abs(dx - fd_x).max() < 1e-7 * scale_x
    if np.abs(di).max() > 0:
        assert np.abs(di - fd_i).max() < 1e-7 * np.abs(di).max()
    else:
        assert np.abs(fd_i).max() < 1e-12
