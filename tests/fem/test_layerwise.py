"""The layerwise (zig-zag) plate model: its limits (FSDT for one shear group, Kirchhoff for
thin stiff stacks), the shear groups and corrections, convergence, rigid-body modes and
the wiring (model option, spec key, effect)."""

import math
import pickle
import tomllib

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import fem.model
from fem.effects import effect
from fem.elements import LayerwisePlate, ShearDifferencePlate
from fem.elements.layerwise_plate import node_dofs
from fem.errors import ModelError, SpecError
from fem.laminates.laminate import Laminate, Layer
from fem.laminates.layerwise import (
    LayerwiseLaminate,
    inertia_names,
    layer_groups,
    stiffness_names,
    unit_matrices,
)
from fem.laminates.material import Material
from fem.model import ModelOptions, SpecimenModel, solve_laminate
from fem.solver.mesh import PlateMesh
from fem.spec import parse_spec
from fem.specimen import Parameter
from tests.fem.test_layerwise_sensitivity import (
    ADHESIVE,
    ALUMINIUM,
    FOAM,
    SKIN,
    sandwich,
)

GPA = 1e9
CFRP = Material("cfrp", 130 * GPA, 9 * GPA, 5 * GPA, 0.3, 1560.0, G13=5 * GPA, G23=3.2 * GPA)
GFRP = Material("gfrp", 40 * GPA, 10 * GPA, 4 * GPA, 0.28, 1950.0, G13=4 * GPA, G23=3.5 * GPA)


def relative(a, b):
    return np.asarray(a) / np.asarray(b) - 1


@pytest.mark.parametrize(
    "layers",
    [
        (Layer(ALUMINIUM, 8e-3, 0.0, "al"),),  # the 3-D control plate's section, a/h = 19
        (
            Layer(GFRP, 1.5e-3, 0.0, "g1"),
            Layer(CFRP, 3e-3, math.radians(30), "c"),
            Layer(GFRP, 1.5e-3, 0.0, "g2"),
        ),
    ],
    ids=["homogeneous", "laminate"],
)
def test_one_shear_group_is_the_fsdt(layers, monkeypatch):
    """One shear group (a single layer, or a stack without a soft layer under "blocks"):
    Phi = z, the group's shear stiffness is Whitney's (k = 5/6 for the homogeneous plate),
    the inertia the full FSDT inertia, so the frequencies equal those of
    ``transverse_shear`` with ``rotary_inertia`` to round-off (tolerance 1e-11; the
    eigen-solver returns eigenvalues to ~1e-12), the FSDT element given the layerwise
    one's bases (u, v and the shear strains of a stiff group on the C0 basis; the FSDT
    element keeps them bicubic, and the two differ by 1.4e-4 here, the discretisation's
    order).  The laminate's 30-degree core makes A45, B16 .. D26 live."""

    class ShearDifferenceC0(ShearDifferencePlate):
        C0_FIELDS = ("u", "v", "gx", "gy")
        NODE_DOFS = node_dofs(ShearDifferencePlate.FIELDS, C0_FIELDS)

    lam = Laminate(layers)
    mesh = PlateMesh(0.15, 0.1, 9, 6)
    layerwise = solve_laminate(lam, mesh, 10, theory="layerwise", layer_groups="blocks")
    monkeypatch.setattr(fem.model, "ShearDifferencePlate", ShearDifferenceC0)
    fsdt = solve_laminate.__wrapped__(lam, mesh, 10, transverse_shear=True, rotary_inertia=True)
    assert layerwise.layerwise.groups == (0,) * len(layers)
    np.testing.assert_allclose(layerwise.layerwise.shear_correction[0], lam.shear_correction, rtol=1e-13)
    np.testing.assert_allclose(layerwise.frequencies_hz, fsdt.frequencies_hz, rtol=1e-11)


