"""A peak list whose thin-plate fit matched its peaks wrongly: the shear models refitted
from the spec's values with the peaks matched afresh (``afresh_from_spec``), judged on
every peak by the matching cost (``_rematched_candidate``), and the rule that selects one,
looks one round ahead, or names the lead (``_afresh_from_spec``).

The real-like spruce plate (``studies.long_plates.simulate(3, real_like=True)``: rolling
shear G23 = G12 / 21, rotary inertia and a 4 g sensor in the recordings, five hits with
hum, rattle and bounce, the peak list from ``extract_peaks``; a handbook spec with none of
it) is where the diagnosis ended "unexplained" before: the thin plate matched 19-26 of
its 34 peaks with nu12 on its bound of 0, and every candidate was refitted on that
matching."""

import importlib
from types import SimpleNamespace

import pytest

from fem.specimen import Parameter
from identify.engine.peak_lists import matching_cost, model_error
from identify.fitting import driver
from identify.fitting.driver import AddedEffect, Refitting, afresh_from_spec, fit
from identify.measurements import parse_measurements
from identify.recordings.peaks import extract_peaks
from studies import long_plates

diagnosis = importlib.import_module("identify.diagnosis.diagnose")
POLICY = diagnosis.SELECTION_POLICY


@pytest.fixture(scope="module")
def spruce(tmp_path_factory):
    """Seed 3's peak list, its handbook model, thin-plate fit and true values."""
    folder = tmp_path_factory.mktemp("spruce3")
    plate = long_plates.simulate(3, folder, real_like=True)
    table = extract_peaks(list(plate.recordings), "original").to_frame()
    model = long_plates.handbook_model()
    peaks = parse_measurements(table[["configuration", "frequency_hz", "std_hz"]], model)
    return SimpleNamespace(model=model, peaks=peaks, baseline=fit(model, peaks), truth=plate.truth)


@pytest.fixture(scope="module")
def afresh(spruce):
    """Seed 3's transverse-shear refit from the spec, matched afresh, and its context."""
    refitting = Refitting.from_baseline(spruce.model, spruce.peaks, spruce.baseline)
    job = dict(refitting=refitting, kind="transverse_shear", options=POLICY.candidate_options)
    return SimpleNamespace(refitting=refitting, added=afresh_from_spec(job))


def test_the_shear_model_from_the_spec_matches_more_peaks_at_less_cost(spruce, afresh):
    """From the spec's values, at the shear start whose spectrum matches the peaks best
    (G23 = G12 / 16 of ``SHEAR_STARTS``: wood's rolling shear), the transverse-shear model
    matches more peaks than the thin-plate fit and its matching cost over all of them, at
    one tolerance, falls by more than the selection's ``min_gain`` (measured: 31 of 34
    peaks, cost 75 against 168, gain 86).  Its rolling shear modulus is the truth's within
    10 % (measured 1.7 %: the sensor still missing), where the refit on the thin plate's
    matching ran G13 to the bound (1900 GPa)."""
    baseline, peaks, added = spruce.baseline, spruce.peaks, afresh.added
    fit_ = added.result
    assert fit_ is not None and fit_.finished
    assert any("G23 = 0.0625 G12" in n and "matched afresh" in n for n in added.notes), added.notes
    assert len(fit_.measurements) > len(baseline.measurements)
    candidate = diagnosis._rematched_candidate(baseline, peaks, added)
    tolerance = min(model_error(baseline), model_error(fit_))
    penalty = (fit_.statistics.k - baseline.statistics.k) * __import__("math").log(len(peaks))
    assert candidate.gain == pytest.approx(
        matching_cost(baseline, peaks, tolerance) - matching_cost(fit_, peaks, tolerance) - penalty
    )
    assert candidate.scaled_gain > POLICY.min_gain
    assert candidate.plausible
    g23 = fit_.value(Parameter("G23", "spruce"))
    assert g23 == pytest.approx(spruce.truth["G23"], rel=0.1)


