"""The selection rules that make the diagnosis hold on plates it was not tuned on: an
implausible or singular estimate is never selected, whatever its criterion (it is
reported as a sign), and only an answer (one that pays for itself) may keep another
candidate from being refitted."""

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from fem.model import SHEAR_THEORY_STD_REL
from fem.solver.attachments import PointMass
from fem.solver.sensitivity import condition_verdict
from fem.specimen import Parameter
from identify.diagnosis import diagnose as diagnose_module
from identify.diagnosis.compare import compare
from identify.diagnosis.diagnose import SELECTION_POLICY, Candidate, Diagnosis, Step, _candidate, _signs
from identify.engine.result import FitStatus
from identify.fitting import driver
from identify.fitting.driver import AddedEffect, Refit, add_effect, point_mass_hints
from identify.fitting.precheck import Precheck
from identify.recordings.synthetic import synthetic_measurements
from studies.common import start_model, true_model


@pytest.fixture(scope="module")
def sensor_point_mass():
    """The paper's plate with a hidden 3 g sensor: the baseline and its point-mass
    candidate (plausible, a large BIC gain)."""
    truth = true_model().with_attachments([PointMass(3e-3, 0.125, 0.110)]).with_options(modes=8)
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=8, labels="close")
    model = start_model().with_options(modes=8)
    baseline = compare(model, data).fitted
    added = add_effect(Refit(baseline, data, model.specimen), "point_mass", point_mass_hints(baseline))
    return baseline, added


def test_a_plausible_identifiable_candidate_is_selectable(sensor_point_mass):
    baseline, added = sensor_point_mass
    c = _candidate(baseline, added)
    assert c.eligible and c.plausible and not c.singular and c.selectable
    assert c.scaled_gain > 10


def test_an_implausible_candidate_is_a_sign_not_an_answer(sensor_point_mass):
    """The same refit marked implausible: not selectable although its gain is large, and
    named as a sign of what is missing when the round stops or takes another effect."""
    baseline, added = sensor_point_mass
    c = _candidate(baseline, replace(added, implausible=("a point mass of 20 g is 9 % of the plate",)))
    assert c.eligible and not c.selectable
    sign = _signs([c], None, SELECTION_POLICY)
    assert "point_mass would pay" in sign and "implausible, not taken" in sign and "shear" in sign


def test_a_candidate_singular_at_its_solution_is_not_selectable(sensor_point_mass):
    """A condition number at the solution beyond the paper's limit (1e7) and 1e3 x the
    start's without the effect (the issue's thickness estimate: 5e34) is not identifiable
    there: never selected, even though the start looked well conditioned."""
    baseline, added = sensor_point_mass
    well = Precheck(condition_number=50.0, base_condition_number=20.0, weakest="")
    fit = added.result
    singular_fit = replace(fit, uncertainty=replace(fit.uncertainty, condition_number=5e34))
    c = Candidate("thickness", "", replace(added, result=singular_fit, precheck=well), 100.0, 100.0)
    assert c.eligible and c.plausible and c.singular and not c.selectable
    assert "singular at its solution" in _signs([c], None, SELECTION_POLICY)
    ok = Candidate("thickness", "", replace(added, precheck=well), 100.0, 100.0)
    assert not ok.singular


