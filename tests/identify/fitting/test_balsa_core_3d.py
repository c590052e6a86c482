"""On a 3-D model this project's code did not write: a sandwich whose core is soft in
plane and stiffer through its thickness (end-grain balsa type), made with the blind
study's generator (CalculiX C3D20R, ``tests/data/solid3d/blind.py``, regression case
``regression_balsa_sandwich``: 240 x 160 mm, 0.4 mm carbon-fabric skins on a 6 mm core
with G13, G23 = 3.1, 2.4 x its G12 and E3 = 20 x its E1; the thin-plate frequencies lie
4-27 % above the 3-D ones, the first-order shear plate's within 0.05 %).

The user's spec gives no transverse shear moduli and handbook starts (skins 55 / 55 /
4.2 GPa, core 0.15 / 0.15 / 0.06 GPa: 0.8-0.9 x the truth); the scatter is 0.05 %."""

import os
import re
import tomllib

import numpy as np
import pytest

from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.diagnosis.compare import compare
from identify.diagnosis.diagnose import diagnose
from identify.engine.result import FitStatus
from identify.engine.updating import FitOptions
from identify.fitting.driver import (
    Refit,
    add_effect,
    prepare_effect,
    vanishing_shear_start,
)
from identify.fitting.plausibility import MAX_SHEAR_RATIO
from studies import blind_diagnosis as study

from .continuation import continuation_steps

CASE = "regression_balsa_sandwich"
GPA = 1e9
HANDBOOK = {
    ("cfrp_fabric", "E1"): 55 * GPA,
    ("cfrp_fabric", "E2"): 55 * GPA,
    ("cfrp_fabric", "G12"): 4.2 * GPA,
    ("cfrp_fabric", "nu12"): 0.08,
    ("balsa_core", "E1"): 0.15 * GPA,
    ("balsa_core", "E2"): 0.15 * GPA,
    ("balsa_core", "G12"): 0.06 * GPA,
    ("balsa_core", "nu12"): 0.25,
}


@pytest.fixture(scope="module")
def baseline():
    """The user's model (every layer identified, no G13/G23, the core's E3 stated as a data
    sheet gives it), the 3-D frequencies of the three configurations at 0.05 % scatter,
    and the thin-plate fit of them."""
    case = study.load(CASE)
    text = re.sub(r"G13_GPa = .*\nG23_GPa = .*\n", "", case["truth_spec_toml"])
    model = parse_spec(tomllib.loads(text), CASE)
    model = model.with_values({Parameter(kind, m): v for (m, kind), v in HANDBOOK.items()})
    data = study.measurements(case, model, 5e-4, np.random.default_rng(5))
    return model, data, compare(model, data).fitted


def test_the_shear_continuation_descends_from_the_thin_plate_s_misfit(baseline):
    """The thin plate leaves 7.9 % (measured), about 160 x the scatter.  From the thin-plate
    limit (the core's G13 = G23 = F x G12 with F in the thousands: 8 G12 is nowhere near
    it) every continuation step lowers the misfit from at most the thin plate's (measured:
    5.7 % below it, the shear element's discretisation against the thin plate's), and the
    shear refit ends below a hundredth of it, plausible although the core's G13 is
    beyond the ply limit of 2.5 G12 (the core's class, from its E3)."""
    model, data, thin = baseline
    assert thin.rms_rel_error > 0.05
    prepared = prepare_effect(thin, "transverse_shear")
    parameters = list(prepared.base) + list(prepared.added)
    shear = [p for p in prepared.added if p.kind in ("G13", "G23")]
    assert {p.target for p in shear} == {"balsa_core"}
    context = Refit(thin, data, model.specimen, FitOptions(), effect_of={})
    limit, factor = vanishing_shear_start(context, prepared.model, shear, parameters)
    assert factor > 1000
    _, reached, kept = continuation_steps(context, limit, shear, factor, parameters)
    assert kept[0] <= thin.statistics.sum_squares and reached < factor / 100
    assert np.all(np.diff(kept) < 0), kept
    added = add_effect(Refit(thin, data, model.specimen), "transverse_shear")
    fitted = added.result
    assert fitted.statistics.sum_squares < 0.01 * thin.statistics.sum_squares
    assert added.implausible == (), added.implausible
    core = fitted.specimen.materials["balsa_core"]
    assert core.G13 > MAX_SHEAR_RATIO * core.G12


@pytest.mark.skipif(
    not os.environ.get("LAYER_ID_LONG_TESTS"), reason="long (4 min): set LAYER_ID_LONG_TESTS=1"
)
def test_the_diagnosis_reaches_the_layerwise_model_and_every_property(baseline):
    """The whole diagnosis from the handbook starts: layerwise selected in the first round
    (measured 7.94 % -> 0.0382 %, 0.77 x the stated scatter: converged), and every layer
    property within 3 std of the 3-D model's (measured: within 1.3 std, the core's
    in-plane E1 the worst; 247 s on a loaded 2-core machine)."""
    model, data, _ = baseline
    result = diagnose(model, data)
    assert [c.kind for c in result.selected] == ["layerwise"]
    final = result.final
    assert final.status is FitStatus.CONVERGED
    truth = parse_spec(tomllib.loads(study.load(CASE)["truth_spec_toml"]), CASE)
    for p, value, std in zip(final.parameters, final.values, final.uncertainty.std, strict=True):
        assert abs(value - truth.value(p)) < 3 * std, (p.name, value, truth.value(p), std)
