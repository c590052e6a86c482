"""The diagnosis (``identify.diagnosis.diagnose.Diagnosis``) as text and as the notebook
view, from what it is handed: the verdict, every round's candidates, the refit with the
selection and the comparison's own report and tables."""

from __future__ import annotations

import math

import pandas as pd

from fem.effects import effect
from fem.numbers import finite_or_none

from ..engine.ambiguity import images_note
from . import html_report as h
from .report import parameter_lines
from .rounding import percent, status_line


def diagnosis_view(diagnosis) -> str:
    """The notebook view: the verdict, every round's candidates and the comparison's
    tables, drawn by the HTML report's code."""
    rounds = [
        (
            f"Round {s.number}: from {' + '.join(s.selected_before) or 'the baseline'}",
            h.table(
                pd.DataFrame(
                    [
                        {
                            "effect": c.kind,
                            "RMS after [%]": 100 * c.rms_rel_error if c.fit else None,
                            "BIC gain": finite_or_none(c.gain),
                            "status": c.status,
                            "parameters": ", ".join(f"{k} = {v:.4g}" for k, v in c.effect_values().items()),
                            "note": " ".join(x for x in (c.note, c.error) if x),
                        }
                        for c in s.candidates
                    ]
                ),
                "{:.4g}",
            )
            + h.paragraph(f"-> {s.reason}"),
        )
        for s in diagnosis.steps
    ]
    good = diagnosis.explained
    leads = [("Where to look", "".join(h.paragraph(lead.text) for lead in diagnosis.leads))]
    return h.view(
        "Diagnosis",
        ("explained" if good else "not explained", diagnosis.verdict, good),
        (leads if diagnosis.leads else []) + rounds + diagnosis.comparison.sections(),
    )


def diagnosis_text(diagnosis) -> str:
    """The diagnosis as text: the verdict, every round's candidates with their gain, status
    and parameters, the refit with the selection, then the comparison's report."""
    base = diagnosis.baseline.statistics
    lines = [
        "== diagnosis ==",
        "",
        diagnosis.verdict,
        "",
        f"baseline: RMS relative error {100 * diagnosis.baseline.rms_rel_error:.4f} %, "
        f"reduced chi^2 {base.reduced_chi2:.3g}",
    ]
    if diagnosis.leads:
        lines += ["", "where to look"] + [f"  - {lead.text}" for lead in diagnosis.leads]
    if diagnosis.at_noise_level:
        lines += [
            "no effect was refitted: the residual patterns below (a score test) show what each would explain"
        ]
    for step in diagnosis.steps:
        start = " + ".join(step.selected_before) or "the baseline"
        took = f", {step.seconds:.0f} s" if math.isfinite(step.seconds) else ""
        lines += [
            "",
            f"round {step.number}: from {start} (RMS {100 * step.start.rms_rel_error:.4f} %{took})",
            f"  {'effect':17s} {'RMS after %':>11s} {'BIC gain':>9s} {'gain / c':>9s} {'refit s':>7s}  "
            "status / parameters",
        ]
        for c in step.candidates:
            values = ", ".join(f"{k} = {v:.4g}" for k, v in c.effect_values().items())
            gain = f"{c.gain:9.1f} {c.scaled_gain:9.1f}" if math.isfinite(c.gain) else f"{'-':>9s} {'-':>9s}"
            status = c.status if c.fit else c.status.replace("_", " ")
            mark = "" if c.plausible else "  IMPLAUSIBLE: " + "; ".join(c.added.implausible)
            if c.plausible_with:
                mark += f" (plausible with {c.plausible_with} on top)"
            if c.matched_afresh:
                mark += (
                    "  [from the spec's values, the peaks matched afresh: the gains are the matching cost's]"
                )
            lines.append(
                f"  {c.kind:17s} {100 * c.rms_rel_error:11.4f} {gain} {c.added.seconds:7.0f}  {status}  "
                f"{values}{mark}".rstrip()
            )
            if not c.fit:
                lines.append(f"  {'':17s} {c.error}")
        if step.skipped:
            refined = {r for k in step.skipped for r in effect(k).refines}
            lines.append(
                f"  not tried: {', '.join(step.skipped)} (refines {' or '.join(sorted(refined))}, "
                "which did not pay)"
            )
        lines.append(f"  -> {step.reason}")
    if diagnosis.final is not None:
        lines += [""] + refit_lines(diagnosis.final, [c.kind for c in diagnosis.selected])
    if diagnosis.above_start:
        lines += [
            "",
            "refits that ended above the fit they were added to (where its effect vanishes each is "
            "that fit, so the refit failed: a start, or on a peak list a matching made for the fit "
            f"without the effect): {', '.join(diagnosis.above_start)}",
        ]
    if math.isfinite(diagnosis.seconds):
        lines += ["", f"({diagnosis.seconds:.1f} s)"]
    return "\n".join(lines) + "\n\n" + diagnosis.comparison.report()


def refit_lines(final, kinds: list[str]) -> list[str]:
    """The summary of the refit with the selected effects ``kinds``: how it ended, its
    parameters +- std, what was decided of each effect, and the plate's images it cannot
    tell from its answer (``FitResult.images``)."""
    chain = " ".join(f"--effect {kind}" for kind in kinds)
    lines = [
        f"refit with {' + '.join(kinds)}: the layers identified with the effects the data ask for (the "
        f"model of `fit {chain}`, refitted from the diagnosis's end; with --report its full report is "
        "refit.txt)",
        f"  {status_line(final.status.value, final.message)}",
        f"  RMS relative error {percent(final.rms_rel_error, 3)}",
    ]
    lines += parameter_lines(final, 40)
    notes = [text for _, text in final.effect_notes]
    if final.images:
        notes.append(images_note(final.parameters, final.values, final.images))
    return lines + [f"  - {text}" for text in notes]


__all__ = ["diagnosis_text", "diagnosis_view", "refit_lines"]