def test_a_refinement_whose_margin_cannot_win_is_not_refitted_again():
    """What a refinement explained beyond what it refines, when last refitted, against what
    the best candidate explains now: below 1/``RefitPolicy.prune_factor`` of it, the refinement is held
    back with a note; above, it is refitted."""
    from types import SimpleNamespace

    from identify.diagnosis.diagnose import _held_back, _margins

    factor = SELECTION_POLICY.refits.prune_factor

    def fitted(kind, sum_squares, selectable=True, finished=True):
        return SimpleNamespace(
            kind=kind,
            selectable=selectable,
            fit=SimpleNamespace(statistics=SimpleNamespace(sum_squares=sum_squares), finished=finished),
        )

    round1 = [fitted("transverse_shear", 1000.0), fitted("thick_plate", 1100.0), fitted("layerwise", 644.0)]
    margins = _margins(["layerwise"], round1, 1)
    assert margins == {"layerwise": (1, 356.0, "transverse_shear")}
    # Stopped at its iteration limit (blind171's, far above the shear fit): no margin.
    stopped = [*round1[:2], fitted("layerwise", 1.4e5, finished=False)]
    assert _margins(["layerwise"], stopped, 1) == {}
    state = SimpleNamespace(statistics=SimpleNamespace(sum_squares=1000.0))
    point_mass = [fitted("point_mass", 1000.0 - 2062.0 / 2 - 1000.0 / 2)]  # explains 1531 > 2 x 356
    held = _held_back(["layerwise"], margins, state, point_mass, factor)
    assert (
        "layerwise not refitted again: in round 1 it explained a chi^2 of 356 beyond transverse_shear"
        in held["layerwise"]
    )
    assert (
        _held_back(["layerwise"], margins, state, [fitted("point_mass", 400.0)], factor) == {}
    )  # 600 < 712: refit
    assert _held_back(["layerwise"], {}, state, point_mass, factor) == {}  # never refitted: no margin known
    assert (
        _held_back(["layerwise"], margins, state, [fitted("point_mass", -5000.0, selectable=False)], factor)
        == {}
    )


def test_a_refinement_is_tried_when_nothing_pays_far_from_the_noise():
    """Layerwise refines the shear candidates: tried when one of them paid, and also when
    none paid but one explained some misfit and the misfit is still ``far_from_noise``
    (the round would otherwise stop with the more complete theory untried); not when the
    misfit is near the noise, when the shear candidates explained nothing (and did not
    fail to start), or when another candidate pays (the round goes on without it)."""
    from types import SimpleNamespace

    from identify.diagnosis.diagnose import _refine

    far_from_noise, min_gain = SELECTION_POLICY.far_from_noise, SELECTION_POLICY.min_gain

    def tried(kind, scaled_gain, gain, selectable=True, above=False, fit=True, pruned=False):
        return SimpleNamespace(
            kind=kind,
            scaled_gain=scaled_gain,
            gain=gain,
            eligible=fit,
            selectable=selectable and fit,
            fit=SimpleNamespace(finished=True) if fit else None,
            added=SimpleNamespace(pruned=pruned, precheck=None),
            ended_above=lambda state: fit and above,
        )

    kinds = ["transverse_shear", "thick_plate", "layerwise", "point_mass"]
    far = SimpleNamespace(statistics=SimpleNamespace(reduced_chi2=30 * far_from_noise))
    near = SimpleNamespace(statistics=SimpleNamespace(reduced_chi2=far_from_noise / 2))
    stalled = [
        tried("transverse_shear", 8.4, 4564.6),
        tried("thick_plate", 3.0, 1953.7),
        tried("point_mass", -2.2, 4846.4),
    ]  # blind13's first round: nothing pays
    assert _refine("layerwise", kinds, [], stalled, far, SELECTION_POLICY)
    assert not _refine("layerwise", kinds, [], stalled, near, SELECTION_POLICY)
    nothing = [tried("transverse_shear", -3.0, -50.0), tried("thick_plate", -4.0, -80.0)]
    assert not _refine("layerwise", kinds, [], nothing, far, SELECTION_POLICY)
    paying_mass = stalled[:2] + [tried("point_mass", 2 * min_gain, 9000.0)]
    assert not _refine("layerwise", kinds, [], paying_mass, far, SELECTION_POLICY)
    paying_shear = [tried("transverse_shear", 2 * min_gain, 9000.0)]
    assert _refine("layerwise", kinds, [], paying_shear, near, SELECTION_POLICY)
    selected = ["thick_plate"]
    assert _refine("layerwise", kinds, selected, nothing, near, SELECTION_POLICY), (
        "what it refines is selected"
    )
    # The simpler theories failed to start (a refit that ended above the fit it contains,
    # or one that failed): far from the noise the fuller theory is tried, near it not.
    above = [tried("transverse_shear", -3.0, -50.0, above=True), tried("thick_plate", -4.0, -80.0)]
    assert _refine("layerwise", kinds, [], above, far, SELECTION_POLICY)
    assert not _refine("layerwise", kinds, [], above, near, SELECTION_POLICY)
    failed = [tried("transverse_shear", 0.0, 0.0, fit=False), tried("thick_plate", -4.0, -80.0)]
    assert _refine("layerwise", kinds, [], failed, far, SELECTION_POLICY)
    pruned = [tried("transverse_shear", 0.0, 0.0, fit=False, pruned=True), tried("thick_plate", -4.0, -80.0)]
    assert not _refine("layerwise", kinds, [], pruned, far, SELECTION_POLICY)


