"""Which physical effects is the model missing?  A forward selection.

The baseline (layer properties fitted, no effect) is compared with refits that switch
one more effect on, its parameters free together with everything already free.  Each is
judged by the Bayesian information criterion, BIC = chi^2 + k ln n (chi^2 in units of the
measurement scatter, k free parameters, n frequencies), so an effect's extra parameters
must pay for themselves; without a stated scatter, chi^2 is replaced by n ln(RSS / n).

Forward selection: the effect that lowers the criterion most is added, the others are tried
again on top of it, and so on, until nothing pays for itself: its gain, divided by the
over-dispersion c = max(1, reduced chi^2) the refit leaves (a misfit made of model error,
not noise, shrinks every chi^2 difference's weight), must exceed
``SelectionPolicy.min_gain``.  Once the misfit is at the noise level a round refits only the
candidates whose linearised bound could pay (``Round.must_pay``).  Before a refit one
evaluation checks the conditioning of the augmented sensitivity matrix (``precheck``): a
singular candidate is reported as not identifiable and never iterated.  An estimate that is
physically unlikely (``plausibility``), or whose refit ends singular
(``Candidate.singular``), is never selected whatever its gain, nor may it keep another
candidate from being refitted: it is reported as a sign of what is missing (``Effect.sign``;
``docs/diagnosis.md`` states every rule and threshold).  Implausible estimates are also
ranked behind plausible rivals whose criterion is within ``plausibility_margin`` (in units
of c); of two candidates with the same free parameters, the one with more of the physics
every plate has (``thick_plate`` over ``transverse_shear``) is preferred unless the other is
better by ``complete_margin``.  Candidates are refitted with the pairing re-checked at their
solution (``repair``), in parallel processes when that pays; the selection is finally
refitted in full (iterations, pairing check), and that refit's own status says whether the
data are now explained.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Executor, wait
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from fem.effects import REGISTRY, effect
from fem.model import SpecimenModel
from fem.numbers import finite_or_none
from fem.solver.sensitivity import Verdict
from fem.solver.threads import one_blas_thread
from fem.specimen import Parameter

from ..engine.parameters import display, json_key
from ..engine.peak_lists import matching_cost, model_error
from ..engine.result import FitResult, FitStatus
from ..engine.statistics import CHI2_TEST_LEVEL
from ..engine.ties import Tied
from ..engine.updating import FitOptions, Settle
from ..fitting.budget import with_theory_accuracy
from ..fitting.driver import (
    AddedEffect,
    PruneBelow,
    Refit,
    RefitPolicy,
    Refitting,
    add_effect,
    afresh_from_spec,
    worker_pool,
)
from ..measurements import Measurements
from ..reporting.diagnosis_report import diagnosis_text, diagnosis_view
from .compare import Comparison, compare
from .leads import Lead, leads
from .ranking import plausible_first


@dataclass(frozen=True)
class SelectionPolicy:
    """The numbers of the forward selection; a study or a test passes another to vary
    them (``diagnose(..., policy=...)``).  docs/diagnosis.md gives each with the cases
    behind it.

    ``min_gain``: an effect is selected when its BIC gain / c exceeds this (Kass and
    Raftery's "very strong" evidence, 2 ln B > 10).  ``plausibility_margin``: an
    implausible estimate is ranked behind plausible rivals within this many units of c.
    ``complete_margin``: a candidate with the physics of another and more that every
    real plate has (rotary inertia: ``thick_plate`` against ``transverse_shear``; a soft
    layer's own shear: ``layerwise`` against both), with no more free parameters, is
    preferred unless the lesser one's criterion is lower by more than this (units of c;
    2 ln B > 6 is "strong" evidence): where the data cannot tell, the lesser model's
    error is taken up by the moduli.  ``far_from_noise``: a refinement
    (``Effect.refines``) is also tried when nothing paid in its round, what it refines
    explained some misfit and the reduced chi^2 is still above this (25: an RMS five
    times the scatter), and the diagnosis points where to look when it ends unexplained
    this far from the noise (``leads``).  ``candidate_iterations``,
    ``candidate_stall_chi2``: a candidate's refit stops after that many iterations or
    once chi^2 falls by less than that per step, three in a row (a ranking needs the
    misfit, not the last digits of the parameters).  ``final_stall_chi2``: the chosen
    and the final refits run to convergence (``refits.effect_iterations``) or until chi^2
    falls by less than this per step, three in a row, where a weakly determined
    direction only creeps (its std then says so).  ``parallel_from``: candidate refits
    run in worker processes when a round has at least this many and the baseline fit
    took at least ``refits.parallel_from_s``.  ``refits``: how the effects are refitted
    (``RefitPolicy``)."""

    min_gain: float = 10.0
    plausibility_margin: float = 10.0
    complete_margin: float = 6.0
    far_from_noise: float = 25.0
    candidate_iterations: int = 20
    candidate_stall_chi2: float = 0.1
    final_stall_chi2: float = 0.01
    parallel_from: int = 3
    refits: RefitPolicy = RefitPolicy()

    @property
    def candidate_options(self) -> FitOptions:
        """The iteration control of a candidate's refit."""
        return FitOptions(max_iterations=self.candidate_iterations, stall_chi2=self.candidate_stall_chi2)

    @property
    def final_options(self) -> FitOptions:
        """The iteration control of the chosen refit of a round and of the final one."""
        return FitOptions(max_iterations=self.refits.effect_iterations, stall_chi2=self.final_stall_chi2)


#: The documented defaults (docs/diagnosis.md).
SELECTION_POLICY = SelectionPolicy()


@dataclass(frozen=True)
class Candidate:
    """One effect added to a state of the selection: its refit, the BIC gain over the
    state (positive = better) and that gain / c (``scaled_gain``, see the module doc)."""

    kind: str
    note: str
    added: AddedEffect
    gain: float
    scaled_gain: float
    error: str = ""
    # implausible alone, plausible with this effect refitted on top of it (``_afresh_from_spec``)
    plausible_with: str = ""
    # refitted from the spec's values to the whole peak list, its gain the matching cost's
    # fall over every peak (``_rematched_candidate``)
    matched_afresh: bool = False

    @property
    def fit(self) -> FitResult | None:
        return self.added.result

    @property
    def precheck(self):
        """The conditioning before the refit (a ``fitting.Precheck``; None when not run)."""
        return self.added.precheck

    @property
    def plausible(self) -> bool:
        return not self.added.implausible

    @property
    def eligible(self) -> bool:
        """Can be selected: refitted to a finished (converged or poor) fit."""
        return self.fit is not None and self.fit.finished

    def ended_above(self, state: FitResult) -> bool:
        """Refitted to a finished fit that ended above the fit it contains
        (``AddedEffect.ended_above``): a failed start."""
        return self.eligible and self.added.ended_above(state)

    @property
    def singular(self) -> bool:
        """The refit ended where the frequencies do not determine its parameters: the
        condition number at the solution above the paper's limit and ``SINGULAR_GROWTH``
        times the start's without the effect (as ``precheck`` judges the start)."""
        check, fit = self.precheck, self.fit
        if fit is None or check is None:
            return False
        return check.singular_at(fit.uncertainty.condition_number)

    @property
    def selectable(self) -> bool:
        """Can be selected: finished, plausible and identifiable at its solution.  An
        implausible or singular estimate is never an answer, whatever its BIC gain: it is
        reported as a sign of what is missing (``Effect.sign``)."""
        return self.eligible and self.plausible and not self.singular

    @property
    def rms_rel_error(self) -> float:
        return self.fit.rms_rel_error if self.fit else float("nan")

    @property
    def bic(self) -> float:
        return self.fit.statistics.bic if self.fit else float("inf")

    def effect_values(self) -> dict[str, float]:
        """The effect's own parameters in display units (e.g. mass_g, x_mm; a material's
        shear moduli as 'cfrp.G13_GPa')."""
        return _values(self.fit, self.added.added) if self.fit else {}

    def effect_std(self) -> dict[str, float | None]:
        return _values(self.fit, self.added.added, std=True) if self.fit else {}

    @property
    def status(self) -> str:
        """The refit's status word, or why there is none (``not_applicable``,
        ``not_identifiable``, ``not_refitted``: pruned, or ``failed``)."""
        if self.fit is not None:
            return self.fit.status.value
        if not self.added.applicable:
            return "not_applicable"
        if self.precheck is not None and self.precheck.singular:
            return "not_identifiable"
        return "not_refitted" if self.added.pruned else "failed"

    def to_dict(self) -> dict:
        check = self.precheck
        return {
            "effect": self.kind,
            "rms_rel_error_after": self.rms_rel_error if self.fit else None,
            "bic_gain": finite_or_none(self.gain),
            "gain_over_c": finite_or_none(self.scaled_gain),
            "status": self.status,
            "parameters": self.effect_values(),
            "std": self.effect_std(),
            "plausible": self.plausible,
            "implausible": list(self.added.implausible),
            "condition_number": finite_or_none(check.condition_number) if check else None,
            "seconds": finite_or_none(self.added.seconds),
            "note": " ".join(x for x in (self.note, self.error) if x),
            "matched_afresh": self.matched_afresh,
            "plausible_with": self.plausible_with or None,
        }


def _key(p) -> str:
    if p.kind in ("angle", "thickness", "G13", "G23"):
        return f"{p.target}.{json_key(p)}"
    return json_key(p)


def _values(fit: FitResult, parameters, std: bool = False) -> dict:
    out = {}
    for p in parameters:
        value = fit.std(p) if std else fit.value(p)
        out[_key(p)] = finite_or_none(display(p, value)) if std else display(p, value)
        if isinstance(p, Tied):  # a follower: its ratio to the leader
            for follower, ratio in p.followers:
                out[_key(follower)] = (
                    finite_or_none(display(follower, ratio * value))
                    if std
                    else display(follower, ratio * value)
                )
    return out


@dataclass(frozen=True)
class Step:
    """One round of the forward selection: from ``start`` (the effects selected so far),
    every remaining candidate tried (most preferred first); ``chosen`` or None, and why."""

    number: int
    selected_before: tuple[str, ...]
    start: FitResult
    candidates: tuple[Candidate, ...]
    chosen: Candidate | None
    reason: str
    skipped: tuple[str, ...] = ()  # refinements not tried (what they refine did not pay)
    seconds: float = float("nan")  # the round's wall time
    # candidates whose refit ended above the fit it contains (``AddedEffect.ended_above``)
    above_start: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        return {
            "round": self.number,
            "with": list(self.selected_before),
            "rms_rel_error": self.start.rms_rel_error,
            "candidates": [c.to_dict() for c in self.candidates],
            "not_tried": list(self.skipped),
            "chosen": self.chosen.kind if self.chosen else None,
            "reason": self.reason,
            "seconds": finite_or_none(self.seconds),
        }


@dataclass(frozen=True)
class Diagnosis:
    """The baseline and its residual patterns (``comparison``), the forward selection
    (``steps``), the first round's ranking (``candidates``: one effect at a time, most
    preferred first) and the ``final`` refit with the selected effects (None when none)."""

    baseline: FitResult
    comparison: Comparison
    candidates: tuple[Candidate, ...]
    steps: tuple[Step, ...] = ()
    final: FitResult | None = None
    seconds: float = float("nan")
    dropped: tuple[str, ...] = ()  # chosen in a round, taken out at the end (``_determined_final``)
    policy: SelectionPolicy = SELECTION_POLICY

    @property
    def at_noise_level(self) -> bool:
        return self.comparison.at_noise_level

    @property
    def selected(self) -> tuple[Candidate, ...]:
        return tuple(
            s.chosen for s in self.steps if s.chosen is not None and s.chosen.kind not in self.dropped
        )

    @property
    def above_start(self) -> tuple[str, ...]:
        """Candidates whose refit ended above the fit it contains (``Step.above_start``,
        ``AddedEffect.ended_above``), as "round N: kind": at the limit where the effect's
        parameters vanish the refit is the state it was added to (with rotary inertia, for
        the kinds that keep it, where that is higher), so this is a failed refit to report,
        not a normal event: the count should be 0.  An effect that frees no parameter
        (rotary inertia alone) has no such limit and is never counted."""
        return tuple(f"round {s.number}: {kind}" for s in self.steps for kind in s.above_start)

    @property
    def explained(self) -> bool:
        """The data are explained: at the noise level without effects, or the final refit
        with the selection converged (its misfit consistent with the scatter)."""
        return self.at_noise_level or (self.final is not None and self.final.converged)

    @property
    def leads(self) -> tuple[Lead, ...]:
        """Where to look (``leads.leads``) when the data are not explained and the misfit the
        selection ends with is ``policy.far_from_noise`` times the (stated or assumed) scatter;
        empty otherwise."""
        if self.explained or not self.steps:
            return ()
        st = (self.final or self.baseline).statistics
        if st.dof <= 0 or st.chi2_against_scatter / st.dof <= self.policy.far_from_noise:
            return ()
        return leads(self.steps[-1])

    @property
    def verdict(self) -> str:
        if self.at_noise_level:
            return "nothing beyond the measurement scatter remains: no effect is needed"
        if not self.selected:
            text = "no candidate effect explains the misfit well enough to pay for its parameters"
            if self.leads:
                st = self.baseline.statistics
                text += (
                    f"; the misfit left is far from the noise (RMS {100 * st.rms_rel_error:.3g} %, "
                    f"{st.chi2_against_scatter / st.dof:.3g} x the scatter in chi^2): something is "
                    "missing, see where to look"
                )
            return text
        final = self.final
        chain = " + ".join(c.kind for c in self.selected)
        text = (
            f"missing: {chain} (RMS error {100 * self.baseline.rms_rel_error:.3g} % -> "
            f"{100 * final.rms_rel_error:.3g} %, refit {final.status.value})"
        )
        chosen = {c.kind for c in self.selected}
        odd = [c.kind for c in self.selected if not c.plausible and c.plausible_with not in chosen]
        if odd:
            text += (
                f"; implausible estimate of {', '.join(odd)}: "
                "read it as a sign of what is missing, not a value"
            )
        if self.dropped:
            text += (
                f"; {', '.join(self.dropped)} taken out: with it the refit fitted but did not determine its "
                "parameters"
            )
        if not final.converged:
            text += "; the refit still does not explain the data"
        return text

    def to_dict(self) -> dict:
        final = self.final
        return {
            "rms_rel_error": self.baseline.rms_rel_error,
            "reduced_chi2": self.baseline.statistics.reduced_chi2
            if self.baseline.statistics.scatter_known
            else None,
            "verdict": self.verdict,
            "at_noise_level": self.at_noise_level,
            "explained": self.explained,
            "ranking": [c.to_dict() for c in self.candidates],
            "selected": [
                {
                    "effect": c.kind,
                    "rms_rel_error_after": c.rms_rel_error,
                    "bic_gain": finite_or_none(c.gain),
                    "parameters": c.effect_values(),
                    "plausible": c.plausible,
                }
                for c in self.selected
            ],
            "path": [s.to_dict() for s in self.steps],
            # The fit's own document: its "effects" table holds the selected effects' estimates.
            "final": None if final is None else final.to_dict(),
            "dropped": list(self.dropped),
            "above_start": list(self.above_start),
            "leads": [lead.to_dict() for lead in self.leads],
            "seconds": finite_or_none(self.seconds),
        }

    def _repr_html_(self) -> str:
        """The notebook view (``reporting.diagnosis_report.diagnosis_view``)."""
        return diagnosis_view(self)

    def report(self) -> str:
        """The text report (``reporting.diagnosis_report.diagnosis_text``)."""
        return diagnosis_text(self)


def _signs(ordered, best, policy: SelectionPolicy) -> str:
    """Candidates not selectable (implausible, or singular at their solution) that explain
    more than the chosen one would: reported as signs."""
    floor = best.fit.statistics.sum_squares if best is not None else float("inf")
    out = []
    for c in ordered:
        if (
            c.eligible
            and not c.selectable
            and c.fit.statistics.sum_squares < floor
            and c.scaled_gain > policy.min_gain
        ):
            why = "implausible" if not c.plausible else "singular at its solution"
            out.append(
                f"{c.kind} would pay (gain / c = {c.scaled_gain:.1f}) but is {why}, not taken: "
                + effect(c.kind).sign
            )
    return ("; " + "; ".join(out)) if out else ""


def _canonical(kinds) -> frozenset:
    out = set()
    for k in kinds:
        out |= effect(k).physics
    return frozenset(out)


def _refine(kind: str, kinds, selected, candidates, state: FitResult, policy: SelectionPolicy) -> bool:
    """Is refinement ``kind`` worth a refit in this round: what it refines is not among the
    candidates at all, or is selected already, or paid for itself in this round (even at
    the noise level: the refinement may be the more complete physics, ``complete_margin``),
    or, while nothing paid and the misfit is ``far_from_noise``, explained some misfit or
    failed to start (its refit failed, or ended above the fit it contains): the round would
    stop with the more complete theory untried."""
    refined = set(effect(kind).refines)
    if not refined & set(kinds) or refined & set(selected):
        return True
    if any(c.scaled_gain > policy.min_gain for c in candidates if c.kind in refined):
        return True
    nothing_pays = not any(c.selectable and c.scaled_gain > policy.min_gain for c in candidates)
    far = state.statistics.reduced_chi2 > policy.far_from_noise
    simpler = [c for c in candidates if c.kind in refined]
    explained = any(c.eligible and c.gain > 0 for c in simpler)
    failed = any(_failed_to_start(c, state) for c in simpler)
    return nothing_pays and far and (explained or failed)


def _failed_to_start(candidate: Candidate, state: FitResult) -> bool:
    """A candidate whose refit failed (not pruned, not unidentifiable beforehand) or ended
    above the fit it contains (``Candidate.ended_above``)."""
    added = candidate.added
    if candidate.fit is None:
        return not added.pruned and not (added.precheck is not None and added.precheck.singular)
    return candidate.ended_above(state)


def _margins(refined: list[str], candidates, number: int) -> dict[str, tuple[int, float, str]]:
    """For each refinement refitted this round whose refit finished (converged or a poor
    fit): (round, the chi^2 it explained beyond the best of what it refines, that effect).
    A refit stopped at its iteration limit measured its start, not the refinement, so it
    holds nothing back later (the case behind it: docs/diagnosis.md, blind171)."""
    out = {}
    for kind in refined:
        mine = next((c for c in candidates if c.kind == kind and c.fit is not None and c.fit.finished), None)
        base = [c for c in candidates if c.kind in effect(kind).refines and c.fit is not None]
        if mine is not None and base:
            best = min(base, key=lambda c: c.fit.statistics.sum_squares)
            out[kind] = (number, best.fit.statistics.sum_squares - mine.fit.statistics.sum_squares, best.kind)
    return out


def _held_back(
    refining: list[str],
    margins: dict,
    state: FitResult,
    candidates,
    factor: float,
) -> dict[str, str]:
    """Refinements not refitted again this round, each with its note: what one explained
    beyond what it refines when last refitted is less than 1 / ``factor`` (the pruning
    rule's own, ``RefitPolicy.prune_factor``) of what
    another candidate explains now, so it cannot be this round's choice (the layerwise
    refit is 70 % of a round on a thick 3-D plate, 140-160 s, and in a later round it
    only repeated its earlier margin)."""
    explained = [
        (state.statistics.sum_squares - c.fit.statistics.sum_squares, c.kind)
        for c in candidates
        if c.selectable
    ]
    if not explained:
        return {}
    best, by = max(explained)
    held = {}
    for kind in refining:
        if kind in margins and margins[kind][1] * factor < best:
            number, margin, of = margins[kind]
            held[kind] = (
                f"; {kind} not refitted again: in round {number} it explained a chi^2 of {margin:.4g} beyond "
                f"{of}, less than 1/{factor:g} of the {best:.4g} {by} explains now"
            )
    return held


def _refined_start(kind: str, candidates, state: FitResult) -> FitResult | None:
    """The fit a refinement's refit starts from: the lowest-criterion finished candidate
    among the effects ``kind`` refines, unless it ended above ``state`` (a failed start
    is no place to start from); None: from ``state``, as any candidate, so that a refit
    ending above it is continued from the thin-plate limit at its values."""
    refined = [
        c for c in candidates if c.kind in effect(kind).refines and c.selectable and not c.ended_above(state)
    ]
    return min(refined, key=lambda c: c.bic).fit if refined else None


def _more_complete(
    best: Candidate | None, ordered, selected, c_hat: float, margin: float
) -> Candidate | None:
    """``best``, or an eligible, plausible candidate whose physics strictly contains it
    (with what is ``selected``) with the same number of free parameters and a criterion
    within ``margin`` x ``c_hat`` of it (``SelectionPolicy.complete_margin``)."""
    if best is None:
        return None
    mine = _canonical(list(selected) + [best.kind])
    fuller = [
        c
        for c in ordered
        if c is not best
        and c.selectable
        and _canonical(list(selected) + [c.kind]) > mine
        and c.fit.statistics.k == best.fit.statistics.k
        and c.bic - best.bic < margin * c_hat
    ]
    return min(fuller, key=lambda c: c.bic) if fuller else best


def _nested(a: str, b: str, selected) -> bool:
    """The physics of one candidate contains the other's (with what is selected), e.g.
    transverse_shear and thick_plate: not rivals but the same explanation, one with a part
    more."""
    x, y = _canonical(list(selected) + [a]), _canonical(list(selected) + [b])
    return x <= y or y <= x


def _eligible_kinds(kinds: list[str], selected: list[str], closed: set[str]) -> list[str]:
    """The candidates worth a refit on top of ``selected``: not closed (not identifiable,
    nothing to act on), changing the model, and not the same as an earlier one."""
    now = _canonical(selected)
    seen, out = set(), []
    for k in kinds:
        if k in selected or k in closed:
            continue
        then = _canonical(selected + [k])
        if then == now or then in seen:
            continue
        seen.add(then)
        out.append(k)
    return out


def _over_dispersion(fit: FitResult) -> float:
    st = fit.statistics
    return max(1.0, st.reduced_chi2) if st.scatter_known and st.dof > 0 else 1.0


def _candidate(state: FitResult, added: AddedEffect) -> Candidate:
    fit = added.result
    if fit is None:
        return Candidate(added.kind, "", added, float("-inf"), float("-inf"), added.error)
    gain = state.statistics.bic - fit.statistics.bic
    note = "; ".join(added.notes) if fit.finished else fit.message
    return Candidate(added.kind, note, added, gain, _scaled_gain(state, fit))


def _rematch_from_spec(
    peak_list: Measurements, state: FitResult, baseline: FitResult, at_noise_level: bool
) -> bool:
    """Whether the shear effects are refitted from the spec's values to the whole peak list
    (``afresh_from_spec``) when no candidate pays: on a peak list, far from the noise, in
    the first round (the candidates were judged on the thin-plate fit's peak matching)."""
    return not peak_list.ranked and not at_noise_level and state is baseline


def _afresh_from_spec(
    refitting: Refitting, trying: list[str], ordered: list[Candidate], pool, policy: SelectionPolicy, say
) -> tuple[Candidate | None, str]:
    """Of the shear effects among ``trying`` refitted from the spec's values with the peaks
    matched afresh (``afresh_from_spec``), those that pay over the state by their matching
    cost on every peak (``_rematched_candidate``), the best-paying first: the first one
    selectable, or implausible alone but plausible with the round's best other candidate
    refitted on top of it (``_plausible_with``: another missing effect distorts it alone).
    Otherwise None and, when one pays, a lead for the stop's reason."""
    kinds = [k for k in trying if effect(k).restarts_from_spec]
    if not kinds:
        return None, ""
    say(
        f"  no candidate pays on the thin-plate fit's peak matching: {', '.join(kinds)} from the spec's "
        "values, the peaks matched afresh"
    )
    jobs = [dict(refitting=refitting, kind=k, options=policy.candidate_options) for k in kinds]
    added = (
        list(pool.map(afresh_from_spec, jobs)) if pool is not None else [afresh_from_spec(j) for j in jobs]
    )
    baseline, peaks = refitting.baseline, refitting.measurements
    candidates = [_rematched_candidate(baseline, peaks, a) for a in added]
    for c in candidates:
        finished = c.fit is not None and c.fit.finished
        odd = "" if c.plausible else "; implausible: " + "; ".join(c.added.implausible)
        say(f"  {c.kind} afresh: " + (c.note + odd if finished else c.error))
    paying = sorted((c for c in candidates if c.scaled_gain > policy.min_gain), key=lambda c: -c.scaled_gain)
    if not paying:
        return None, ""
    other = next(
        (
            c
            for c in sorted(ordered, key=lambda c: -c.scaled_gain)
            if c.selectable and not effect(c.kind).restarts_from_spec and not effect(c.kind).refines
        ),
        None,
    )
    for lead in paying:  # the best-paying first; an implausible one, with the next effect on top
        if lead.selectable:
            return lead, ""
        if lead.plausible or other is None:
            continue  # singular at its solution: a second effect does not make it identifiable
        partnered = _plausible_with(refitting, lead, other, pool, policy, say)
        if partnered is not None:
            return partnered, ""
    lead = paying[0]
    why = "; ".join(lead.added.implausible) or "singular at its solution"
    return None, (
        f"; from the spec's values with the peaks matched afresh, {lead.kind} {lead.note}, but its "
        f"estimate is {'implausible' if not lead.plausible else 'not determined'} ({why})"
        + (f", also with {other.kind} on top of it" if other is not None and not lead.plausible else "")
        + ": the thin-plate fit's peak matching is likely wrong, and another effect missing beside it"
    )


def _plausible_with(
    refitting: Refitting, lead: Candidate, other: Candidate, pool, policy: SelectionPolicy, say
) -> Candidate | None:
    """``lead`` (an afresh refit, implausible alone) marked plausible with ``other``'s effect
    when that effect refitted on top of it makes every estimate plausible and the two pay
    together over the thin-plate fit (``_rematched_candidate``); None otherwise."""
    why = "; ".join(lead.added.implausible)
    say(f"  {lead.kind} afresh is implausible ({why}): {other.kind} refitted on top of it")
    on_top = add_effect(
        refitting.refit(lead.fit, policy.candidate_options, pool=pool), other.kind, refitting.hints(lead.fit)
    )
    pair = on_top.result
    if pair is None or not pair.finished:
        return None
    reasons = on_top.implausible + refitting.judged_implausible(lead.added.added, pair.specimen)
    both = _rematched_candidate(
        refitting.baseline, refitting.measurements, replace(on_top, added=lead.added.added + on_top.added)
    )
    say(
        f"  {lead.kind} + {other.kind} afresh: {both.note}"
        + (f"; implausible: {'; '.join(reasons)}" if reasons else "")
    )
    if reasons or not both.scaled_gain > policy.min_gain or both.singular:
        return None
    note = (
        f"{lead.note}; implausible alone ({why}), plausible with {other.kind} refitted on top "
        f"of it, which the next round tries (the two {both.note})"
    )
    alone = f"{lead.kind}: implausible estimate"
    notes = tuple(n for n in lead.added.notes if not n.startswith(alone)) + (
        f"{alone} alone ({why}), plausible with {other.kind} refitted on top of it",
    )
    return replace(lead, added=replace(lead.added, notes=notes), note=note, plausible_with=other.kind)


def _rematched_candidate(state: FitResult, peaks: Measurements, added: AddedEffect) -> Candidate:
    """A refit of the whole peak list (``afresh_from_spec``) as a candidate over ``state``:
    its gain is the fall of the matching cost over every peak at one tolerance (the smaller
    model error of the two; ``matching_cost``: a matched peak its squared error over the
    scatter widened by that tolerance, a left-out one ``GATE``^2) less ln n per parameter
    more, BIC's penalty.  With the residuals' own scale in each peak's sigma, the cost is
    chi^2 / c, so the gain stands where ``_scaled_gain`` does."""
    fit = added.result
    if fit is None or not fit.finished:
        why = added.error or (fit.message if fit is not None else "")
        return Candidate(added.kind, "", added, float("-inf"), float("-inf"), why)
    tolerance = min(model_error(state), model_error(fit))
    before, after = matching_cost(state, peaks, tolerance), matching_cost(fit, peaks, tolerance)
    gain = before - after - (fit.statistics.k - state.statistics.k) * math.log(len(peaks))
    note = (
        f"matches {len(fit.measurements)} of {len(peaks)} peaks at RMS {100 * fit.rms_rel_error:.3g} % "
        f"(the thin-plate fit {len(state.measurements)} at {100 * state.rms_rel_error:.3g} %): matching cost "
        f"{after:.4g} against {before:.4g} at {100 * tolerance:.2g} %, a gain of {gain:.1f}"
    )
    return Candidate(added.kind, note, added, gain, gain, matched_afresh=True)


def _scaled_gain(state: FitResult, fit: FitResult) -> float:
    """The BIC gain of ``fit`` over ``state`` with chi^2 divided by ``fit``'s over-dispersion
    c (the plain BIC gain without a stated scatter)."""
    now, then = state.statistics, fit.statistics
    if not then.scatter_known:
        return now.bic - then.bic
    return (now.sum_squares - then.sum_squares) / _over_dispersion(fit) - (then.k - now.k) * math.log(then.n)


def _workers(requested: int | None, tasks: int, baseline_seconds: float, policy: SelectionPolicy) -> int:
    """Worker processes for a round of ``tasks`` candidate refits (``diagnose``'s ``workers``)."""
    if requested is not None:
        return max(1, requested)
    if tasks < policy.parallel_from or baseline_seconds < policy.refits.parallel_from_s:
        return 1
    return max(1, min(2, os.cpu_count() or 1, tasks))


@dataclass(frozen=True)
class Round:
    """What a round's candidate refits share: their context (``refit``: the fit they add
    to, its data, the spec's specimen, the policy's candidate options), the point-mass
    start positions (``hints``), the worker processes (``pool``, ``n_workers`` refits at a
    time; None: all here) and the selection's ``policy``.  ``must_pay``: the state is at
    the noise level, so a candidate is refitted only where its linearised bound could pay
    for its parameters (``pay_floor``)."""

    refit: Refit
    hints: tuple
    pool: Executor | None = None
    n_workers: int = 1
    policy: SelectionPolicy = SELECTION_POLICY
    must_pay: bool = False

    @property
    def state(self) -> FitResult:
        return self.refit.state

    def pay_floor(self, prepared) -> PruneBelow:
        """The least reduction of the weighted sum of squares with which ``prepared`` pays
        for itself: its gain / c above ``min_gain`` after its parameters' k ln n, with c at
        its least, 1 (a lower bound in every round: c is never below 1).  Without a stated
        scatter the criterion is n ln(RSS / n): paying takes RSS down by the factor
        exp(-(min_gain + k ln n) / n), and the floor is that share of the state's RSS (it
        was compared in chi^2 units with relative residuals, so at the noise level of the
        assumed scatter every candidate was pruned)."""
        statistics, k = self.state.statistics, len(prepared.added)
        n = statistics.n
        least = self.policy.min_gain + k * math.log(n)
        if not statistics.scatter_known:
            least = -statistics.sum_squares * math.expm1(-least / n)
        where = " at the noise level" if self.must_pay else ""
        return PruneBelow(
            least,
            f"it must explain to pay for itself{where} (gain / c above "
            f"{self.policy.min_gain:g} after {k} ln {n} for its parameters)",
        )

    def job(self, prepared, below: float | None) -> dict:
        """The keyword arguments of the refit of one ``prepared`` candidate (``_add``;
        without the pool: it may run in a worker process); ``below``: the most another
        candidate explained so far (None: none paid yet), which prunes as
        ``RefitPolicy.prune_factor`` says, and at the noise level ``pay_floor`` too.  In
        every round the refit is abandoned once, from its first step on, it could no longer
        explain ``pay_floor`` by that rule (``add_effect``'s ``abandon_below``): a candidate
        that cannot pay is not refitted to the end (rounds where nothing paid refitted
        every candidate to its end: 386 s of the held-out half's 1,758 s, run 14)."""
        prune = None if below is None else PruneBelow(below)
        floor = self.pay_floor(prepared)
        if self.must_pay and (prune is None or prune.chi2 < floor.chi2):
            prune = floor
        return dict(
            refit=self.refit,
            kind=prepared.kind,
            hints=self.hints,
            prune_below=prune,
            abandon_below=floor,
            prepared=prepared,
        )

    def refitted_here(self, job: dict) -> AddedEffect:
        """``job``'s refit (``_add``) in this process; an effect with
        ``independent_starts`` refits its starts side by side in the pool (a point mass
        refitted again with the held shear moduli free ran its starts one after another
        while both workers waited: blind27, 68 s)."""
        if self.pool is not None and effect(job["kind"]).independent_starts:
            job = {**job, "refit": replace(self.refit, pool=self.pool)}
        return _add(job)


def _leader_freed_again(round_: Round, candidates: list[Candidate], held, say) -> list[Candidate]:
    """The round's leading candidate (the lowest criterion of those refitted, plausible
    or not) refitted again with the shear moduli ``held`` that ``state`` holds because they
    ran out while other physics was missing (``fitting.held_shear_moduli``) freed, where
    it frees none itself; the refit with the lower misfit kept.  Only the leader: freeing
    them in every candidate doubled a sandwich's time (blind03, 698 -> 1347 s, where the
    skins' G13/G23 ran out again in each), and the leader is where the freed moduli
    decide the answer (blind13: the point mass alone 12.6 g, 0.72 % RMS, implausible; with
    the plies' G13/G23 free, 4.2 g at the sensor, 0.074 %, consistent)."""
    state = round_.state
    fitted = [c for c in candidates if c.fit is not None and not c.added.shear_moduli]
    if not held or not fitted:
        return candidates
    leader = min(fitted, key=lambda c: c.bic)
    hints = _ends(leader) if effect(leader.kind).independent_starts else round_.hints
    prepared = round_.refit.prepare(leader.kind, hints, free_again=held)
    if isinstance(prepared, AddedEffect):
        again = _candidate(state, prepared)
    elif not prepared.frees_any(held):
        return candidates  # the data do not see them here (``choose_shear_moduli``): the refit would repeat
    else:
        say(f"  {leader.kind} again with G13, G23 of {', '.join(sorted({p.target for p in held}))} free")
        again = _candidate(state, round_.refitted_here({**round_.job(prepared, None), "hints": hints}))
    if again.fit is None or not again.fit.statistics.sum_squares < leader.fit.statistics.sum_squares:
        note = f"{leader.kind} refitted with the held G13, G23 free again: " + (
            again.error
            if again.fit is None
            else f"RMS {100 * again.rms_rel_error:.3g} %, not lower: kept without them"
        )
        return [
            replace(c, note="; ".join(filter(None, [c.note, note]))) if c is leader else c for c in candidates
        ]
    return [again if c is leader else c for c in candidates]


def _ends(leader: Candidate) -> tuple[dict, ...]:
    """Where the refits of ``leader`` (an effect with ``independent_starts``) ended: its
    solution and the other finished ones it kept (``AddedEffect.rivals``), as starts of its
    refit with the held shear moduli free.  That refit contains the leader at each of them
    (the moduli at their held values; ``free`` keeps a start 2 % inside the edges), so from
    there it can only descend; the leader's starts over the plate are not refitted from
    scratch again (blind27: 68 s alone)."""
    kind = effect(leader.kind)
    own = {
        p: leader.fit.value(p)
        for p in leader.added.added
        if isinstance(p, Parameter) and p.target == leader.kind
    }
    return tuple(kind.hint_at(values) for values in (own, *leader.added.rivals))


def _prepare(job: dict):
    """One candidate's pre-check, ``Refit.prepare`` (module level: runs in a worker process)."""
    return job["refit"].prepare(job["kind"], job["hints"], job["start"], job["free_again"])


def _add(job: dict):
    """One candidate's refit, ``Refit.add`` (module level: runs in a worker process)."""
    return job["refit"].add(
        job["kind"],
        job["hints"],
        prepared=job["prepared"],
        prune_below=job["prune_below"],
        abandon_below=job["abandon_below"],
    )


def _try(round_: Round, kinds: list[str], starts: dict | None = None, free_again=()) -> list[Candidate]:
    """The candidates ``kinds`` on top of ``state``: each pre-checked with one evaluation
    (side by side in the pool when there is one), then refitted most promising first (by
    the linearised bound), each only when it could come near what the best so far
    explained (``_refitted``).  ``starts``: kind -> a fit its refit starts from;
    ``free_again``: shear moduli ``state`` holds, freed again with effects that free none
    themselves (``fitting.held_shear_moduli``, ``_leader_freed_again``)."""
    state, pool = round_.state, round_.pool
    out, ready = [], []
    jobs = [
        dict(
            refit=round_.refit,
            kind=kind,
            hints=round_.hints,
            start=(starts or {}).get(kind),
            free_again=free_again,
        )
        for kind in kinds
    ]
    # The pre-checks are independent of each other: with a pool they run side by side (a
    # shear candidate's evaluates up to five starts, each a full solve of every configuration).
    for prepared in pool.map(_prepare, jobs) if pool is not None and len(jobs) > 1 else map(_prepare, jobs):
        if isinstance(prepared, AddedEffect):
            out.append(_candidate(state, prepared))
        else:
            ready.append(prepared)
    ready.sort(key=lambda r: -r.bound)
    return out + _refitted(round_, ready, out)


def _explained_best(round_: Round, candidates) -> float | None:
    """The most chi^2 one of ``candidates`` explained of those that may prune the others
    (None: none).  Only an answer may: an implausible estimate that explains much must not
    keep the right physics from being refitted, nor may one that does not pay for itself
    (blind02, held-out: a thickness refit at gain / c 2.2 pruned the orientation, whose
    linearised bound is second order in the angles)."""
    explained = [
        round_.state.statistics.sum_squares - c.fit.statistics.sum_squares
        for c in candidates
        if c.selectable and c.scaled_gain > round_.policy.min_gain
    ]
    return max(explained) if explained else None


def _refitted(round_: Round, ready: list, before: list[Candidate]) -> list[Candidate]:
    """The refits of the pre-checked candidates ``ready`` (most promising first), in
    batches of ``n_workers``: a refit is pruned (``RefitPolicy.prune_factor``) by what
    ``before`` and the earlier batches explained (``_explained_best``), never by its own
    batch, so the answer does not depend on which refit ends first.

    With a pool a refit starts as soon as a process is free, before the earlier batches
    have ended: a batch used to wait for its slowest (a long spruce plate's first round
    took 92 s, the shear refits 35-39 s beside others of 2-15 s).  Once the earlier
    batches have ended, a refit their answers prune gets the result it would have had,
    "not refitted" (its refit, if it is running, ends unread).  An effect with
    ``independent_starts`` (a point mass) is refitted here, its starts' refits in the pool
    beside one other refit: as one job it kept one process busy while the other waited
    (a long spruce plate's second round: 128 s beside a 15 s candidate)."""
    state, pool = round_.state, round_.pool
    factor = round_.refit.policy.prune_factor
    at_once = round_.n_workers if pool is not None else 1
    done: dict[int, Candidate] = {}

    def job(i: int) -> dict:
        """Refit ``i``'s job, pruned by what the earlier batches' ended refits explained."""
        earlier = [done[j] for j in range(i - i % at_once) if j in done]
        return round_.job(ready[i], _explained_best(round_, before + earlier))

    def pruned(job: dict) -> bool:
        return job["prune_below"] is not None and job["prune_below"].prunes(job["prepared"].bound, factor)

    if pool is None:
        for i in range(len(ready)):
            done[i] = _candidate(state, _add(job(i)))
        return [done[i] for i in range(len(ready))]
    apart = [effect(r.kind).independent_starts for r in ready]
    waiting = list(range(len(ready)))  # not started yet, in order
    running: dict = {}  # future -> refit index
    ended: dict[int, AddedEffect] = {}  # refits whose earlier batches have not all ended

    def settle() -> None:
        """Each refit whose earlier batches have all ended: pruned, or its ended result."""
        for i in range(len(ready)):
            if i in done or any(j not in done for j in range(i - i % at_once)):
                continue
            final = job(i)
            if pruned(final):
                done[i] = _candidate(state, _add(final))  # returns at once: not refitted
                for future in [f for f, j in running.items() if j == i]:
                    future.cancel()
                    del running[future]
            elif i in ended:
                done[i] = _candidate(state, ended.pop(i))

    def start() -> None:
        """Refits started while a process is free, skipping those pruned already."""
        while waiting and len(running) < at_once:
            i = waiting.pop(0)
            this = job(i)
            if i in done or pruned(this):
                continue  # a pruned one is settled once its earlier batches have ended
            if not apart[i]:
                running[pool.submit(_add, this)] = i
                continue
            while len(running) < at_once - 1:
                beside = next((j for j in waiting if not apart[j] and not pruned(job(j))), None)
                if beside is None:
                    break
                waiting.remove(beside)
                running[pool.submit(_add, job(beside))] = beside
            ended[i] = round_.refitted_here(this)
            return

    while len(done) < len(ready):
        settled = len(done)
        settle()
        start()
        if len(done) == settled and running:
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in finished:
                ended[running.pop(future)] = future.result()
    return [done[i] for i in range(len(ready))]


@one_blas_thread
def diagnose(
    model: SpecimenModel,
    measurements: Measurements,
    kinds: list[str] | None = None,
    progress: Callable[[str], None] | None = None,
    workers: int | None = 1,
    policy: SelectionPolicy = SELECTION_POLICY,
) -> Diagnosis:
    """Find the effects the model misses: a forward selection over ``kinds``.

    The baseline (layer properties fitted, no effect) is compared with refits that switch
    one more effect on, judged by the Bayesian information criterion (BIC = chi^2 + k ln n),
    until no effect pays for itself (at the noise level only the candidates that could are
    refitted); the module doc of
    ``identify.diagnosis.diagnose`` gives the rules, ``docs/diagnosis.md`` every threshold.
    A baseline already at the noise level stops there, with no effect refitted; a later
    state at the noise level goes on to a round that refits only the candidates whose
    linearised bound could pay for their parameters.

    Parameters
    ----------
    model : SpecimenModel
        The model (``fem.load_spec``).
    measurements : Measurements
        The measured frequencies (``load_measurements``).
    kinds : list of str, optional
        The effect kinds to try; default (None): every registered effect.
    progress : callable, optional
        Called with a line of text as the selection goes (each round's candidates).
    workers : int or None, default 1
        Processes for the candidate refits: 1, all here; None, 2 when a round has several
        and the fit is not trivial, as the command line does.  Workers are spawned and
        import the main module: a script that asks for them needs the
        ``if __name__ == "__main__":`` guard.
    policy : SelectionPolicy, default SELECTION_POLICY
        The numbers of the selection and of its refits (docs/diagnosis.md).

    Returns
    -------
    Diagnosis
        The baseline and its residual patterns, the selection's steps, the first round's
        ranking and the final refit with the selected effects (None when none).

    Raises
    ------
    SpecError
        A kind is not a registered effect (before any work).

    Examples
    --------
    >>> import identify
    >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
    >>> model = identify.load_spec(COATED_PLATE)
    >>> diagnosis = identify.diagnose(model, identify.load_measurements(COATED_PLATE_MEASURED, model))
    >>> diagnosis.selected, diagnosis.explained  # the baseline fits at the noise level
    ((), True)
    """
    kinds = list(kinds) if kinds is not None else list(REGISTRY)
    for kind in kinds:
        effect(kind)  # unknown kinds fail before any work
    started = time.perf_counter()
    say = progress or (lambda text: None)
    comparison = compare(model, measurements)
    baseline = comparison.fitted
    baseline_seconds = time.perf_counter() - started
    if comparison.at_noise_level:
        # The spec's own model fits: no round, not even the pre-checks that would prune
        # every candidate (the bundled example: 0.75 s -> 4.7 s, the shear models' meshes).
        say("the baseline fits at the noise level: no effect refitted")
        return Diagnosis(baseline, comparison, (), (), None, time.perf_counter() - started, policy=policy)
    peak_list = measurements
    refitting = Refitting.from_baseline(model, peak_list, baseline, policy.refits)
    state, selected, steps, closed = baseline, [], [], set()
    # refinement -> (round, chi^2 it explained beyond, of what)
    margins: dict[str, tuple[int, float, str]] = {}
    pool = None
    try:
        for number in range(1, len(kinds) + 1):
            round_started = time.perf_counter()
            trying = _eligible_kinds(kinds, [c.kind for c in selected], closed)
            if not trying:
                steps.append(
                    Step(
                        number,
                        tuple(c.kind for c in selected),
                        state,
                        (),
                        None,
                        "stop: no candidate left to try",
                    )
                )
                break
            hints = refitting.hints(state, comparison)
            n_workers = _workers(workers, len(trying), baseline_seconds, policy)
            if n_workers > 1 and pool is None:
                pool = worker_pool(n_workers)

            # At the noise level the chi^2 test no longer rejects the model, but an effect
            # may still pay for itself (a sensor on a sandwich at 1.18 x the scatter, the
            # layers 5.7 std off without it: docs/diagnosis.md): the round refits only the
            # candidates whose bound could pay.  (Not the baseline's: that returned above.)
            at_noise_level = state.statistics.consistent
            # the candidates' data: a peak list's peaks as the state matched them
            this_round = Round(
                refitting.refit(state, policy.candidate_options),
                hints,
                pool,
                n_workers,
                policy,
                must_pay=at_noise_level,
            )

            def run(batch, starts=None):  # called in this round only: the loop variables are this round's
                in_processes = f" in {n_workers} processes" if pool else ""  # noqa: B023
                say(f"round {number}: trying {', '.join(batch)}{in_processes}")  # noqa: B023
                return _try(this_round, batch, starts)  # noqa: B023

            names = [c.kind for c in selected]
            candidates = run([k for k in trying if not effect(k).refines])
            held_by_state = refitting.held_shear(state, [c.added for c in selected])
            candidates = _leader_freed_again(this_round, candidates, held_by_state, say)
            restart = refitting.restarted(trying, state)
            if restart:
                # The thin-plate fit ran to its bounds: the shear candidates from the spec's values too.
                again = {c.kind: c for c in run(restart, {k: refitting.respec for k in restart})}
                candidates = [
                    _candidate(state, c.added.or_from_spec(again[c.kind].added)) if c.kind in again else c
                    for c in candidates
                ]
            refining = [
                k for k in trying if effect(k).refines and _refine(k, kinds, names, candidates, state, policy)
            ]
            skipped = [k for k in trying if effect(k).refines and k not in refining]
            held = _held_back(refining, margins, state, candidates, refitting.policy.prune_factor)
            refining = [k for k in refining if k not in held]
            if refining:
                # A refinement starts where the best of what it refines ended (the layerwise
                # model's solves cost 6-18 of the single layer's: few iterations from there).
                candidates += run(refining, {k: _refined_start(k, candidates, state) for k in refining})
                margins.update(_margins(refining, candidates, number))
            candidates = _continue_unfinished(this_round, candidates, say)
            closed |= {c.kind for c in candidates if c.fit is None and not c.added.pruned}
            above = tuple(c.kind for c in candidates if c.ended_above(this_round.refit.state))
            finished = [c for c in candidates if c.eligible]
            c_hat = _over_dispersion(min(finished, key=lambda c: c.bic).fit) if finished else 1.0
            ordered = plausible_first(
                [c for c in candidates if c.fit is not None],
                c_hat,
                policy.plausibility_margin,
                key=lambda c: c.bic,
                judged=lambda c: c.plausible,
                related=lambda a, b: _nested(a.kind, b.kind, names),  # noqa: B023 (used now)
            )
            ordered += [c for c in candidates if c.fit is None]
            best = next((c for c in ordered if c.selectable), None)
            plausible_best = best
            best = _more_complete(best, ordered, names, c_hat, policy.complete_margin)
            if best is not plausible_best:
                ordered = [best] + [c for c in ordered if c is not best]
            for c in candidates:
                say(
                    f"  {c.kind}: "
                    + (f"RMS {100 * c.rms_rel_error:.4f} %, BIC gain {c.gain:.1f}" if c.fit else c.error)
                    + f" ({c.added.seconds:.1f} s)"
                )
            before = tuple(c.kind for c in selected)
            afresh, rematched_lead = None, ""
            if (best is None or not best.scaled_gain > policy.min_gain) and _rematch_from_spec(
                peak_list, state, baseline, at_noise_level
            ):
                afresh, rematched_lead = _afresh_from_spec(refitting, trying, ordered, pool, policy, say)
                if afresh is not None:
                    best = afresh
                    ordered = [afresh] + [c for c in ordered if c.kind != afresh.kind]
            if best is None or not best.scaled_gain > policy.min_gain:
                if best is not None:
                    reason = (
                        f"the best, {best.kind}, does not pay for itself "
                        f"(gain / c = {best.scaled_gain:.1f} <= {policy.min_gain:g})"
                    )
                elif at_noise_level:
                    reason = "no candidate could pay for itself (each one's linearised bound is short)"
                else:
                    reason = "no plausible, identifiable candidate could be refitted"
                reason = (
                    "stop: the misfit is at the noise level, and " if at_noise_level else "stop: "
                ) + reason
                reason += _signs(ordered, best, policy) + rematched_lead + "".join(held.values())
                steps.append(
                    Step(
                        number,
                        before,
                        state,
                        tuple(ordered),
                        None,
                        reason,
                        tuple(skipped),
                        time.perf_counter() - round_started,
                        above,
                    )
                )
                break
            reason = f"add {best.kind} (gain / c = {best.scaled_gain:.1f})"
            lowest = min((c for c in ordered if c.eligible), key=lambda c: c.bic)
            if best is afresh:
                reason = (
                    f"add {best.kind}, refitted from the spec's values with the peaks matched afresh: "
                    f"{best.note}"
                )
            elif best is not plausible_best:
                reason += (
                    f"; preferred to {plausible_best.kind}: the same free parameters and physics a real "
                    "plate "
                    f"has besides, and {plausible_best.kind}'s criterion is only "
                    f"{(best.bic - plausible_best.bic) / c_hat:.1f} (/ c) lower, within "
                    f"{policy.complete_margin:g}"
                )
            elif lowest is not best:
                reason += (
                    f"; preferred to {lowest.kind}, whose criterion is {best.bic - lowest.bic:.1f} lower but "
                    "whose estimate is implausible or singular"
                )
            reason += _signs(ordered, best, policy) + "".join(held.values())
            # The chosen refit is taken to convergence (the candidates stopped once their misfit
            # settled) before the next round looks again.
            # On a peak list the peaks are matched again here, from the state's matching: the
            # next round's candidates are judged on the new state's matched peaks.
            rematch = not peak_list.ranked
            polished = (
                refitting.polished_afresh(best.fit, policy.final_options)
                if best is afresh
                else refitting.polished(best.fit, state, policy.final_options, pool)
            )
            polished, notes = refitting.with_determined_shear(polished, policy.final_options)
            # The layer properties the thin-plate fit held are freed where the effect now
            # determines them, before the next round: held, their handbook error is misfit
            # that the next round's candidates would take up.  Not on a peak list: there a
            # property freed while an effect is still missing takes up its misfit and the
            # matching follows it, so they stay held until the final refit (the measured
            # case is in docs/diagnosis.md, "Peak lists").
            if not rematch:
                polished = refitting.released(polished, policy.final_options, settle=Settle.QUICK)
            if rematch or (
                polished.finished
                and (notes or polished.statistics.sum_squares <= best.fit.statistics.sum_squares)
            ):
                added = replace(
                    best.added,
                    result=polished,
                    notes=best.added.notes + tuple(notes),
                    added=tuple(p for p in polished.parameters if p not in state.parameters),
                )
                # Re-matched, the misfit is over other peaks than the state's: the gain stays
                # the one the candidate won on the state's.
                best = replace(best, added=added) if rematch else _candidate(state, added)
                ordered = [best if c.kind == best.kind else c for c in ordered]
            steps.append(
                Step(
                    number,
                    before,
                    state,
                    tuple(ordered),
                    best,
                    reason,
                    tuple(skipped),
                    time.perf_counter() - round_started,
                    above,
                )
            )
            selected.append(best)
            state = best.fit
    finally:
        if pool is not None:
            pool.shutdown()
    completion_started = time.perf_counter()
    matched = state  # the last state a peak list was matched to (the completion is refitted on its matching)
    completion = _completed(refitting, state, selected, kinds, say, policy) if selected else None
    if completion is not None:
        before = tuple(c.kind for c in selected)
        completed = " + ".join(sorted(set(before) & set(effect(completion.kind).completes)))
        reason = (
            f"add {completion.kind} in place of the single shear layer (gain / c = "
            f"{completion.scaled_gain:.1f}): the more complete theory, refitted from the selection's end"
            if effect(completion.kind).replaces
            else f"add {completion.kind} beside {completed} (gain / c = {completion.scaled_gain:.1f}): "
            "the physics every real plate has besides, with no parameter more, and the misfit falls"
        )
        steps.append(
            Step(
                len(steps) + 1,
                before,
                state,
                (completion,),
                completion,
                reason,
                seconds=time.perf_counter() - completion_started,
            )
        )
        selected.append(completion)
        state = completion.fit
    final = _final(refitting, state, selected, say, policy, like=matched) if selected else None
    taken_out = ()
    determined = _determined_final(refitting, final, steps, selected, say, policy)
    if determined is not None:
        final, step, taken_out = determined
        steps.append(step)
    first = steps[0].candidates if steps else ()
    # The answer's std with the selected theory's own error; every decision above read the
    # measurements' scatter alone.
    final = with_theory_accuracy(final) if final is not None else None
    return Diagnosis(
        baseline,
        comparison,
        tuple(first),
        tuple(steps),
        final,
        time.perf_counter() - started,
        taken_out,
        policy,
    )


def _determined_final(
    refitting: Refitting,
    final: FitResult | None,
    steps: list[Step],
    selected: list[Candidate],
    say,
    policy: SelectionPolicy,
) -> tuple[FitResult, Step, tuple[str, ...]] | None:
    """When the final refit does not determine the last selected effect, that effect is
    taken out and the selection before it refitted in full; kept (the new final and a step
    that says why) when that refit is determined.  Not determined: the refit fits the
    frequencies but its sensitivity matrix is singular (``not_identifiable``: no parameter
    has a std), or the effect's ``amount`` (a sensor's mass) has a std at least its value
    (as reported: with the known inputs' tolerances), so the data cannot tell it from its
    absence: the misfit it removes is model error that an effect of that size imitates, not
    a sign of the effect.  A candidate's own tests (gain, plausibility, its conditioning
    against its start's) see neither: they are taken before the final refit frees every
    parameter together.  Only with two effects or more selected: without the one, the
    baseline would be the answer and its misfit is what was to be explained.

    An undetermined amount is kept, with a step that says so, when the final refit is
    identifiable, the refit without the effect is not consistent with the scatter and the
    theory's own error together (``_within_theory_and_scatter``) and the effect pays for
    itself over it (gain / c above ``min_gain``): the data then need an effect of that
    kind, only its amount is uncertain with the known inputs' tolerances (blind81: a
    2.02 g sensor fitted as 3.43 +- 4.5 g, the misfit 0.216 % without it and 0.083 % with
    it; taken out, a skin's E1 ended 3.54 std off).  blind22's phantom 0.82 g mass is
    still taken out: without it the layerwise refit's 0.0329 % is within 0.020 % scatter
    and the theory's 0.049 %.  Returns (the final refit, the step, the effects taken out)."""
    if final is None or len(selected) < 2:
        return None
    last = selected[-1]
    vague = _undetermined_amount(final, last.kind)
    if final.status is not FitStatus.NOT_IDENTIFIABLE and not vague:
        return None
    before = next(s for s in reversed(steps) if s.chosen is last)
    why = (
        "is not identifiable"
        if not vague
        else f"does not determine {last.kind}'s {', '.join(p.name for p in vague)}"
    )
    say(f"the refit with {' + '.join(c.kind for c in selected)} {why}: refitting without {last.kind}")
    again = _final(refitting, before.start, selected[:-1], say, policy)
    if again.status is FitStatus.NOT_IDENTIFIABLE or again.uncertainty.verdict == Verdict.SINGULAR:
        return None
    if vague:
        undetermined = "; ".join(
            f"{p.name} {display(p, v):.3g} +- {display(p, sd):.2g}"
            for p, v, sd in zip(final.parameters, final.values, final.uncertainty.std)
            if p in vague
        )
        needed = _scaled_gain(again, final)
        if (
            final.status is not FitStatus.NOT_IDENTIFIABLE
            and not _within_theory_and_scatter(again)
            and needed > policy.min_gain
        ):
            reason = (
                f"keep {last.kind}: the refit with it does not determine its amount ({undetermined}, "
                "with the known inputs' tolerances), but without it the refit is not consistent with the "
                f"scatter and the theory's own error (RMS {100 * again.rms_rel_error:.3g} %) and {last.kind} "
                f"pays over it (gain / c = {needed:.1f}, RMS {100 * final.rms_rel_error:.3g} %): the data "
                "need an effect of this kind; its amount is uncertain"
            )
            say(reason)
            return (
                final,
                Step(len(steps) + 1, tuple(c.kind for c in selected), final, (last,), None, reason),
                (),
            )
        unknown = f"does not determine its amount ({undetermined}: the data cannot tell it from none)"
    else:
        unknown = (
            f"does not determine its parameters (condition number {final.uncertainty.condition_number:.3g})"
        )
    reason = (
        f"drop {last.kind}: the refit with it fits the frequencies (RMS {100 * final.rms_rel_error:.3g} %) "
        f"but {unknown}; without it the refit's parameters are determined (RMS "
        f"{100 * again.rms_rel_error:.3g} %, {again.status.value}): an effect the data cannot tell from "
        "the layers is not an answer"
    )
    return (
        again,
        Step(len(steps) + 1, tuple(c.kind for c in selected), final, (last,), None, reason),
        (last.kind,),
    )


def _within_theory_and_scatter(fit: FitResult) -> bool:
    """The misfit consistent, by the chi^2 test at ``CHI2_TEST_LEVEL``, with the scatter and
    the theory's own error together (``ModelOptions.theory_std_rel``: 0.049 % a frequency
    for a shear-deformable theory against 3-D elasticity, 0 for the thin plate): what a
    model without an effect may miss without the data asking for the effect.  Without a
    stated scatter, the fit's own test."""
    st = fit.statistics
    if not st.scatter_known or st.dof <= 0:
        return fit.converged
    table = fit.measurements.table
    measured, std = table["frequency_hz"].to_numpy(), table["std_hz"].to_numpy()
    variance = std**2 + (fit.model.options.theory_std_rel * measured) ** 2
    chi2 = float(np.sum((fit.model_hz - measured) ** 2 / variance))
    return float(stats.chi2.sf(chi2, st.dof)) >= CHI2_TEST_LEVEL


def _undetermined_amount(fit: FitResult, kind: str) -> tuple[Parameter, ...]:
    """The parameters of effect ``kind`` that measure its amount (``Effect.amount``),
    when ``fit`` determines none of them; else empty."""
    amount = effect(kind).amount
    own = [
        (p, vague)
        for p, vague in zip(fit.parameters, fit.uncertainty.undetermined, strict=True)
        if fit.effect_of.get(p) == kind and p.kind in amount
    ]
    return tuple(p for p, _ in own) if own and all(vague for _, vague in own) else ()


def _continue_unfinished(round_: Round, candidates: list[Candidate], say) -> list[Candidate]:
    """Candidates where one that stopped at the iteration limit with a lower criterion than
    every finished one (its misfit still falling) is continued, each at most once."""
    candidates = list(candidates)
    for _ in range(len(candidates)):
        ranked = sorted((c for c in candidates if c.fit is not None), key=lambda c: c.bic)
        if not ranked or ranked[0].fit.status is not FitStatus.NOT_CONVERGED:
            break
        c = ranked[0]
        policy = round_.policy
        say(f"  continuing {c.kind} (not converged in {policy.candidate_iterations} iterations)")
        options = replace(policy.candidate_options, max_iterations=policy.final_options.max_iterations)
        fit = round_.refit.continued(c.fit, options)
        extended = _candidate(round_.state, replace(c.added, result=fit))
        candidates[candidates.index(c)] = extended
        if not extended.eligible:
            break
    return candidates


def _completed(
    refitting: Refitting, state: FitResult, selected, kinds, say, policy: SelectionPolicy
) -> Candidate | None:
    """The more complete physics from the selection's end: each effect that ``completes`` a
    selected one (``Effect.completes``), a fuller theory in its place first
    (``Effect.replaces``), then what joins it; the first kept is returned.

    A fuller theory (the layerwise model in place of a single shear layer) is kept when its
    criterion is lower at all (gain / c above 0, any extra shear moduli paid for: it is the
    same effect's more complete theory, not a new effect that must bring ``min_gain``) or,
    with no more free parameters, within ``complete_margin`` x c of the state's; what joins
    (rotary inertia beside transverse shear, no parameter more) when the misfit falls.
    Not tried where an effect selected already covers its physics, where no candidate
    kind has it, or where it ``adds_nothing`` to the state's model.  Why these exist and
    the cases behind them: docs/diagnosis.md."""
    names = {c.kind for c in selected}
    order = sorted((k for k in REGISTRY if effect(k).completes), key=lambda k: not effect(k).replaces)
    for kind in order:
        completing = effect(kind)
        completed = sorted(names & set(completing.completes))
        offered = kind in kinds or any(kind in effect(k).physics and not effect(k).refines for k in kinds)
        if (
            not completed
            or not offered
            or completing.adds_nothing(state.model)
            or any(completing.physics <= effect(n).physics for n in names)
        ):
            continue
        why = (
            "in place of {} (the more complete theory, from the selection's end)"
            if completing.replaces
            else "beside {} (the more complete physics)"
        )
        say(f"trying {kind} " + why.format(" + ".join(completed)))
        candidate = _candidate(state, refitting.refit(state, policy.candidate_options).add(kind))
        if candidate.fit is None or not candidate.selectable:
            continue
        if not completing.replaces:
            if candidate.gain > 0:
                return candidate
            continue
        c_hat = _over_dispersion(min(candidate.fit, state, key=lambda f: f.statistics.bic))
        fuller = (
            candidate.fit.statistics.k <= state.statistics.k
            and candidate.fit.statistics.bic - state.statistics.bic < policy.complete_margin * c_hat
        )
        if candidate.scaled_gain > 0 or fuller:
            return candidate
    return None


def _final(
    refitting: Refitting,
    state: FitResult,
    selected,
    say,
    policy: SelectionPolicy,
    like: FitResult | None = None,
) -> FitResult:
    """The selection refitted in full: iterations to convergence (a peak list matched
    again from ``like``'s matching, default ``state``'s), the layer properties the
    thin-plate fit held freed again where the data now determine them (``released``), and
    the whole pairing check once, at that answer; its status is its own (converged only
    when consistent with the scatter)."""
    say(f"refitting with {' + '.join(c.kind for c in selected)} (pairing checked in full)")
    result = refitting.continued(state, policy.final_options, Settle.QUICK, like=like)
    notes = tuple((c.kind, text) for c in selected for text in c.added.notes)
    # An effect refitted from several starts may have had rival solutions that fitted
    # about as well in its round: with the effects selected after it one of them may fit
    # better (blind145: a sensor at the x-mirror of its place fitted best before the
    # plies' turn was added, its true mirror image after; 0.117 % against 0.047 %).
    for c in selected if refitting.measurements.ranked else ():
        for values in c.added.rivals:
            other = refitting.continued(
                replace(state, model=state.model.with_values(values), pairings=None),
                policy.final_options,
                Settle.QUICK,
            )
            described = ", ".join(f"{p.kind} {display(p, v):.4g}" for p, v in values.items())
            if other.finished and other.statistics.sum_squares < result.statistics.sum_squares:
                say(f"  {c.kind} from its rival ({described}): {100 * other.rms_rel_error:.4f} %, kept")
                notes += (
                    (
                        c.kind,
                        f"{c.kind}: refitted with the whole selection from its rival solution ({described}), "
                        "it fits better than from the one its round chose: kept",
                    ),
                )
                result = other
    result = refitting.explained(refitting.released(result, policy.final_options))
    return replace(
        result,
        warnings=tuple(dict.fromkeys(result.warnings + tuple(text for _, text in notes))),
        effect_notes=notes,
        baseline=refitting.baseline,
    )


__all__ = ["Candidate", "Diagnosis", "SelectionPolicy", "SELECTION_POLICY", "Step", "diagnose"]