def test_homogeneous_shear_correction_and_sandwich_core():
    """Each group's shear stiffness is energy-equivalent to the Jourawski shear stress:
    5/6 for a homogeneous layer (a parabola), also when the layer is split in halves
    (each half of a parabola has the same ratio); close to 1 for a soft core between
    stiff skins, whose shear stress is nearly constant (measured 0.999999; the skins' 0.763)."""
    half = LayerwiseLaminate.of(
        Laminate((Layer(ALUMINIUM, 4e-3, 0.0, "a"), Layer(ALUMINIUM, 4e-3, 0.0, "b"))), "layers"
    )
    np.testing.assert_allclose(half.shear_correction, 5 / 6, rtol=1e-13)
    core = LayerwiseLaminate.of(sandwich().laminate("original"))
    assert core.groups == (0, 1, 0)
    assert np.all(core.shear_correction[1] > 0.999) and np.all(core.shear_correction[1] < 1)


def test_generalised_coefficients_of_one_group_are_clt_moments():
    """With one group Phi = z, so E = B, F = G = D, the inertia J = I1, K = L = I2, and the
    A, B, D and I0..I2 blocks are the laminate's own (``fem.laminates.laminate``), to round-off."""
    lam = Laminate((Layer(GFRP, 1e-3, 0.2, "g"), Layer(CFRP, 2e-3, 0.0, "c")))
    stack = LayerwiseLaminate.of(lam, "blocks")
    s, i = stack.stiffness, stack.inertia
    assert len(s) == len(stiffness_names(1)) == 18 + 12 + 6 + 3 and len(i) == len(inertia_names(1)) == 6
    scale = np.abs(s[:18]).reshape(3, 6).max(axis=1).repeat(6)
    np.testing.assert_allclose(s[:18] / scale, lam.stiffness / scale, atol=1e-14)
    np.testing.assert_allclose(s[18:24] / scale[6:12], lam.stiffness[6:12] / scale[6:12], atol=1e-14)  # E = B
    for block in (s[24:30], s[30:36]):  # F = D and G = D
        np.testing.assert_allclose(block / scale[12:], lam.stiffness[12:] / scale[12:], atol=1e-14)
    np.testing.assert_allclose(s[36:], lam.shear_stiffness, rtol=1e-13)
    np.testing.assert_allclose(i, lam.inertia[[0, 1, 2, 1, 2, 2]], rtol=1e-13, atol=1e-16)


def test_thin_stiff_stack_is_kirchhoff():
    """A cross-ply CFRP stack at a/h = 1000 with one shear group per layer: the layerwise
    model within 0.05 % of Kirchhoff (with rotary inertia) for the first 8 modes (the
    tolerance of the FSDT's locking test; measured at most 0.0040 %), and never above it (a
    locking element is too stiff): the Kirchhoff limit g = 0 is in the discrete space.  At
    a/h = 200 the difference is 25x larger ((h/a)^2 on the same mesh, which does not resolve
    the free-edge layer of width ~h; measured 24.5-25.0x), whereas locking would grow it."""
    mesh = PlateMesh(0.15, 0.15, 10, 10)
    difference = {}
    for ratio in (200, 1000):
        t = 0.15 / ratio / 3
        lam = Laminate((Layer(CFRP, t, 0.0, "a"), Layer(CFRP, t, math.pi / 2, "b"), Layer(CFRP, t, 0.0, "c")))
        kirchhoff = solve_laminate(lam, mesh, 8, rotary_inertia=True)
        layerwise = solve_laminate(lam, mesh, 8, theory="layerwise", layer_groups="layers")
        assert layerwise.layerwise.n_groups == 3
        difference[ratio] = relative(layerwise.frequencies_hz, kirchhoff.frequencies_hz)
    assert np.all(difference[1000] < 0) and np.abs(difference[1000]).max() < 5e-4, difference[1000]
    np.testing.assert_allclose(difference[200] / difference[1000], 25.0, rtol=0.1)


