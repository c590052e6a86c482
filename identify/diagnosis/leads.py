"""Where to look when a diagnosis ends with the misfit far from the noise and nothing
left pays for itself: what the last round's refits say, as leads with a code each.

A refit with k more free parameters lowers chi^2 by about k x c even where its effect is
absent (c = max(1, reduced chi^2), the over-dispersion the refit leaves: each free
parameter takes up about one unit of a chi^2 inflated by model error c times; without a
stated scatter, c is the residual variance).  A
candidate that lowered it by more explains part of the misfit, however little it gains
after the criterion's penalty; two such candidates may be needed together, or trade off
on the modes measured.  An implausible or singular estimate that explains more is a sign
of what is missing (``Effect.sign``); a refit that ended above the fit it contains failed
(at the limit where its effect vanishes it is that fit).  Decisions never read
these texts: programs read ``Lead.code``.
"""

from __future__ import annotations

from dataclasses import dataclass

from fem.effects import effect

#: Lead codes, for programs (``--json``): a failed refit, an implausible or singular
#: estimate that explains more than any selectable one, candidates that explain part of
#: the misfit, and the plate outside the candidate models (always the last lead).
FAILED_REFIT, IMPLAUSIBLE, PARTIAL, OUTSIDE = "failed_refit", "implausible", "partial", "outside_models"


@dataclass(frozen=True)
class Lead:
    """One place to look: ``code`` (one of the module's codes) and the sentence shown."""

    code: str
    text: str

    def to_dict(self) -> dict:
        return {"code": self.code, "text": self.text}


def explained(candidate, state) -> tuple[float, float]:
    """The share of ``state``'s chi^2 that ``candidate``'s refit explains, and that drop in
    units of chance (the drop / (k c), k its added free parameters, c the over-dispersion
    its refit leaves: about 1 where its effect is absent)."""
    before, after = state.statistics, candidate.fit.statistics
    drop = before.sum_squares - after.sum_squares
    added = max(1, after.k - before.k)
    # One scatter unit, or the residual variance where the misfit is larger (without a
    # stated scatter the two are the same).
    unit = max(after.chi2_unit, after.reduced_chi2)
    return drop / before.sum_squares, drop / (added * unit)


def leads(step) -> tuple[Lead, ...]:
    """The leads of the selection round ``step`` (the one where nothing more paid; its
    ``above_start``: the refits that ended above the fit they contain,
    ``AddedEffect.ended_above``)."""
    out = []
    state = step.start
    if step.above_start:
        out.append(
            Lead(
                FAILED_REFIT,
                f"{', '.join(step.above_start)}: the refit ended above the fit it contains (where its "
                "effect vanishes the refit is that fit), so the refit failed (a start that did not "
                "descend) and says nothing against the effect: please report it with the data",
            )
        )
    fitted = [(c, *explained(c, state)) for c in step.candidates if c.eligible]
    partial = [(c, share, chance) for c, share, chance in fitted if c.selectable and chance > 1.0]
    partial.sort(key=lambda t: -t[1])
    best = max((share for _, share, _ in partial), default=0.0)
    for c, share, _ in sorted(fitted, key=lambda t: -t[1]):
        if not c.selectable and share > best and share > 0:
            why = "; ".join(c.added.implausible) if not c.plausible else "singular at its solution"
            out.append(
                Lead(
                    IMPLAUSIBLE,
                    f"{c.kind} explains {100 * share:.0f} % of the misfit, but its estimate is not an "
                    f"answer ({why}): {effect(c.kind).sign}",
                )
            )
    if len(partial) >= 2:
        (a, share_a, _), (b, share_b, _) = partial[:2]
        out.append(
            Lead(
                PARTIAL,
                f"{a.kind} ({100 * share_a:.0f} % of the misfit) and {b.kind} ({100 * share_b:.0f} %) "
                "each explain more than their parameters would by chance, and neither pays alone: try "
                f"them together (fit --effect {a.kind} --effect {b.kind}) and judge the estimates; where "
                "both move the same modes they trade off, and a second configuration or measured mode "
                "shapes separate them",
            )
        )
    elif partial:
        c, share, chance = partial[0]
        out.append(
            Lead(
                PARTIAL,
                f"{c.kind} explains {100 * share:.0f} % of the misfit ({chance:.1f}x what its parameters "
                "would by chance), too little to pay for them: the rest is physics no candidate holds, "
                "or an effect that trades off against it on these modes (a second configuration or "
                "measured mode shapes separate them)",
            )
        )
    out.append(
        Lead(
            OUTSIDE,
            "or the plate is outside the candidate models: check the pairing (label the modes with the "
            "largest residuals), the spec (sizes, density, layer order) and the specimen (a "
            "delamination, a bond that is not continuous, a layer that does not act as a plate layer)",
        )
    )
    return tuple(out)


__all__ = ["FAILED_REFIT", "IMPLAUSIBLE", "OUTSIDE", "PARTIAL", "Lead", "explained", "leads"]
