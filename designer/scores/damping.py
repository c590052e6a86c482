"""How well a test set identifies the layers' loss factors.

The loss-factor columns d eta_i / d eta_p = d ln(lambda_i) / d ln(p) (``fem.solver.damping``) of
every mode of every configuration, close modes combined as the identification combines
them (``fem.solver.damping.close_groups``), are scored like the stiffness columns: their
condition number with the paper's verdict, and the predicted std of each loss factor for
a damping ratio scatter of ``damping_std_rel`` (``[design] damping_std_rel``, default 3 %)
at the nominal loss factors: the spec's values of the identified ones, else
``NOMINAL_LOSS``.  A design good for stiffness may be useless for damping (a loss factor
whose predicted std exceeds its nominal value): the verdict says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fem.laminates.material import LOSS_FACTORS
from fem.model import SpecimenModel
from fem.numbers import finite_or_none
from fem.solver.damping import close_groups, first_order_loss_factors, loss_columns
from fem.solver.sensitivity import Verdict, condition_verdict

#: Loss factor assumed for an identified material the spec gives none for (a polymer
#: coating's order; only the predicted std scales with it).
NOMINAL_LOSS = 0.01


@dataclass(frozen=True)
class DampingScores:
    """targets: (material, damping parameter); nominal loss factors and their predicted std
    [-]; condition number of the loss-factor columns and its verdict; the damping ratio
    scatter assumed [relative]."""

    targets: tuple[tuple[str, str], ...]
    nominal: np.ndarray
    predicted_std: np.ndarray
    condition_number: float
    verdict: Verdict
    damping_std_rel: float

    @property
    def names(self) -> list[str]:
        return [f"{m}.{k}" for m, k in self.targets]

    @property
    def useless(self) -> list[str]:
        """The loss factors this design cannot determine (predicted std above the value)."""
        return [n for n, v, s in zip(self.names, self.nominal, self.predicted_std) if not s < v]

    def to_dict(self) -> dict:
        nominal: dict[str, dict] = {}
        predicted: dict[str, dict] = {}
        for (m, k), v, s in zip(self.targets, self.nominal, self.predicted_std):
            nominal.setdefault(m, {})[k] = float(v)
            predicted.setdefault(m, {})[k] = finite_or_none(s)
        return {
            "condition_number": finite_or_none(self.condition_number),
            "verdict": self.verdict,
            "damping_std_rel": self.damping_std_rel,
            "nominal": nominal,
            "predicted_std": predicted,
            "useless_for": self.useless,
        }

    def report(self) -> str:
        lines = [
            f"damping: condition number of the loss-factor columns {self.condition_number:.4g}: "
            f"{self.verdict}; "
            f"predicted std for {100 * self.damping_std_rel:.3g} % damping scatter:"
        ]
        lines += [
            f"  {n:28s} {v:.4g} +- {s:.2g}" for n, v, s in zip(self.names, self.nominal, self.predicted_std)
        ]
        if self.useless:
            lines.append(
                f"  this design does not determine {', '.join(self.useless)} (std above the value): useless "
                "for their damping whatever it does for stiffness"
            )
        return "\n".join(lines)


def damping_scores(model: SpecimenModel, configurations, damping_std_rel: float) -> DampingScores | None:
    """The loss-factor scores of ``configurations`` (``Configuration`` objects) of
    ``model`` at its nominal properties; None when no material has ``identify_damping``."""
    materials = model.specimen.materials
    targets = [(m.name, k) for m in materials.values() for k in m.identify_damping]
    if not targets:
        return None
    nominal = np.array(
        [getattr(materials[m], "eta_E1" if k == "eta" else k) or NOMINAL_LOSS for m, k in targets]
    )
    values = {(m, k): v for (m, k), v in zip(targets, nominal)}
    nominal_materials = []
    for m in {m for m, _ in targets}:
        etas = {k: values.get((m, k), values.get((m, "eta"), NOMINAL_LOSS)) for k in LOSS_FACTORS}
        nominal_materials.append(materials[m].with_values(**etas))
    scored = model.with_configurations(configurations)
    scored = scored.with_specimen(scored.specimen.with_materials(nominal_materials))
    columns = loss_columns(scored, targets)
    modal = first_order_loss_factors(scored)
    n = scored.options.modes
    rows, sigma = [], []
    for k, c in enumerate(scored.specimen.configurations):
        lam, eta = scored.solve(c.name).modes.eigenvalues, modal[c.name]
        for group in close_groups(lam, eta):
            w = lam[group] / lam[group].sum()
            rows.append(w @ columns[k * n + np.array(group)])
            sigma.append(damping_std_rel * np.sqrt(np.sum((w * eta[group]) ** 2)))
    a = np.array(rows)
    weighted = a / np.array(sigma)[:, None]
    if len(a) < len(targets):
        return DampingScores(
            tuple(targets),
            nominal,
            np.full(len(targets), math.inf),
            math.inf,
            Verdict.SINGULAR,
            damping_std_rel,
        )
    s = np.linalg.svd(a, compute_uv=False)
    condition = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    std = (
        np.sqrt(np.diag(np.linalg.pinv(weighted.T @ weighted)))
        if math.isfinite(condition)
        else np.full(len(targets), math.inf)
    )
    return DampingScores(
        tuple(targets), nominal, std, condition, condition_verdict(condition), damping_std_rel
    )
