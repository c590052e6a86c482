"""Plausibility by what a layer is: a core whose cells or grain run through its thickness
(end-grain balsa, a honeycomb: the spec gives E3 well above its in-plane moduli) may
carry transverse shear moduli many times its in-plane G12; a ply or a foam may not."""

import numpy as np
import pytest

from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.diagnosis.compare import compare
from identify.engine.updating import FitOptions, Follow, Settle
from identify.fitting import driver
from identify.fitting.driver import (
    Refit,
    add_effect,
    prepare_effect,
    vanishing_shear_start,
)
from identify.fitting.plausibility import CORE_MAX_SHEAR_RATIO, MAX_SHEAR_RATIO, implausible
from identify.recordings.synthetic import synthetic_measurements

from .continuation import continuation_steps


def sandwich(skin, core, core_shear=None, e3_gpa=3.0) -> dict:
    """A 300 x 200 mm panel: 0.8 mm fabric skins on a 10 mm core (GPa, GPa, GPa, nu)."""
    balsa = {
        "E1_GPa": core[0],
        "E2_GPa": core[1],
        "G12_GPa": core[2],
        "nu12": core[3],
        "density_kg_m3": 160,
        "identify": True,
    }
    if e3_gpa is not None:
        balsa["E3_GPa"] = e3_gpa
    if core_shear is not None:
        balsa["G13_GPa"], balsa["G23_GPa"] = core_shear
    return {
        "specimen": {
            "name": "end-grain balsa sandwich",
            "length_mm": 300.0,
            "width_mm": 200.0,
            "layers": [
                {"material": "fabric", "thickness_mm": 0.8},
                {"material": "balsa", "thickness_mm": 10.0},
                {"material": "fabric", "thickness_mm": 0.8},
            ],
        },
        "materials": {
            "fabric": {
                "E1_GPa": skin[0],
                "E2_GPa": skin[1],
                "G12_GPa": skin[2],
                "nu12": skin[3],
                "density_kg_m3": 1500,
                "identify": True,
            },
            "balsa": balsa,
        },
        "configurations": [{"name": "original"}],
        "model": {"modes": 10},
    }


TRUE_SKIN, TRUE_CORE, TRUE_CORE_SHEAR = (22.0, 21.0, 3.0, 0.12), (0.15, 0.14, 0.06, 0.3), (0.18, 0.15)


@pytest.mark.parametrize(
    "e3_gpa,ratio,plausible",
    [
        (3.0, 3.0, True),
        (3.0, 0.8 * CORE_MAX_SHEAR_RATIO, True),
        (3.0, 1.2 * CORE_MAX_SHEAR_RATIO, False),
        (None, 3.0, False),
        (0.15, 3.0, False),
    ],
)
def test_the_shear_limit_follows_the_layers_class(e3_gpa, ratio, plausible):
    """G13 = G23 = ratio x G12 of the core: within the core limit where the spec gives E3 =
    20 x its in-plane moduli; beyond the ply limit (2.5) where it gives none, or an E3
    like its in-plane ones (a foam)."""
    nominal = parse_spec(sandwich(TRUE_SKIN, TRUE_CORE, e3_gpa=e3_gpa)).specimen
    g12 = nominal.materials["balsa"].G12
    shear = [Parameter("G13", "balsa"), Parameter("G23", "balsa")]
    fitted = nominal.with_values({p: ratio * g12 for p in shear})
    reasons = implausible(shear, fitted, nominal)
    assert (reasons == ()) is plausible, reasons
    if not plausible:
        limit = CORE_MAX_SHEAR_RATIO if e3_gpa == 3.0 else MAX_SHEAR_RATIO
        assert f"-{limit:g} x" in reasons[0]


def test_a_balsa_core_s_shear_refit_descends_from_the_thin_plate():
    """A panel whose core's G13, G23 are 3.0 and 2.5 x its G12 (the layerwise model as the
    truth, 10 modes at 0.05 % scatter), fitted from handbook values without shear (4 %
    RMS): the Mindlin refit ran its core's moduli past the ply limit, was held at G12 and
    ended worse than the thin plate it contains (6.9 %); with the core's class known from
    its E3, it descends to about 0.16 % and is plausible."""
    truth = parse_spec(sandwich(TRUE_SKIN, TRUE_CORE, TRUE_CORE_SHEAR)).with_options(theory="layerwise")
    data = synthetic_measurements(truth, modes=10, noise_rel=5e-4, seed=3)
    start = parse_spec(sandwich((19.0, 23.0, 3.4, 0.15), (0.17, 0.12, 0.07, 0.25)))
    baseline = compare(start, data).fitted
    added = add_effect(Refit(baseline, data, start.specimen), "thick_plate")
    assert added.implausible == ()
    assert added.result.statistics.sum_squares < 0.01 * baseline.statistics.sum_squares