def test_a_refinement_does_not_start_from_a_failed_start():
    """A refinement starts where the lowest-criterion selectable candidate it refines
    ended, but not from one that ended above the fit it contains (a failed start): then
    from the next one, or from the state (None) as any candidate."""
    from types import SimpleNamespace

    from identify.diagnosis.diagnose import _refined_start

    def tried(kind, bic, above=False, selectable=True):
        return SimpleNamespace(
            kind=kind,
            bic=bic,
            selectable=selectable,
            fit=f"{kind} fit",
            ended_above=lambda state: above,
        )

    state = SimpleNamespace()
    mass = tried("point_mass", 10.0)
    shear, thick = tried("transverse_shear", 50.0), tried("thick_plate", 60.0)
    assert _refined_start("layerwise", [mass, shear, thick], state) == "transverse_shear fit"
    shear_above = tried("transverse_shear", 50.0, above=True)
    assert _refined_start("layerwise", [mass, shear_above, thick], state) == "thick_plate fit"
    thick_above = tried("thick_plate", 60.0, above=True)
    assert _refined_start("layerwise", [mass, shear_above, thick_above], state) is None
    unselectable = tried("thick_plate", 40.0, selectable=False)
    assert _refined_start("layerwise", [shear, unselectable], state) == "transverse_shear fit"


def test_shear_candidates_restart_from_the_spec_when_the_thin_plate_distorted_it():
    """``spec_start`` gives the spec's values as a start when the thin-plate fit is
    degenerate, and only then: a converged fit near the spec's values is not; one that
    moved a layer modulus more than ``DISTORTED`` times off the spec's value is (a spec
    whose E1 is 4 x what the data say stands for the thin plate that distorted it)."""
    from identify.fitting.driver import DISTORTED, fit_layers, spec_start

    truth = true_model().with_options(modes=6)
    data = synthetic_measurements(truth, modes=6, noise_rel=5e-4, seed=3, labels="close")
    model = start_model().with_options(modes=6)
    baseline = fit_layers(model, data)
    assert baseline.converged
    assert spec_start(model, data, baseline) is None
    e1 = next(p for p in baseline.parameters if p.kind == "E1")
    far = model.with_values({e1: (DISTORTED + 1) * baseline.value(e1)})
    start = spec_start(far, data, baseline)
    assert start is not None and start.value(e1) == pytest.approx(far.value(e1))
    assert start.rms_rel_error > baseline.rms_rel_error


@pytest.mark.parametrize("thickness_bic, pruned", [(995.0, False), (900.0, True)])
def test_only_a_candidate_that_pays_may_prune(monkeypatch, thickness_bic, pruned):
    """A round's refits in the order of their linearised bounds: the orientation (bound
    10) is pruned by the thickness refit that explained a chi^2 of 77 only when that refit
    pays for itself (gain / c above ``SelectionPolicy.min_gain``); at a gain of 5 it is no answer, and the
    orientation is refitted (held-out blind02: its bound, second order in the angles,
    understated what it explained)."""
    state = SimpleNamespace(
        statistics=SimpleNamespace(sum_squares=1000.0, bic=1000.0, n=30, scatter_known=True)
    )
    bounds = {"thickness": 100.0, "orientation": 10.0}
    refitted = []

    def prepare(state, kind, hints=(), start=None, free_again=()):
        return SimpleNamespace(kind=kind, bound=bounds[kind], added=())

    def refit(job):
        kind, below = job["kind"], job["prune_below"]
        if below is not None and 2.0 * bounds[kind] < below.chi2:
            return AddedEffect(kind, None, pruned=True)
        refitted.append(kind)
        statistics = SimpleNamespace(
            sum_squares=923.0, bic=thickness_bic if kind == "thickness" else 990.0, scatter_known=False
        )
        return AddedEffect(kind, SimpleNamespace(statistics=statistics, finished=True))

    monkeypatch.setattr(driver, "prepare_effect", prepare)
    monkeypatch.setattr(diagnose_module, "_add", refit)
    out = diagnose_module._try(
        diagnose_module.Round(Refit(state, None, None), ()), ["orientation", "thickness"]
    )
    assert refitted == (["thickness"] if pruned else ["thickness", "orientation"])
    assert [c.kind for c in out] == ["thickness", "orientation"]


