"""Shear moduli that run out of the plausible range in a candidate's refit are held and
reported (``fitting.driver._held_shear``): the set it returns is what ``AddedEffect.held``
carries and what the next effect frees again (``held_shear_moduli``)."""
from dataclasses import replace

from fem.specimen import Parameter
from identify import fit
from identify.engine.updating import FitOptions
from identify.fitting.driver import _held_shear, prepare_effect
from identify.recordings.synthetic import synthetic_measurements
from studies.common import start_model, true_model
from studies.hidden_effect import thick


def test_a_shear_modulus_at_a_hundred_times_g12_is_held_with_its_pair():
    """The thick paper plate (a/h 27, the steel core's G13/G23 seen by the data): a
    transverse-shear candidate whose steel G13 ended at 100x G12 (``MAX_SHEAR_RATIO`` is
    far below that) has both steel shear moduli held at their start values, removed from
    the free parameters, named in the note and returned; the refit without them is back
    near the truth's misfit (the data carry no missing physics: reduced chi^2 below 2)."""
    truth = thick(true_model()).with_options(modes=8, transverse_shear=True)
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=8, labels="close")
    model = thick(start_model()).with_options(modes=8)
    state = fit(model, data)
    prepared = prepare_effect(state, "transverse_shear")
    steel = (Parameter("G13", "steel"), Parameter("G23", "steel"))
    assert any(p.target == "steel" for p in prepared.added)
    g12 = state.model.value(Parameter("G12", "steel"))
    ran_out = replace(state, model=prepared.model.with_values({steel[0]: 100 * g12}))
    result, new, notes, held = _held_shear(state, prepared, ran_out, list(prepared.added), data, model.specimen,
                                           list(prepared.base), state.effect_of, "quick", FitOptions(max_iterations=20))
    assert held == steel
    assert not any(p.target == "steel" for p in new if p.kind in ("G13", "G23"))
    assert len(notes) == 1 and "steel" in notes[0] and "held at their start values" in notes[0]
    start, end = (r.specimen.materials["steel"] for r in (prepared.model, result.model))
    assert (end.G13, end.G23) == (start.G13, start.G23)  # back at the start: here G13 = G23 = G12 by default
    assert result.statistics.reduced_chi2 < 2.0
