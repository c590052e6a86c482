"""Acceptance (wood): the diagnosis of a spruce plate whose frequencies come from an
independent 3-D solid model (CalculiX C3D20R, ``tests/data/solid3d/spruce_plate.json``;
240 x 180 x 8 mm quarter-sawn spruce, grain along the length, a/h = 30 along the grain and
22.5 across; 1 mm aluminium on a 0.1 mm soft adhesive under or over it), started from
handbook spruce values (E1 10.0, E2 0.80, G12 0.62 GPa, nu12 0.40: 8-11 % off the truth)
and knowing nothing of G13 or G23 (``studies.hidden_effect.reference_start("spruce_plate")``):
they default to G12, while wood's rolling shear modulus G23 = G_RT is 0.040 GPa, 17x below
G12 (G13 = G_LT is 0.65 GPa, near G12).

Every registered effect is a candidate.  The frequencies carry 0.05 % Gaussian scatter
(stated as std_hz = 0.0005 f), so "within 2x the noise" is an RMS error of 0.1 %.

What the plate models can do here (tests/data/solid3d/README.md): at the true values,
first-order shear with rotary inertia is within 0.20 % of the 3-D model on the plate
alone but errs low by up to 2.5 % on the bonded configurations (aluminium on wood with a
soft rolling-shear core: the thick-face effect of sandwich theory); the best single-layer
fit leaves 0.22 % RMS (FSDT+RI) or 0.30 % (FSDT), above 2x the noise.  Only the layerwise
model can explain these data, so it is the shear effect the diagnosis must end up with.

Measured (one process, 49 s; on a later day the code just before took 87 s, and 62 s once
the plate alone became the first-order shear plate in the layerwise model): baseline RMS
8.08 % (8.26 % now); the shear candidates start at G23 = G12 / 16 (of
``fitting.SHEAR_STARTS``, by the linearised misfit; from the default G23 = G12 they
stopped in a local minimum at 1.1-1.3 % and a 0.7 g point mass was then invented to absorb
the rest); round 1 selects ``layerwise`` (RMS 0.0495 %, 0.0501 % now; FSDT+RI 0.22 %, FSDT
0.30 %), round 2 stops at the noise level; G23 = 0.04009 +- 0.00005 GPa, G13 = 0.647 +-
0.007 GPa, E1, E2, G12 within 1.8 std of the truth (1.3 now).
"""

import math

import pytest

from fem.specimen import Parameter
from studies import hidden_effect

CASE = "spruce_plate"
SHEAR = {"transverse_shear", "thick_plate", "layerwise"}


@pytest.fixture(scope="module")
def outcome():
    return hidden_effect.run_reference(case=CASE)


def test_baseline_is_far_from_the_3d_model(outcome):
    """Without transverse shear the plate model is 5-50 % too stiff (CLT column of the
    README); the baseline fit's RMS (measured 8.1 %) is far above 5x the 0.05 % noise."""
    assert outcome.diagnosis.baseline.rms_rel_error > 5 * hidden_effect.NOISE


def test_transverse_shear_is_selected_first(outcome):
    assert outcome.selected and outcome.selected[0] in SHEAR, outcome.diagnosis.report()


def test_no_point_mass_is_invented(outcome):
    """The 3-D model has no sensor: a point mass must not be selected, and the layerwise
    model is the only shear model that can explain the bonded configurations."""
    assert "point_mass" not in outcome.selected, outcome.diagnosis.report()
    assert outcome.selected == ("layerwise",), outcome.diagnosis.report()


def test_final_refit_explains_the_data(outcome):
    """Converged, consistent with the scatter, RMS within 2x the 0.05 % noise (measured
    0.042 %)."""
    d = outcome.diagnosis
    assert d.final is not None and d.final.converged and d.explained, d.report()
    assert outcome.rms_after <= 2 * hidden_effect.NOISE, d.report()


def test_rolling_shear_modulus_is_estimated(outcome):
    """G23 of spruce is free (on its own, or in one scale with G13) with a finite std and
    within 3 std of the 3-D model's 0.040 GPa (for a scale: of the geometric mean of the
    true pair, which is what one scale measures; as in test_diagnose_reference.py).  G23
    must not sit at a plausibility bound (G12 / 100 = 0.007 GPa) or near its default G12:
    the 3-std window (measured std 0.14 % of the value) rules out both."""
    final = outcome.diagnosis.final
    truth = hidden_effect.reference_values(CASE)
    shear = [p for p in final.parameters if p.kind in ("G13", "G23") and p.target == "spruce"]
    members = {p: [Parameter(p.kind, p.target)] + [f for f, _ in getattr(p, "followers", ())] for p in shear}
    g23 = [p for p in shear if Parameter("G23", "spruce") in members[p]]
    assert g23, f"G23 of spruce is not free: {[p.name for p in final.parameters]}"
    assert any("transverse shear moduli" in w for w in final.warnings)
    for p in g23:
        std = final.std(p)
        assert math.isfinite(std) and 0 < std < final.value(p)
        true = math.exp(sum(math.log(truth[m]) for m in members[p]) / len(members[p]))
        assert abs(final.value(p) - true) < 3 * std, (p.name, final.value(p), true, std)


@pytest.mark.parametrize("kind", ["E1", "E2", "G12"])
def test_layer_properties_come_back_within_their_uncertainty(outcome, kind):
    """E1, E2, G12 of spruce within 3 std of the 3-D model's (measured: all within 1.8 std;
    nu12, not asserted here, is determined weakly by plate frequencies)."""
    final = outcome.diagnosis.final
    p = Parameter(kind, "spruce")
    true = hidden_effect.reference_values(CASE)[p]
    std = final.std(p)
    assert math.isfinite(std) and abs(final.value(p) - true) < 3 * std, (kind, final.value(p), true, std)