@pytest.mark.parametrize("scatter_known", [True, False], ids=["std_hz_stated", "no_std_hz"])
def test_a_refit_is_abandoned_below_the_pay_floor_in_every_round(scatter_known):
    """Away from the noise level the pay floor does not prune a candidate's start (the
    pre-check's bound may understate it: blind02's orientation), but its refit is abandoned
    once it can no longer explain half of the floor (``abandon_below``): the least any
    candidate of k parameters must explain, c being at least 1.  With a stated scatter it
    is min_gain + k ln n units of chi^2.  Without one the criterion is n ln(RSS / n), and
    the floor the share of RSS that takes: a refit that explains exactly it gains exactly
    min_gain after k ln n (to round-off)."""
    import math

    from identify.engine.statistics import FitStatistics

    statistics = FitStatistics(30, 4, 1000.0 if scatter_known else 2.5e-5, 1e-3, scatter_known)
    round_ = diagnose_module.Round(Refit(SimpleNamespace(statistics=statistics), None, None), ())
    job = round_.job(SimpleNamespace(kind="orientation", bound=5.0, added=("a", "b", "c")), None)
    assert job["prune_below"] is None
    floor = job["abandon_below"]
    assert floor.of.startswith("it must explain to pay for itself (gain / c above 10 after 3 ln 30")
    least = SELECTION_POLICY.min_gain + 3 * math.log(30)
    if scatter_known:
        assert floor.chi2 == pytest.approx(least)
        return
    paying = replace(statistics, k=7, sum_squares=statistics.sum_squares - floor.chi2)
    assert statistics.bic - paying.bic == pytest.approx(SELECTION_POLICY.min_gain, rel=1e-9)
    assert 0 < floor.chi2 < statistics.sum_squares


@pytest.mark.parametrize("slow", ["thickness", "orientation"])
def test_refits_in_processes_are_pruned_by_earlier_batches_only(monkeypatch, slow):
    """Two processes: the refits go in batches of two by bound, [thickness, orientation],
    [suspension, rotary_inertia].  The thickness refit pays and explains a chi^2 of 77:
    it prunes the second batch (2 x bound < 77) but never its own batch's orientation
    (bound 30, which one process would prune), whichever of the two ends first.  When the
    thickness refit is the slow one, the second batch starts before it ends and is given
    the pruned result afterwards: the answer is the same, only the waiting differs."""
    state = SimpleNamespace(
        statistics=SimpleNamespace(sum_squares=1000.0, bic=1000.0, n=30, scatter_known=True)
    )
    bounds = {"thickness": 100.0, "orientation": 30.0, "suspension": 25.0, "rotary_inertia": 10.0}
    second_batch = threading.Event()
    ran = []

    def prepare(state, kind, hints=(), start=None, free_again=()):
        return SimpleNamespace(kind=kind, bound=bounds[kind], added=())

    def refit(job):
        kind, below = job["kind"], job["prune_below"]
        if below is not None and below.prunes(bounds[kind], 2.0):
            return AddedEffect(kind, None, pruned=True, error=f"pruned below {below.chi2:g}")
        ran.append(kind)
        if kind == "thickness" == slow:
            second_batch.wait(timeout=5.0)  # ends after the second batch has started
        elif kind == "orientation" == slow:
            time.sleep(0.3)  # the thickness refit's answer is in before this ends
        elif kind in ("suspension", "rotary_inertia"):
            second_batch.set()
        explained = 77.0 if kind == "thickness" else 3.0
        statistics = SimpleNamespace(
            sum_squares=1000.0 - explained, bic=1000.0 - explained + 5.0, scatter_known=False
        )
        return AddedEffect(kind, SimpleNamespace(statistics=statistics, finished=True))

    monkeypatch.setattr(driver, "prepare_effect", prepare)
    monkeypatch.setattr(diagnose_module, "_add", refit)
    with ThreadPoolExecutor(2) as pool:
        out = diagnose_module._try(
            diagnose_module.Round(Refit(state, None, None), (), pool=pool, n_workers=2), list(bounds)
        )
    assert [c.kind for c in out] == ["thickness", "orientation", "suspension", "rotary_inertia"]
    assert [c.fit is not None for c in out] == [True, True, False, False]
    assert [c.error for c in out[2:]] == ["pruned below 77", "pruned below 77"]
    # started while the thickness refit ran, their answers thrown away
    assert ("suspension" in ran) == (slow == "thickness")


