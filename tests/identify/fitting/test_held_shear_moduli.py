"""Shear moduli that run out of the plausible range in a candidate's refit are held and
reported (``fitting.driver._held_shear``): the set it returns is what ``AddedEffect.held``
carries and what the next round's leading candidate frees again
(``diagnose._leader_freed_again``)."""

from dataclasses import replace
from types import SimpleNamespace

import pytest

from fem.specimen import Parameter
from identify import fit
from identify.diagnosis import diagnose as diagnose_module
from identify.diagnosis.diagnose import Candidate
from identify.engine.updating import FitOptions
from identify.fitting import driver
from identify.fitting.driver import AddedEffect, Prepared, Refit, _held_shear, prepare_effect
from identify.recordings.synthetic import synthetic_measurements
from studies.common import start_model, true_model
from studies.hidden_effect import thick


def test_a_shear_modulus_at_a_hundred_times_g12_is_held_with_its_pair():
    """The thick paper plate (a/h 27, the steel core's G13/G23 seen by the data): a
    transverse-shear candidate whose steel G13 ended at 100x G12 (``MAX_SHEAR_RATIO`` is
    far below that), started at 0.25 G12, has both steel shear moduli held at the ply
    class's relation (steel, given none and no unidirectional ply: G13 = G23 = its G12),
    not at the start, removed from the free parameters, named in the note and returned; the refit
    without them is back near the truth's misfit (the data carry no missing physics:
    reduced chi^2 below 2)."""
    truth = thick(true_model()).with_options(modes=8, transverse_shear=True)
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=8, labels="close")
    model = thick(start_model()).with_options(modes=8)
    state = fit(model, data)
    prepared = prepare_effect(state, "transverse_shear")
    steel = (Parameter("G13", "steel"), Parameter("G23", "steel"))
    assert any(p.target == "steel" for p in prepared.added)
    g12 = state.model.value(Parameter("G12", "steel"))
    prepared = replace(
        prepared, model=prepared.model.with_values({steel[0]: 0.25 * g12, steel[1]: 0.25 * g12})
    )
    ran_out = replace(state, model=prepared.model.with_values({steel[0]: 100 * g12}))
    refit = Refit(state, data, model.specimen, FitOptions(max_iterations=20))
    result, new, notes, held = _held_shear(
        refit, prepared, ran_out, list(prepared.added), list(prepared.base)
    )
    assert held == steel
    assert not any(p.target == "steel" for p in new if p.kind in ("G13", "G23"))
    assert len(notes) == 1 and "steel" in notes[0] and "the ply class's relation" in notes[0]
    end = result.model.specimen.materials["steel"]
    assert end.defaulted_shear_moduli == ("G13", "G23")  # G13 = G23 = G12, not the 0.25 G12 start
    assert result.statistics.reduced_chi2 < 2.0


def _candidate(kind: str, sum_squares: float, added=(), values=None, rivals=()):
    """A refitted candidate as the selection sees it: its misfit and criterion, and the
    ``values`` of what it ``added`` [SI]."""
    statistics = SimpleNamespace(
        sum_squares=sum_squares, bic=sum_squares, rms_rel_error=1e-3, scatter_known=False
    )
    fit = SimpleNamespace(
        statistics=statistics, rms_rel_error=1e-3, finished=True, value=(values or {}).__getitem__
    )
    return Candidate(kind, "", AddedEffect(kind, fit, tuple(added), rivals=tuple(rivals)), 0.0, 0.0)


@pytest.mark.parametrize("again_sum_squares, kept", [(10.0, "again"), (500.0, "leader")])
def test_only_the_leading_candidate_is_refitted_with_the_held_moduli_free(
    monkeypatch, again_sum_squares, kept
):
    """Of a round's candidates, only the one with the lowest criterion that frees no shear
    moduli itself is refitted with the held ones free (the layerwise candidate, lower but
    freeing its own, is passed over); its refit replaces it only when the misfit falls,
    and otherwise the leader stays with a note saying so.  A point mass's refit starts
    where the leader's ended (its solution and its other finished one), not from the
    round's starts over the plate.  When the data do not see the held moduli at this
    state (none of them would be freed), nothing is refitted."""
    steel = (Parameter("G13", "steel"), Parameter("G23", "steel"))
    layerwise = _candidate("layerwise", 50.0, steel)
    mass, x, y = (Parameter(k, "point_mass") for k in ("mass", "x", "y"))
    rival = {mass: 4e-3, x: 0.02, y: 0.03}
    leader = _candidate("point_mass", 100.0, (mass, x, y), {mass: 5e-3, x: 0.2, y: 0.1}, [rival])
    other = _candidate("orientation", 200.0)
    ends = (
        {"xy": (0.2, 0.1), "mass_kg": 5e-3, "ended": True},
        {"xy": (0.02, 0.03), "mass_kg": 4e-3, "ended": True},
    )
    calls = []

    def prepare(state, kind, hints=(), start=None, free_again=()):
        calls.append(((kind,), tuple(free_again), tuple(hints)))
        return Prepared(kind, None, (), tuple(free_again), None, (), 0.0)

    def refit(job):
        assert job["hints"] == ends
        return _candidate(job["kind"], again_sum_squares, job["prepared"].added).added

    monkeypatch.setattr(driver, "prepare_effect", prepare)
    monkeypatch.setattr(diagnose_module, "_add", refit)
    # the round's start: its criterion and what its pay floor reads
    state = SimpleNamespace(statistics=SimpleNamespace(bic=1000.0, n=30, scatter_known=True))
    round_ = diagnose_module.Round(Refit(state, None, None), ({"xy": (0.1, 0.1), "share": 0.5},))
    out = diagnose_module._leader_freed_again(round_, [layerwise, leader, other], steel, lambda t: None)
    assert calls == [(("point_mass",), steel, ends)]
    assert out[0] is layerwise and out[2] is other
    if kept == "again":
        assert out[1].fit.statistics.sum_squares == 10.0
    else:
        assert out[1].fit is leader.fit and "not lower: kept without them" in out[1].note
    nowhere = diagnose_module.Round(Refit(None, None, None), ())
    assert diagnose_module._leader_freed_again(nowhere, [leader], (), lambda t: None) == [leader]
    # The data do not see them at this state (nothing of them freed): no refit that would repeat the leader's.
    monkeypatch.setattr(
        driver, "prepare_effect", lambda *a, **k: Prepared("point_mass", None, (), (), None, (), 0.0)
    )
    monkeypatch.setattr(diagnose_module, "_add", lambda job: pytest.fail("refitted without freeing anything"))
    assert diagnose_module._leader_freed_again(round_, [leader], steel, lambda t: None) == [leader]
