"""The layerwise model against the independent 3-D elasticity references (CalculiX C3D20R,
mesh-converged to 1e-5 .. 2e-4 of each frequency; ``tests/data/solid3d``), with the true
material properties, the first 10 flexural modes of every configuration paired by the MAC
of w (``tests.fem.solid3d``)."""

import numpy as np
import pytest

from fem.laminates.layerwise import LayerwiseLaminate
from tests.fem import solid3d


def needs(case):
    return pytest.mark.skipif(
        not solid3d.available(case),
        reason=f"3-D reference tests/data/solid3d/{case}.json not generated yet "
        "(python tests/data/solid3d/generate.py --case " + case + ")",
    )


def check(case, configuration, tolerance, **options):
    error, macs = solid3d.errors(case, configuration, theory="layerwise", **options)
    assert np.all(macs > 0.95), macs  # the pairing is unambiguous
    assert np.abs(error).max() < tolerance, np.round(100 * error, 3)
    return error


@needs("foam_sandwich")
@pytest.mark.parametrize("configuration", ["original", "al_bottom", "al_top"])
def test_foam_sandwich(configuration):
    """The issue's acceptance: within 0.2 % for the first 10 modes of all three
    configurations (measured: original 0.063 %, bonded 0.034 %; the FSDT with rotary
    inertia is 0.37 % and 4.7 % off, Kirchhoff 100 % and 126 %)."""
    check("foam_sandwich", configuration, 2e-3)


@needs("laminate_on_adhesive")
@pytest.mark.parametrize("configuration", ["original", "al_bottom", "al_top"])
def test_laminate_on_adhesive(configuration):
    """The issue's acceptance: a laminate on a 0.1 mm bond line within 0.1 % (measured:
    original 0.035 %, bonded 0.079 %; the FSDT 0.035 % and 0.32 %)."""
    check("laminate_on_adhesive", configuration, 1e-3)


@needs("thick_homogeneous")
def test_thick_homogeneous_control():
    """Control: one layer, so the layerwise model is the FSDT with k = 5/6; both within
    0.2 % of 3-D at a/h = 19 for the first 10 modes (measured -0.014 .. -0.187 %, growing
    with the wavenumber: the first-order theory's own limit).  The same frequencies to
    2e-6: the layerwise element puts u, v and the shear strains on the C0 basis where the
    FSDT element keeps them bicubic (measured 1.3e-6 apart at most; equal to round-off on
    equal bases, ``test_layerwise.py::test_one_shear_group_is_the_fsdt``)."""
    layerwise = check("thick_homogeneous", "original", 2e-3)
    fsdt, _ = solid3d.errors("thick_homogeneous", "original", transverse_shear=True, rotary_inertia=True)
    np.testing.assert_allclose(layerwise, fsdt, atol=2e-6)


@needs("spruce_plate")
def test_one_wood_layer_is_the_first_order_shear_plate():
    """One spruce layer, whose rolling shear modulus is 16 x below its G13: one shear group
    and no stretching field (a layer is soft only against another layer), so the
    layerwise model is the FSDT with rotary inertia, both within 0.2 % of 3-D at a/h = 30
    (measured -0.013 .. -0.196 %), the same to 1e-6 (2.2e-7 apart: the C0 and bicubic
    bases of u, v and the shear strains, ``test_thick_homogeneous_control``).  With the stretching field
    the single layer once had, the frequencies moved by 1e-5 at most: the field bought
    nothing but DOFs and a model structure that switched as a fit moved G23 / G13."""
    model = solid3d.spec_model("spruce_plate").with_options(theory="layerwise")
    stack = LayerwiseLaminate.of(model.specimen.laminate("original"))
    assert (stack.n_groups, stack.stretch) == (1, ())
    layerwise = check("spruce_plate", "original", 2e-3)
    fsdt, _ = solid3d.errors("spruce_plate", "original", transverse_shear=True, rotary_inertia=True)
    np.testing.assert_allclose(layerwise, fsdt, atol=1e-6)


@needs("thick_laminate")
@pytest.mark.parametrize("configuration", ["original", "al_bottom"])
def test_thick_laminate(configuration):
    """A 6 mm glass/carbon/glass laminate (a/h = 33) with 1 mm aluminium on the bond line:
    within 0.15 % (measured 0.059 % and 0.095 %, like the FSDT's 0.066 % and 0.082 %: the
    bond line is a small part of this stack's shear compliance, and what remains is the
    first-order theory's limit within the thick plies)."""
    check("thick_laminate", configuration, 1.5e-3)


@needs("foam_sandwich")
def test_core_stretch_is_what_the_bonded_sandwich_needs():
    """The core's transverse normal strain (linear through the core): without it the
    bonded sandwich is 0.22 % stiff, with it 0.034 % soft; in the symmetric original plate
    it is a 0.04 % effect (the core bulging in flexure).  A solid model run for this check
    with the foam's nu13 = nu23 = 0 (the plate model neglects that Poisson coupling) moves
    by -0.034 % (bonded) and -0.060 % (original) at mode 10: the layerwise model's residual
    (-0.033 %, -0.063 %) is that coupling.  So: bonded without the stretch above +0.15 %,
    with it within +-0.05 %."""
    bonded = {
        c: solid3d.errors("foam_sandwich", "al_bottom", theory="layerwise", core_stretch=c)[0]
        for c in (True, False)
    }
    assert 1.5e-3 < bonded[False].max() < 3e-3, bonded[False]
    assert np.abs(bonded[True]).max() < 5e-4, bonded[True]