#: A final refit's parameters as ``_determined_final`` reads them: a layer property and
#: a point mass's amount and position (values SI).
_PARAMETERS = (Parameter("E1", "steel"), Parameter("mass", "point_mass"), Parameter("y", "point_mass"))


def _fit(status, rms=1e-3, condition=1e3, vague=(), chi2=30.0, k=12):
    """A refit as ``_determined_final`` reads it: status, misfit (RMS and chi^2 with k
    parameters on 30 frequencies), conditioning and which parameters (of
    ``_PARAMETERS``, by kind) the scatter leaves undetermined."""
    verdict = condition_verdict(condition)
    measured = np.linspace(200.0, 3000.0, 30)
    return SimpleNamespace(
        status=status,
        rms_rel_error=rms,
        statistics=_stats(chi2, k),
        # 0.02 % scatter, a layerwise model (its own error 0.049 %), residuals of +-rms
        measurements=SimpleNamespace(
            table=pd.DataFrame({"frequency_hz": measured, "std_hz": 2e-4 * measured})
        ),
        model=SimpleNamespace(options=SimpleNamespace(theory_std_rel=SHEAR_THEORY_STD_REL)),
        model_hz=measured * (1 + rms * (-1.0) ** np.arange(30)),
        converged=status is FitStatus.CONVERGED,
        parameters=_PARAMETERS,
        values=np.array([200e9, 0.8e-3, 0.07]),
        effect_of={p: "point_mass" for p in _PARAMETERS[1:]},
        uncertainty=SimpleNamespace(
            condition_number=condition,
            verdict=verdict,
            std=np.array([2e9, 2.5e-3, 1e3]),
            undetermined=tuple(p.kind in vague for p in _PARAMETERS),
        ),
    )


def _chosen(kind):
    return Candidate(kind, "", AddedEffect(kind, None), 100.0, 100.0)