def test_convergence_under_mesh_refinement():
    """An unsymmetric thick sandwich, 100 x 100 mm: 2 mm skins on a 16 mm foam with 4 mm
    aluminium on the top skin (two shear groups), nested meshes 6, 12, 24: every one of the
    first 8 frequencies decreases (conforming Rayleigh-Ritz, nested spaces), and the
    observed order log2((f6 - f12) / (f12 - f24)) is the bicubic Hermite element's O(h^4)
    in the eigenvalues: every mode above 3.5 (the FSDT element's bound), the median within
    4 +- 0.5 (measured 3.86-5.67, median 4.0).  The plate is small so that the meshes
    resolve the skins' free-edge zone, sqrt(2 D_skin / S_core) = 11 mm wide.  Without the
    core's stretch: with it, see ``test_core_stretch_converges``."""
    lam = Laminate(
        (
            Layer(SKIN, 2e-3, 0.0, "s1"),
            Layer(FOAM, 16e-3, 0.0, "c"),
            Layer(SKIN, 2e-3, 0.0, "s2"),
            Layer(ALUMINIUM, 4e-3, 0.0, "al"),
        )
    )
    solutions = [
        solve_laminate(lam, PlateMesh(0.1, 0.1, n, n), 8, theory="layerwise", core_stretch=False)
        for n in (6, 12, 24)
    ]
    assert solutions[0].layerwise.groups == (0, 1, 0, 0) and solutions[0].layerwise.stretch == ()
    f = np.array([s.frequencies_hz for s in solutions])
    assert np.all(f[0] > f[1]) and np.all(f[1] > f[2])
    order = np.log2((f[0] - f[1]) / (f[1] - f[2]))
    assert np.all(order > 3.5) and abs(np.median(order) - 4) < 0.5, order


def test_core_stretch_converges():
    """With the core's transverse normal strain, the bonded foam sandwich of the 3-D
    references (250 x 200 mm, 6 mm foam, 1 mm aluminium on a 0.1 mm bond line) converges
    from above under nested refinement 8, 16, 24 (10 modes), the default mesh for 10 modes
    (16 elements) within 0.03 % of the 24-element mesh (measured at most 0.014 %), and
    that within 0.01 % of 32 elements (measured earlier: 0.008 %).  The order is lower
    than 4 here (about 2.5, the d = 16 -> 24 step): the stretch and the shear of a soft
    core have free-edge zones about the core thickness (6 mm) wide, which elements of
    10-30 mm do not resolve; their weight in the frequencies shrinks all the same."""
    fabric = Material(
        "cfrp_fabric", 62 * GPA, 60 * GPA, 4.8 * GPA, 0.05, 1500.0, G13=3.5 * GPA, G23=3.5 * GPA
    )
    pvc = Material(
        "pvc_foam", 0.1 * GPA, 0.1 * GPA, 0.035 * GPA, 0.4286, 80.0, G13=0.035 * GPA, G23=0.035 * GPA
    )
    lam = Laminate(
        (
            Layer(ALUMINIUM, 1e-3, 0.0, "al"),
            Layer(ADHESIVE, 1e-4, 0.0, "ad"),
            Layer(fabric, 0.5e-3, 0.0, "s1"),
            Layer(pvc, 6e-3, 0.0, "c"),
            Layer(fabric, 0.5e-3, 0.0, "s2"),
        )
    )
    f = np.array(
        [
            solve_laminate(
                lam, PlateMesh.with_element_size(0.25, 0.2, d), 10, theory="layerwise"
            ).frequencies_hz
            for d in (8, 16, 24)
        ]
    )
    assert np.all(f[0] > f[1]) and np.all(f[1] > f[2])
    assert np.abs(f[1] / f[2] - 1).max() < 3e-4, f[1] / f[2] - 1