def test_the_continuation_starts_at_the_thin_plate_and_only_descends():
    """At the thin-plate limit (``vanishing_shear_start``: the core's G13 = G23 thousands
    of times its G12, the shear correction below a tenth of each measurement's scatter)
    the thin-plate fit's values give its frequencies within 0.3 % (the first-order shear
    element's thin limit lies up to 0.28 % from the thin-plate element's on this mesh,
    measured) and its misfit within 2 % (measured 1.4 % lower: residuals of about 120
    scatters).  From there the continuation starts no higher than the thin-plate fit's
    misfit (within 1 %: a tenth of the scatter per mode), lowers the shear moduli while
    each step lowers it (``shear_continuation``), and the refit with them free from there
    descends further, to below a hundredth of it.  8 G12, the fixed start this replaces,
    is not that limit for this core: there the model is still more than 1 % off."""
    truth = parse_spec(sandwich(TRUE_SKIN, TRUE_CORE, TRUE_CORE_SHEAR)).with_options(theory="layerwise")
    data = synthetic_measurements(truth, modes=10, noise_rel=5e-4, seed=3)
    start = parse_spec(sandwich((19.0, 23.0, 3.4, 0.15), (0.17, 0.12, 0.07, 0.25)))
    baseline = compare(start, data).fitted
    prepared = prepare_effect(baseline, "transverse_shear")
    parameters = list(prepared.base) + list(prepared.added)
    shear = [p for p in prepared.added if p.kind in ("G13", "G23")]
    context = Refit(baseline, data, start.specimen, FitOptions(), effect_of={})
    model, factor = vanishing_shear_start(context, prepared.model, shear, parameters)
    assert factor > 100
    at_limit = driver.fit_layers(
        model, data, parameters, FitOptions(max_iterations=0), Follow.on(baseline, Settle.NONE)
    )
    assert np.max(np.abs(at_limit.model_hz / baseline.model_hz - 1)) < 0.003
    assert abs(at_limit.statistics.sum_squares / baseline.statistics.sum_squares - 1) < 0.02
    model, reached, kept = continuation_steps(context, model, shear, factor, parameters)
    assert kept[0] / baseline.statistics.sum_squares - 1 < 0.01 and reached < factor
    assert np.all(np.diff(kept) < 0)
    refit = driver.fit_layers(
        model,
        data,
        parameters,
        FitOptions(max_iterations=40),
        Follow.on(baseline, Settle.NONE),
    )
    assert np.all(np.diff([it.cost for it in refit.history]) <= 0)
    assert refit.statistics.sum_squares < 0.01 * baseline.statistics.sum_squares
    at_eight = driver.fit_layers(
        prepared.model.with_values({p: 8 * baseline.model.specimen.materials[p.target].G12 for p in shear}),
        data,
        parameters,
        FitOptions(max_iterations=0),
        Follow.on(baseline, Settle.NONE),
    )
    assert np.max(np.abs(at_eight.model_hz / baseline.model_hz - 1)) > 0.01


def test_a_failed_shear_refit_is_continued_from_the_thin_plate_then_tries_every_start(monkeypatch):
    """Where each refit counts as worse than the thin plate (forced here), the shear
    candidate is refitted first from the thin-plate limit (the continuation), and where
    that too ends worse, which it cannot do unforced, the note reports a fault and the
    other screened starts are tried (``_restarted``); the lowest misfit is kept and the
    note names the starts tried."""
    truth = parse_spec(sandwich(TRUE_SKIN, TRUE_CORE, TRUE_CORE_SHEAR)).with_options(theory="layerwise")
    data = synthetic_measurements(truth, modes=10, noise_rel=5e-4, seed=3)
    start = parse_spec(sandwich((19.0, 23.0, 3.4, 0.15), (0.17, 0.12, 0.07, 0.25)))
    baseline = compare(start, data).fitted
    continued = []
    continuation = driver.shear_continuation

    def recording(*args, **kwargs):
        continued.append(True)
        return continuation(*args, **kwargs)

    monkeypatch.setattr(driver, "shear_continuation", recording)
    monkeypatch.setattr(driver, "ended_worse", lambda result, state: True)
    added = add_effect(Refit(baseline, data, start.specimen), "transverse_shear")
    assert continued == [True]
    # The core is no unidirectional ply: its other starts are (1, 1) and (0.25, 0.25) x G12.
    assert any(
        note.startswith("the refit from the screened start ended worse") and "restarted 3 time(s)" in note
        for note in added.notes
    ), added.notes
    assert any("please report it" in note for note in added.notes), added.notes
    assert added.result.statistics.sum_squares < baseline.statistics.sum_squares