@pytest.mark.parametrize(
    "final_status, vague, n_selected, again_condition, again_status, dropped",
    [
        (FitStatus.NOT_IDENTIFIABLE, (), 2, 1e4, FitStatus.POOR_FIT, True),  # blind22 (run 8): taken out
        (
            FitStatus.NOT_IDENTIFIABLE,
            (),
            2,
            1e9,
            FitStatus.POOR_FIT,
            False,
        ),  # without it no better determined
        (FitStatus.NOT_IDENTIFIABLE, (), 1, 1e4, FitStatus.POOR_FIT, False),  # the only effect: kept
        (FitStatus.CONVERGED, (), 2, 1e4, FitStatus.POOR_FIT, False),  # determined: nothing to do
        # A mass the data cannot tell from none (0.8 +- 2.5 g), the refit without it consistent with
        # the scatter (blind22): taken out.
        (FitStatus.CONVERGED, ("mass", "y"), 2, 1e4, FitStatus.CONVERGED, True),
        (FitStatus.CONVERGED, ("mass",), 1, 1e4, FitStatus.CONVERGED, False),
        # Its position undetermined but its mass not (a sensor on a line of symmetry): kept.
        (FitStatus.CONVERGED, ("y",), 2, 1e4, FitStatus.CONVERGED, False),
        # The amount undetermined, but without it the refit is a poor fit beyond the scatter and
        # the theory's own error, which the mass pays over (blind81): kept, with a step that says so.
        (FitStatus.POOR_FIT, ("mass",), 2, 1e4, "far", "kept"),
        # ... not when the final refit is not identifiable (blind22 on 6e47d2d) ...
        (FitStatus.NOT_IDENTIFIABLE, ("mass",), 2, 1e4, "far", True),
        # ... nor when the refit without it is a poor fit only against the scatter alone, within
        # the theory's own error (blind22: 0.0329 % on 0.020 % scatter): taken out.
        (FitStatus.CONVERGED, ("mass",), 2, 1e4, "within_theory", True),
    ],
)
def test_an_effect_that_leaves_the_final_refit_undetermined_is_taken_out(
    monkeypatch, final_status, vague, n_selected, again_condition, again_status, dropped
):
    """The final refit fits the frequencies but does not determine the last selected
    effect (its sensitivity matrix singular, or the effect's amount with a std at least its
    value): that effect is taken out and the selection before it refitted from the state
    it was chosen on; the new final is kept only when it is determined, and only when an
    effect remains.  An undetermined amount stays when the refit without it is not
    consistent with the scatter and the effect pays for itself over that refit: chi^2
    45 with 15 parameters against 400 with 12 is a gain / c of 355 / 3 - 3 ln 30 = 108."""
    layerwise, mass = _chosen("layerwise"), _chosen("point_mass")
    selected = [layerwise, mass][:n_selected] if n_selected == 2 else [mass]
    starts = {c.kind: object() for c in selected}
    steps = [Step(i + 1, (), starts[c.kind], (c,), c, "add") for i, c in enumerate(selected)]
    condition = 3e9 if final_status is FitStatus.NOT_IDENTIFIABLE else 1e5
    # chi^2 45 (20 beside the refit within the theory's error, so that the mass would pay there)
    final_chi2 = 20.0 if again_status == "within_theory" else 45.0
    final = _fit(final_status, rms=2e-4, condition=condition, vague=vague, chi2=final_chi2, k=15)
    calls = []

    def refit(refitting, state, chosen, say, policy, like=None):
        calls.append((state, [c.kind for c in chosen]))
        if again_status == "far":  # 0.2 %: 4.3 x the scatter and theory together
            return _fit(FitStatus.POOR_FIT, rms=2e-3, condition=again_condition, chi2=400.0)
        if again_status == "within_theory":  # 0.033 %: 1.65 x the scatter, 0.62 x with the theory
            return _fit(FitStatus.POOR_FIT, rms=3.3e-4, condition=again_condition, chi2=81.7)
        return _fit(again_status, rms=4e-4, condition=again_condition, chi2=20.0)

    monkeypatch.setattr(diagnose_module, "_final", refit)
    out = diagnose_module._determined_final(None, final, steps, selected, lambda text: None, SELECTION_POLICY)
    if not dropped:
        assert out is None
        return
    if dropped == "kept":
        kept, step, taken_out = out
        assert kept is final and taken_out == ()
        assert step.chosen is None and step.reason.startswith("keep point_mass")
        assert "point_mass.mass 0.8 +- 2.5" in step.reason and "gain / c = 108.1" in step.reason
        return
    again, step, taken_out = out
    assert taken_out == ("point_mass",)
    assert calls == [(starts["point_mass"], ["layerwise"])]  # from the state point_mass was chosen on
    assert step.chosen is None and step.candidates == (mass,) and step.reason.startswith("drop point_mass")
    if vague:
        assert "point_mass.mass 0.8 +- 2.5" in step.reason  # the amount in the spec's unit, g
    comparison = SimpleNamespace(at_noise_level=False)
    diagnosis = Diagnosis(
        _fit(FitStatus.POOR_FIT, rms=1e-2),
        comparison,
        (),
        tuple(steps) + (step,),
        again,
        dropped=("point_mass",),
    )
    assert [c.kind for c in diagnosis.selected] == ["layerwise"]
    assert "point_mass taken out" in diagnosis.verdict