def test_exactly_six_rigid_body_modes():
    """Dense check of the deflated solve with the layerwise element (the bonded sandwich,
    three groups, the foam stretching): in the definite pencil M x = mu (K - sigma M) x
    exactly six eigenvalues are the rigid-body ones (mu = 1/|sigma| to 1e-8), the g fields
    are zero in rigid motion (as e is), and the Lanczos solve returns the next six
    eigenvalues to 1e-6."""
    lam = sandwich().laminate("al_bottom")
    stack = LayerwiseLaminate.of(lam)
    mesh = PlateMesh(0.08, 0.06, 3, 2)
    ours = solve_laminate(lam, mesh, 6, theory="layerwise").modes.eigenvalues
    assert stack.stretch == (3,)  # the foam
    units = unit_matrices(mesh, stack.n_groups, 2 * len(stack.stretch), stack.soft)
    K = units.matrix(units.combined_data(stack.stiffness, units.element_stiffness)).toarray()
    M = units.matrix(units.combined_data(stack.inertia, units.element_mass)).toarray()
    rigid = units.rigid_body_modes
    assert np.abs(K @ rigid).max() < 1e-9 * np.abs(K).max()
    sigma = -0.1 * ours[0]
    mu = sla.eigh(M, K - sigma * M, eigvals_only=True)[::-1]
    assert np.sum(np.abs(mu * abs(sigma) - 1) < 1e-8) == 6
    np.testing.assert_allclose(sigma + 1 / mu[6:12], ours, rtol=1e-6)


def test_groups():
    """ "auto": one group per layer (plies of a cross-ply zig-zag), except that the layers
    that are not soft (shear modulus above 0.1 of the stack's largest) and carry under 5 %
    of the shear compliance each (a sandwich's skins, a bonded aluminium plate) share one,
    and adjacent layers of one material and angle are one; "blocks": soft layers alone,
    runs of stiff layers together; "layers": one per layer; unknown: one-line error."""
    bonded = Laminate(
        (
            Layer(CFRP, 1.25e-3, 0.0, "c1"),
            Layer(GFRP, 2.5e-3, math.pi / 2, "g"),
            Layer(CFRP, 1.25e-3, 0.0, "c2"),
            Layer(ADHESIVE, 1e-4, 0.0, "ad"),
            Layer(ALUMINIUM, 2e-3, 0.0, "al"),
        )
    )
    assert layer_groups(bonded) == layer_groups(bonded, "layers") == (0, 1, 2, 3, 4)
    assert layer_groups(bonded, "blocks") == (0, 0, 0, 1, 2)
    split = Laminate((Layer(CFRP, 1e-3, 0.0, "a"), Layer(CFRP, 1e-3, 0.0, "b"), Layer(GFRP, 1e-3, 0.0, "c")))
    assert layer_groups(split) == (0, 0, 1) and layer_groups(split, "layers") == (0, 1, 2)
    bonded_sandwich = sandwich().laminate("al_bottom")
    assert layer_groups(bonded_sandwich) == (0, 1, 0, 2, 0)
    assert layer_groups(bonded_sandwich, "blocks") == (0, 1, 2, 3, 4)
    assert layer_groups(Laminate((Layer(FOAM, 5e-3, 0.0, "f"),))) == (0,)
    with pytest.raises(ModelError, match="grouping 'plies' is unknown"):
        layer_groups(bonded, "plies")
    with pytest.raises(ModelError, match="theory = 'zigzag' is unknown"):
        ModelOptions(theory="zigzag")


def test_element_classes_are_shared_and_pickle():
    """One element class per group count (so unit matrices are cached per count), found
    by name, so solutions holding it pickle to worker processes."""
    three = LayerwisePlate.with_groups(3)
    assert three is LayerwisePlate.with_groups(3) and len(three.NODE_DOFS) == 10 + 6 * 3
    assert pickle.loads(pickle.dumps(three)) is three
    solution = SpecimenModel(sandwich(), ModelOptions(modes=3, divisions=4, theory="layerwise")).solve(
        "al_bottom"
    )
    np.testing.assert_array_equal(
        pickle.loads(pickle.dumps(solution)).frequencies_hz, solution.frequencies_hz
    )


SPEC = """
[specimen]
name = "sandwich"
length_mm = 80
width_mm = 60
layers = [ { material = "skin", thickness_mm = 0.5 }, { material = "foam", thickness_mm = 4 },
           { material = "skin", thickness_mm = 0.5 } ]
[materials.skin]
E1_GPa = 62
E2_GPa = 60
G12_GPa = 4.8
nu12 = 0.05
density_kg_m3 = 1500
G13_GPa = 3.5
identify = true
[materials.foam]
E1_GPa = 0.1
E2_GPa = 0.1
G12_GPa = 0.035
nu12 = 0.43
density_kg_m3 = 80
[model]
modes = 4
divisions = 6
"""


