"""The identified loss factors in every output: the fit JSON (``eta_*`` under each
material, their std in its ``"std"`` table, and the ``"damping"`` block), parameters.csv
rows, the text report's section and the HTML report's table and figure."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from fem.laminates.material import LOSS_FACTORS
from fem.numbers import finite_or_none
from fem.solver.damping import loss_from_ratio, loss_slope

if TYPE_CHECKING:
    from ..fitting.damping import DampingResult


def material_entries(damping: DampingResult, model) -> dict[str, dict]:
    """Material name -> {eta_E1: value, ..., "std": {eta_E1: std, ...}, "flags": {...}}:
    the identified loss factors (a shared ``eta`` under each of the three keys) and the
    known ones the spec gives (no std).  Not identifiable: value and std null."""
    out: dict[str, dict] = {}
    for m in model.specimen.materials.values():
        for kind in LOSS_FACTORS:
            if (
                getattr(m, kind) is not None
                and kind not in m.identify_damping
                and "eta" not in m.identify_damping
            ):
                entry = out.setdefault(m.name, {"std": {}, "flags": {}})
                entry[kind] = getattr(m, kind)
                entry["flags"][kind] = ["known"]
    for (name, kind), value, sd, bound in zip(
        damping.targets, damping.values, damping.std, damping.at_bound or (False,) * len(damping.targets)
    ):
        entry = out.setdefault(name, {"std": {}, "flags": {}})
        for key in LOSS_FACTORS if kind == "eta" else (kind,):
            entry[key], entry["std"][key] = finite_or_none(value), finite_or_none(sd)
            flags = (
                (["not identifiable"] if damping.status == "not_identifiable" else [])
                + (["at bound"] if bound else [])
                + (["shared eta"] if kind == "eta" else [])
            )
            if flags:
                entry["flags"][key] = flags
    return out


def merge_into(document: dict, damping: DampingResult | None, model) -> dict:
    """The fit JSON with the loss factors added under ``"materials"`` and the
    ``"damping"`` block (null when no damping was identified)."""
    document["damping"] = None if damping is None else damping.to_dict()
    if damping is not None:
        for name, entry in material_entries(damping, model).items():
            target = document["materials"].setdefault(name, {"std": {}, "flags": {}})
            for key, value in entry.items():
                if key in ("std", "flags"):
                    target.setdefault(key, {}).update(value)
                else:
                    target[key] = value
    return document


def parameter_rows(damping: DampingResult) -> pd.DataFrame:
    """parameters.csv rows of the identified loss factors (blank value and std when not
    identifiable)."""
    rows = []
    for (name, kind), value, sd, bound in zip(
        damping.targets, damping.values, damping.std, damping.at_bound or (False,) * len(damping.targets)
    ):
        flags = [damping.status] if damping.status != "converged" else []
        flags += ["at bound"] if bound else []
        rows.append(
            {
                "parameter": f"{name}.{kind}",
                "of": "material",
                "value": value,
                "std": sd,
                "unit": "",
                "std_percent": 100 * sd / value if value and math.isfinite(sd) else float("nan"),
                "flags": "; ".join(flags),
            }
        )
    return pd.DataFrame(rows)


def text_section(damping: DampingResult) -> list[str]:
    """The text report's damping section."""
    lines = [
        "",
        f"== damping: {damping.status} ({damping.method.replace('_', ' ')}) ==",
        f"   {damping.message}",
        f"  damped modes used      {len(damping.residuals)}",
        f"  condition number       {damping.condition_number:.3g} ({damping.verdict}; paper: good < 1e3, "
        "singular > 1e7)",
        f"  scatter from           {damping.scatter}",
    ]
    if damping.dof:
        lines.append(
            f"  chi^2                  {damping.chi2:.3g} for {damping.dof} degrees of freedom "
            f"(p = {damping.p_value:.2g})"
        )
    if math.isfinite(damping.rms_rel_error):
        lines.append(f"  RMS relative error     {100 * damping.rms_rel_error:.3g} % of the damping ratios")
    lines += ["", "loss factors (value +- 1 std)"]
    for (name, kind), value, sd in zip(damping.targets, damping.values, damping.std):
        shown = f"{value:.4g} +- {sd:.2g}" if math.isfinite(value) else "not identifiable"
        lines.append(f"  {name + '.' + kind:28s} {shown}")
    if not damping.residuals.empty:
        lines += [
            "",
            "damping residuals (group: close modes, whose lambda-weighted mean is modelled)",
            damping.residuals.drop(columns="weight").to_string(
                index=False, float_format=lambda x: f"{x:.4g}"
            ),
        ]
    lines += [f"  - {n}" for n in damping.notes]
    return lines


def plot_damping(damping: DampingResult, path: Path) -> Path:
    """Measured (error bars: 1 std) and model modal loss factors per configuration."""
    from fem.plotting import new_figure, save_figure

    rows = damping.residuals
    zeta, zeta_std = rows["measured_damping_ratio"].to_numpy(), rows["damping_std"].to_numpy()
    measured = loss_from_ratio(zeta)
    measured_std = zeta_std * loss_slope(zeta)
    model = loss_from_ratio(rows["model_damping_ratio"].to_numpy())
    x = np.arange(len(rows))
    fig, ax = new_figure(figsize=(max(7.0, 0.45 * len(rows) + 2), 4.4))
    for k, name in enumerate(dict.fromkeys(rows["configuration"])):
        mask = (rows["configuration"] == name).to_numpy()
        ax.errorbar(
            x[mask],
            measured[mask],
            yerr=measured_std[mask],
            fmt="o",
            color=f"C{k}",
            capsize=3,
            label=f"{name} measured",
        )
        if rows["model_damping_ratio"].notna().any():
            ax.plot(x[mask], model[mask], "x", color=f"C{k}", ms=8, label=f"{name} model")
    ax.set_xticks(x)
    ax.set_xticklabels(
        [f"{c} {m}" for c, m in zip(rows["configuration"], rows["mode"])], fontsize=6.5, rotation=90
    )
    ax.set_ylabel("modal loss factor eta [-]")
    ax.set_title(f"modal loss factors ({damping.status})", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, axis="y")
    return save_figure(fig, path)
