"""The hidden-effect study, run small: each case diagnosed among four candidate effects
(the full study tries all seven registered kinds)."""
import pytest

from studies import hidden_effect

CANDIDATES = ["transverse_shear", "rotary_inertia", "point_mass", "suspension"]


@pytest.mark.parametrize("case", list(hidden_effect.CASES))
def test_true_effect_ranked_first_and_error_falls(case):
    """Acceptance (issue 5): the right effect ranks first; the RMS error falls at least 5x
    and to within 2x the noise; the layer properties come back within 3 std."""
    o = hidden_effect.run_case(case, CANDIDATES)
    assert o.diagnosis.baseline.statistics.reduced_chi2 > 25, "the baseline misfit is well above the noise"
    assert o.ranked_first == o.true_effect
    assert o.rms_before / o.rms_after >= 5
    assert o.rms_after <= 2 * hidden_effect.NOISE
    assert o.max_z < 3
    assert o.diagnosis.candidates[0].gain > 10
    if case == "sensor_mass":
        values = o.diagnosis.candidates[0].effect_values()
        assert values["mass_g"] == pytest.approx(3.0, rel=0.1)
        # With material axes along the edges the plate is symmetric about its centre lines:
        # (x, y), (150 - x, y), (x, 150 - y) and (150 - x, 150 - y) give identical frequencies;
        # the near-isotropic square plate is nearly symmetric under the 90-degree turn too, so
        # the position is found up to that turn, and a turned answer comes with its rival.
        folded = (abs(values["x_mm"] - 75), abs(values["y_mm"] - 75))
        assert sorted(folded) == pytest.approx([35, 50], abs=5)
        if folded[0] < folded[1]:
            assert any("other solution(s) fit about as well" in w for w in o.diagnosis.candidates[0].fit.warnings)