def test_spec_theory_key():
    """`[model] theory = "layerwise"` and `core_stretch` reach the solve; a wrong value is
    a one-line error with a suggestion."""
    model = parse_spec(tomllib.loads(SPEC + 'theory = "layerwise"\n'))
    assert model.options.theory == "layerwise" and model.solve("original").layerwise.groups == (0, 1, 0)
    with pytest.raises(
        SpecError, match=r"\[model\].theory = 'layerwize' is unknown; did you mean 'layerwise'"
    ):
        parse_spec(tomllib.loads(SPEC + 'theory = "layerwize"\n'))
    with pytest.raises(SpecError, match=r"\[model\].layer_groups = 'all'"):
        parse_spec(tomllib.loads(SPEC + 'layer_groups = "all"\n'))
    off = parse_spec(tomllib.loads(SPEC + 'theory = "layerwise"\ncore_stretch = false\n'))
    assert off.solve("original").layerwise.stretch == () and model.solve("original").layerwise.stretch == (1,)
    with pytest.raises(SpecError, match=r"\[model\].core_stretch = 'no': need true or false"):
        parse_spec(tomllib.loads(SPEC + 'core_stretch = "no"\n'))


def test_layerwise_effect():
    """The effect switches the theory; free, it brings G13, G23 of the identified materials
    (as transverse_shear does: it is that physics and more) and of the soft specimen
    layers (not identified already), and its note states the defaults; on a stack without
    a soft layer it has nothing to add to transverse_shear, so it offers no variant."""
    model = parse_spec(tomllib.loads(SPEC))
    on = effect("layerwise").fixed(model, {"kind": "layerwise"})
    assert on.model.options.theory == "layerwise" and on.free == ()
    (variant,) = effect("layerwise").free(model)
    assert variant.free == (
        Parameter("G13", "skin"),
        Parameter("G23", "skin"),
        Parameter("G13", "foam"),
        Parameter("G23", "foam"),
    )
    assert "on their own: foam" in variant.note
    assert "assumed G23 = G12 for skin, G13 = G23 = G12 for foam" in variant.note
    frequencies = variant.model.frequencies()["original"]
    assert np.all(frequencies < model.frequencies()["original"])  # the soft core lowers every mode
    plain = parse_spec(tomllib.loads(SPEC.replace("G12_GPa = 0.035", "G12_GPa = 3.5")))
    assert effect("layerwise").free(plain) == []


def test_sparse_unit_matrices_sum_as_the_dense_ones(monkeypatch):
    """Element unit matrices kept sparse (above ``SPARSE_UNITS_ABOVE``, the layerwise
    element's ~180) give the dense ones' K and M data to round-off (1e-13 of the largest
    entry: two summation orders of 179 terms), and the same Gauss-grid-free quantities
    made from them (the first unit mass)."""
    from fem.solver import assembly
    from fem.solver.assembly import UnitMatrices

    stack = LayerwiseLaminate.of(sandwich().laminate("al_bottom"))
    element = LayerwisePlate.with_groups(stack.n_groups, 2 * len(stack.stretch))
    mesh = PlateMesh(0.08, 0.06, 3, 2)
    forms = {}
    for above in (0, 1 << 40):
        monkeypatch.setattr(assembly, "SPARSE_UNITS_ABOVE", above)
        units = UnitMatrices(mesh, element)
        assert sp.issparse(units.element_stiffness) == (above == 0)
        forms[above] = (
            units.combined_data(stack.stiffness, units.element_stiffness),
            units.combined_data(stack.inertia, units.element_mass),
            units.first_unit_mass.toarray(),
        )
    for sparse, dense in zip(forms[0], forms[1 << 40], strict=True):
        assert np.abs(sparse - dense).max() <= 1e-13 * np.abs(dense).max()