def test_once_chosen_it_is_matched_afresh_where_rematched_would_keep_that_way(spruce, afresh):
    """``Refitting.polished_afresh`` runs only the way of ``rematched`` that matches the
    peaks afresh from the refit's values; ``rematched`` keeps the way whose matching costs
    less, so the shortcut gives its answer where the other way, matched again from the
    thin-plate fit's matching, costs more (measured: 118 against 62)."""
    peaks, fit_ = spruce.peaks, afresh.added.result
    polished = afresh.refitting.polished_afresh(fit_, POLICY.final_options)
    again = driver._matched_again(
        dict(fit=fit_, measurements=peaks, options=POLICY.final_options, like=spruce.baseline)
    )
    tolerance = min(model_error(polished), model_error(again))
    assert matching_cost(polished, peaks, tolerance) < matching_cost(again, peaks, tolerance)
    assert len(polished.measurements) >= len(fit_.measurements)


# ---- the rule, on stand-ins: which afresh refit is selected, looked ahead or named -------------


def _candidate(kind, gain, implausible=(), fit=None):
    added = AddedEffect(
        kind,
        fit or SimpleNamespace(finished=True),
        (Parameter("G13", "spruce"),),
        implausible=tuple(implausible),
        notes=tuple(f"{kind}: implausible estimate: {r}" for r in implausible),
    )
    return diagnosis.Candidate(kind, f"{kind} note", added, gain, gain)


@pytest.fixture
def rule(monkeypatch):
    """``_afresh_from_spec`` with its refits replaced: ``afresh`` maps a shear kind to its
    afresh candidate, ``on_top`` is the look-ahead's pair (None: no look-ahead expected)."""
    state = SimpleNamespace(afresh={}, on_top=None, looked_ahead=[])
    monkeypatch.setattr(diagnosis, "afresh_from_spec", lambda job: job["kind"])
    monkeypatch.setattr(
        diagnosis,
        "_rematched_candidate",
        lambda base, peaks, a: state.afresh[a] if isinstance(a, str) else state.on_top,
    )

    def add_effect(refit, kind, hints):
        state.looked_ahead.append(kind)
        return AddedEffect(
            kind, SimpleNamespace(finished=True, specimen=None), added=(Parameter("mass", kind),)
        )

    monkeypatch.setattr(diagnosis, "add_effect", add_effect)
    refitting = SimpleNamespace(
        baseline=None,
        measurements=None,
        refit=lambda *a, **k: None,
        hints=lambda fit: (),
        judged_implausible=lambda parameters, specimen: tuple(state.on_top_reasons),
    )
    state.on_top_reasons = []

    def run(ordered):
        return diagnosis._afresh_from_spec(
            refitting,
            ["transverse_shear", "thick_plate", "point_mass"],
            ordered,
            None,
            POLICY,
            lambda t: None,
        )

    state.run = run
    return state


def test_a_plausible_afresh_refit_that_pays_is_selected(rule):
    rule.afresh = {
        "transverse_shear": _candidate("transverse_shear", 85.7),
        "thick_plate": _candidate("thick_plate", 85.4),
    }
    chosen, lead = rule.run([_candidate("point_mass", -4.1)])
    assert chosen.kind == "transverse_shear" and lead == "" and not rule.looked_ahead


def test_one_that_pays_short_of_min_gain_is_neither_selected_nor_named(rule):
    rule.afresh = {k: _candidate(k, POLICY.min_gain) for k in ("transverse_shear", "thick_plate")}
    assert rule.run([_candidate("point_mass", 9.4)]) == (None, "")


def test_an_implausible_one_is_selected_when_the_next_effect_makes_it_plausible(rule):
    """The real-like seed 0: transverse shear from the spec matched 27 of 35 peaks (gain
    61) with G13 = 3.0 G12, implausible; with the point mass refitted on top, plausible and
    a gain of 223.  It is selected, marked plausible with point_mass (which the next round
    tries from it), and the verdict does not call it implausible once that is chosen."""
    odd = ("spruce G13 = 1.88 GPa is 3.02 x its G12 (outside 1/100-2.5 x)",)
    rule.afresh = {
        "transverse_shear": _candidate("transverse_shear", 61.3, odd),
        "thick_plate": _candidate("thick_plate", 61.1, odd),
    }
    rule.on_top = _candidate("transverse_shear", 222.6)
    chosen, lead = rule.run([_candidate("suspension", -3.1), _candidate("point_mass", 0.9)])
    assert rule.looked_ahead == ["point_mass"]
    assert chosen.kind == "transverse_shear" and chosen.plausible_with == "point_mass" and lead == ""
    assert not chosen.plausible  # alone it is not: the verdict reads ``plausible_with``
    assert chosen.added.notes == (
        f"transverse_shear: implausible estimate alone ({odd[0]}), plausible with point_mass refitted on "
        "top of it",
    )