def test_layerwise_is_not_tried_in_place_of_the_single_shear_layer_it_is(monkeypatch, example_spec):
    """A single homogeneous plate (one configuration, one layer) has one shear group and
    no stretching layer: its layerwise theory is ``thick_plate`` itself (equal to
    round-off, ``tests/fem/test_layerwise.py``), so the selection's end does not refit it
    in place of the single shear layer.  The bundled example's bonded configurations stack
    several materials: there it is another model.  (A single wood layer is not such a
    plate: its rolling shear modulus G23 is below a tenth of G13, so the layerwise model
    lets it stretch through its thickness, E3 = E2, which the single shear layer does not.)"""
    from fem.effects import effect
    from identify.diagnosis.diagnose import _completed
    from studies.long_plates import handbook_model

    single = handbook_model()
    layerwise = effect("layerwise")
    assert layerwise.single_shear_layer(single)
    assert not layerwise.single_shear_layer(example_spec)

    def refitted(*args, **kwargs):
        raise AssertionError("layerwise refitted in place of the single shear layer it is")

    monkeypatch.setattr(driver, "add_effect", refitted)
    state = SimpleNamespace(model=single.with_options(transverse_shear=True, rotary_inertia=True))
    selected = [SimpleNamespace(kind="thick_plate")]
    assert _completed(None, state, selected, ["thick_plate", "layerwise"], print, SELECTION_POLICY) is None


def test_a_user_registered_effect_takes_part_in_a_diagnosis(paper_model):
    """An effect a user registers is a candidate like a built-in one: a cable clip of
    unknown mass at a known place (30, 40) mm, planted at 2 g in the paper plate's data (3
    configurations x 6 labelled modes, 1e-4 scatter), is selected by ``diagnose`` among
    it and the suspension, and its mass comes back within 3 std; the effect's own
    declarations (``Effect.refines``, ``covers``, ``sign``...) are the defaults."""
    import numpy as np

    from fem.effects import REGISTRY, Effect, SwitchedOn, register
    from fem.specimen import Parameter

    mass = Parameter("mass", "clip")

    def clipped(model, kg):
        return model.with_attachments(model.specimen.attachments + (PointMass(kg, 0.030, 0.040, "clip"),))

    class CableClip(Effect):
        kind = "cable_clip_test"
        description = "a cable clip of unknown mass at (30, 40) mm"

        def fixed(self, model, table):
            return SwitchedOn(self.kind, clipped(model, 2e-3))

        def free(self, model, hint=None):
            return [SwitchedOn(self.kind, clipped(model, 0.5e-3), (mass,), "clip mass free")]

    data = synthetic_measurements(clipped(paper_model, 2e-3), modes=6, noise_rel=1e-4, seed=3, labels="all")
    try:
        register(CableClip())
        result = diagnose_module.diagnose(paper_model, data, ["cable_clip_test", "suspension"])
    finally:
        REGISTRY.pop("cable_clip_test", None)
    assert [c.kind for c in result.selected] == ["cable_clip_test"], result.report()
    final = result.final
    std = float(final.uncertainty.std[list(final.parameters).index(mass)])
    assert np.isfinite(std) and abs(final.value(mass) - 2e-3) < 3 * std, (final.value(mass), std)


def test_the_refit_policy_is_read_not_the_module_defaults():
    """The pruning rule reads the refit context's ``RefitPolicy``: a candidate whose
    linearised bound is 1/1.5 of what another explained is kept by the default factor 2
    (2/1.5 > 1) but pruned by a policy of factor 0.5, and the note states the factor used."""
    from identify.fitting.driver import REFIT_POLICY, Prepared, PruneBelow, RefitPolicy

    prepared = Prepared("orientation", None, (), (), SimpleNamespace(singular=False), (), 100.0)
    strict = Refit(None, None, None, policy=RefitPolicy(prune_factor=0.5))
    added = add_effect(strict, "orientation", prepared=prepared, prune_below=PruneBelow(150.0))
    assert added.pruned and "less than 1/0.5 of the 150" in added.error
    assert REFIT_POLICY.prune_factor * prepared.bound >= 150.0  # the default would refit it
    default = Refit(None, None, None)
    assert add_effect(
        default, "orientation", prepared=prepared, prune_below=PruneBelow(300.0)
    ).pruned  # 2 x 100 < 300
    # The iteration budget too: a context built with a policy and no options iterates as
    # the policy says, the default context as the documented default.
    assert Refit(None, None, None, policy=RefitPolicy(effect_iterations=7)).options.max_iterations == 7
    assert default.options == REFIT_POLICY.options