def test_a_hold_that_ends_above_the_thin_plate_is_undone(monkeypatch):
    """The same panel with no E3 in the spec: its core is judged as a ply, the Mindlin
    refit's core G13 (3 x G12) counts as implausible and is held at the ply class's
    relation.  Held, it ends at 0.34 %, below the thin plate's 6.0 %; forced here to
    count as above it (it did end above, at 6.9 % against 4 %, while measured bending
    modes could pair with the thin plate's membrane modes), the hold is undone: the free
    estimate is kept, far below the thin plate, and marked implausible (a sign, never
    selected)."""
    ended_worse = driver.ended_worse

    def held_ends_worse(result, state):
        held = {"G13", "G23"}.isdisjoint(p.kind for p in result.parameters if p.target == "balsa")
        return held or ended_worse(result, state)

    monkeypatch.setattr(driver, "ended_worse", held_ends_worse)
    truth = parse_spec(sandwich(TRUE_SKIN, TRUE_CORE, TRUE_CORE_SHEAR)).with_options(theory="layerwise")
    data = synthetic_measurements(truth, modes=10, noise_rel=5e-4, seed=3)
    start = parse_spec(sandwich((19.0, 23.0, 3.4, 0.15), (0.17, 0.12, 0.07, 0.25), e3_gpa=None))
    baseline = compare(start, data).fitted
    added = add_effect(Refit(baseline, data, start.specimen), "thick_plate")
    assert added.implausible and any("stay free" in note for note in added.notes), added.notes
    assert added.result.statistics.sum_squares < 0.01 * baseline.statistics.sum_squares


def test_a_refit_from_the_spec_s_values_is_not_restarted_when_it_ends_above_the_thin_plate(monkeypatch):
    """A shear refit started from the spec's values (the rival ``spec_start`` gives when
    the thin-plate fit is degenerate) starts above the thin-plate fit: ending above it is
    no failed start, and its rival from the thin-plate fit is kept if lower
    (``AddedEffect.or_from_spec``).  Restarting it from every shear start cost a long
    spruce plate's diagnosis 130 s of refits that all ended 60 x above the thin plate.
    Forced here (every refit counts as worse): the refit from the thin-plate fit is
    restarted, the one from the spec's values is not."""
    truth = parse_spec(sandwich(TRUE_SKIN, TRUE_CORE, TRUE_CORE_SHEAR)).with_options(theory="layerwise")
    data = synthetic_measurements(truth, modes=10, noise_rel=5e-4, seed=3)
    start = parse_spec(sandwich((19.0, 23.0, 3.4, 0.15), (0.17, 0.12, 0.07, 0.25)))
    baseline = compare(start, data).fitted
    far = start.with_values({Parameter("E1", "fabric"): 40e9, Parameter("E2", "fabric"): 40e9})
    from_spec = driver.fit_layers(
        far, data, list(baseline.parameters), FitOptions(max_iterations=0), Follow(settle=Settle.NONE)
    )
    assert from_spec.statistics.sum_squares > 10 * baseline.statistics.sum_squares
    restarted = []
    monkeypatch.setattr(driver, "ended_worse", lambda result, state: True)
    monkeypatch.setattr(
        driver,
        "_restarted",
        lambda refit, ready, result, new, base: restarted.append(ready) or (result, new, [], None),
    )
    context = Refit(baseline, data, start.specimen)
    ready = prepare_effect(baseline, "transverse_shear", start=from_spec)
    assert ready.starts_above(baseline)
    add_effect(context, "transverse_shear", prepared=ready)
    assert restarted == []
    add_effect(context, "transverse_shear")
    assert len(restarted) == 1 and not restarted[0].starts_above(baseline)


def test_a_refinement_that_ends_above_the_thin_plate_is_continued_from_the_thin_plate_s_values(
    monkeypatch,
):
    """A refinement (layerwise) starts where what it refines (transverse shear) ended, at
    other layer values than the thin-plate fit's.  Where it ends above the thin plate, the
    continuation starts from the thin-plate limit at the thin-plate fit's own values, the
    fit the refinement contains, not at its start's: there the first step sits at the
    thin plate's misfit and every step can only descend."""
    truth = parse_spec(sandwich(TRUE_SKIN, TRUE_CORE, TRUE_CORE_SHEAR)).with_options(theory="layerwise")
    data = synthetic_measurements(truth, modes=10, noise_rel=5e-4, seed=3)
    start = parse_spec(sandwich((19.0, 23.0, 3.4, 0.15), (0.17, 0.12, 0.07, 0.25)))
    baseline = compare(start, data).fitted
    context = Refit(baseline, data, start.specimen)
    shear = add_effect(context, "transverse_shear").result
    ready = prepare_effect(baseline, "layerwise", start=shear)
    skin_e1 = Parameter("E1", "fabric")
    # the refinement starts at the shear fit's values, well away from the thin plate's
    assert abs(ready.model.value(skin_e1) / baseline.model.value(skin_e1) - 1) > 0.05

    class Stop(Exception):
        pass

    continued_from = []

    def recording(refit, model, shear_moduli, parameters):
        continued_from.append(model)
        raise Stop

    monkeypatch.setattr(driver, "ended_worse", lambda result, state: True)
    monkeypatch.setattr(driver, "vanishing_shear_start", recording)
    with pytest.raises(Stop):
        driver._restarted(context, ready, shear, list(ready.added), list(ready.base))
    (model,) = continued_from
    for parameter, value in zip(baseline.parameters, baseline.values, strict=True):
        assert model.value(parameter) == pytest.approx(value, rel=1e-12), parameter
    assert model.options.theory == "layerwise"