def test_the_best_paying_is_looked_ahead_before_a_plausible_one_that_pays_less(rule):
    """The real-like seed 7: thick_plate afresh paid 59 with G23 = 3.3 G12, transverse_shear
    16 and plausible.  The better-paying is tried with the next effect on top first; only
    when that stays implausible is the plausible one selected."""
    odd = ("spruce G23 = 2.38 GPa is 3.32 x its G12 (outside 1/100-2.5 x)",)
    rule.afresh = {
        "transverse_shear": _candidate("transverse_shear", 16.5),
        "thick_plate": _candidate("thick_plate", 59.3, odd),
    }
    rule.on_top = _candidate("thick_plate", 120.0)
    chosen, _ = rule.run([_candidate("point_mass", 2.5)])
    assert rule.looked_ahead == ["point_mass"]
    assert chosen.kind == "thick_plate" and chosen.plausible_with == "point_mass"
    rule.looked_ahead.clear()
    rule.on_top_reasons = ["spruce G23 still 3 x its G12"]
    chosen, _ = rule.run([_candidate("point_mass", 2.5)])
    assert rule.looked_ahead == ["point_mass"]
    assert chosen.kind == "transverse_shear" and chosen.plausible_with == ""


def test_an_implausible_one_that_stays_implausible_is_named_not_selected(rule):
    odd = ("spruce G13 = 1.88 GPa is 3.02 x its G12 (outside 1/100-2.5 x)",)
    rule.afresh = {k: _candidate(k, 61.0, odd) for k in ("transverse_shear", "thick_plate")}
    rule.on_top = _candidate("transverse_shear", 222.6)
    rule.on_top_reasons = ["spruce G13 still 3 x its G12"]
    chosen, lead = rule.run([_candidate("point_mass", 0.9)])
    assert chosen is None
    assert "peak matching is likely wrong" in lead and "also with point_mass on top of it" in lead
    assert odd[0] in lead


def test_the_verdict_calls_a_look_ahead_selection_plausible_only_with_its_partner():
    """``Diagnosis.verdict``: a selected candidate plausible only with another effect is
    flagged implausible unless that effect was selected too."""
    odd = ("G13 3 x G12",)
    shear = diagnosis.Candidate(
        "transverse_shear", "", SimpleNamespace(implausible=odd), 60.0, 60.0, plausible_with="point_mass"
    )
    mass = diagnosis.Candidate("point_mass", "", SimpleNamespace(implausible=()), 200.0, 200.0)
    final = SimpleNamespace(rms_rel_error=3e-4, status=SimpleNamespace(value="converged"), converged=True)
    baseline = SimpleNamespace(rms_rel_error=4e-3)

    def verdict(chosen):
        steps = tuple(SimpleNamespace(chosen=c) for c in chosen)
        d = SimpleNamespace(
            at_noise_level=False,
            selected=tuple(chosen),
            final=final,
            baseline=baseline,
            dropped=(),
            steps=steps,
        )
        return diagnosis.Diagnosis.verdict.fget(d)

    assert "implausible" not in verdict([shear, mass])
    assert "implausible estimate of transverse_shear" in verdict([shear])


def test_a_failed_afresh_refit_is_a_candidate_with_its_error():
    """An afresh refit that did not run (not applicable, failed) ranks last with its reason."""
    failed = AddedEffect("thick_plate", None, error="failed: the eigen-solver did not converge")
    c = diagnosis._rematched_candidate(None, None, failed)
    assert c.gain == float("-inf") and c.error == failed.error and not c.eligible