def test_the_default_policies_are_the_documented_ones():
    """The defaults of ``SelectionPolicy`` and its ``RefitPolicy`` are the numbers
    docs/diagnosis.md gives ("The numbers, in one place"), field by field, and every field
    is in the table."""
    import re
    from dataclasses import fields
    from pathlib import Path

    text = (Path(__file__).parents[3] / "docs" / "diagnosis.md").read_text()
    documented = {
        name: float(value) for name, value in re.findall(r"^\| `([a-z0-9_.]+)` \| ([0-9.]+) \|", text, re.M)
    }
    policy = SELECTION_POLICY
    shown = {f.name: getattr(policy, f.name) for f in fields(policy) if f.name != "refits"}
    shown |= {f"refits.{f.name}": getattr(policy.refits, f.name) for f in fields(policy.refits)}
    assert documented == pytest.approx(shown)


def test_at_the_noise_level_only_a_candidate_that_could_pay_is_refitted():
    """A state at the noise level still runs a round (blind86: layerwise at 1.18 x the
    scatter, the sensor's point mass then gains 14 / c), but a candidate is refitted only
    where 2 x its linearised bound reaches what it must explain to pay: ``min_gain`` + k
    ln n (c at its least, 1), here 10 + 3 ln 30 = 20.2 for a point mass's three
    parameters; what another candidate explained prunes as before when it is larger."""
    from identify.fitting.driver import Prepared

    state = SimpleNamespace(statistics=SimpleNamespace(n=30, sum_squares=42.0, scatter_known=True))
    at_noise = diagnose_module.Round(Refit(state, None, None), (), must_pay=True)
    added = tuple(Parameter(k, "point_mass") for k in ("mass", "x", "y"))
    check = SimpleNamespace(singular=False)
    weak = Prepared("point_mass", None, (), added, check, (), 9.0)  # 2 x 9 = 18 < 20.2
    floor = at_noise.job(weak, None)["prune_below"]
    assert floor.chi2 == pytest.approx(10 + 3 * np.log(30))
    pruned = add_effect(at_noise.refit, "point_mass", prepared=weak, prune_below=floor)
    assert pruned.pruned and pruned.result is None
    assert "less than 1/2 of the 20.2 it must explain to pay for itself at the noise level" in pruned.error
    assert "after 3 ln 30" in pruned.error
    # a larger reduction another candidate explained is the stricter test, as in any round
    assert at_noise.job(weak, 100.0)["prune_below"].chi2 == 100.0
    # away from the noise level nothing prunes before a candidate has paid
    assert diagnose_module.Round(Refit(state, None, None), ()).job(weak, None)["prune_below"] is None


def _stats(sum_squares: float, k: int, n: int = 30):
    """Fit statistics with a stated scatter: chi^2 ``sum_squares``, k parameters, n frequencies."""
    return SimpleNamespace(
        scatter_known=True,
        sum_squares=sum_squares,
        k=k,
        n=n,
        dof=n - k,
        reduced_chi2=sum_squares / (n - k),
        bic=sum_squares + k * np.log(n),
    )


def _tried(kind: str, state, sum_squares: float, k: int, implausible=()) -> Candidate:
    fit = SimpleNamespace(statistics=_stats(sum_squares, k), finished=True, rms_rel_error=1e-3)
    added = SimpleNamespace(kind=kind, result=fit, implausible=implausible, precheck=None, notes=())
    return _candidate(state, added)
