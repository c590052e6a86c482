"""Each layer's loss factors from the modal damping of all configurations.

After the stiffness fit, each measured mode's loss factor is, to first order, linear in
the layers' loss factors (``fem.solver.damping``):

    eta_i = sum_known eta_p w_ip + sum_unknown eta_p w_ip,   w_ip = d ln(lambda_i) / d ln(p),

with the weights at the identified stiffness.  The known materials' share is subtracted
and the unknown loss factors solved by weighted linear least squares bounded at
0 <= eta <= ``fem.laminates.material.MAX_LOSS_FACTOR`` (scipy ``lsq_linear``), rows weighted by
the damping scatter: the measurements' ``damping_std``, or ``ASSUMED_DAMPING_STD_REL``
of each damping ratio (the std then scaled up by the misfit when it exceeds that: the
scatter estimated from the residual).  The condition number of the loss-factor columns
gets the paper's verdict (``fem.solver.sensitivity.condition_verdict``); a singular one, fewer
measured modes than loss factors, or a std above ``UNDETERMINED_STD`` gives
``not_identifiable`` and no values.  A chi^2 test against the damping scatter
(``identify.engine.statistics.CHI2_TEST_LEVEL``) tells ``converged`` from ``poor_fit``.  When a
mode's energy-weighted RMS loss factor exceeds ``LARGE_LOSS`` and first order errs (by
O(eta^2)) beyond ``REFINE_SHARE`` of the scatter, the fit is refined on the complex
eigenproblem (``fem.solver.complex_modes``).

Damping ratio and loss factor: ``fem.solver.damping.loss_from_ratio`` (eta = 2 zeta for light
damping, exact for a pole of lambda* = omega^2 (1 + i eta)).

Close modes (``fem.solver.damping.close_groups``) are mixed by damping: only their
lambda-weighted sum follows the layers' loss factors, so such a group
enters as one row; a group with a mode not measured is left out (and said so).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy import stats
from scipy.optimize import lsq_linear

from fem.laminates.material import MAX_LOSS_FACTOR
from fem.model import SpecimenModel
from fem.numbers import finite_or_none
from fem.solver.complex_modes import complex_loss_factors
from fem.solver.damping import (
    close_groups,
    known_targets,
    loss_columns,
    loss_from_ratio,
    loss_slope,
    ratio_from_loss,
)
from fem.solver.sensitivity import Verdict, condition_verdict

from ..engine.statistics import CHI2_TEST_LEVEL
from ..measurements import Measurements

#: Damping scatter assumed when the measurements give no damping_std: 3 % of the damping
#: ratio (repeated tap tests of free plates; half-power and curve-fit estimates agree to
#: about that).
ASSUMED_DAMPING_STD_REL = 0.03
#: Above this energy-weighted RMS loss factor of a mode the first-order relation may err by
#: O(eta^2) beyond a fraction of the scatter: one complex solve checks it.
LARGE_LOSS = 0.05
#: ... and when, at the first-order solution, the complex eigenproblem differs from it by
#: more than this share of a row's std (one complex solve per configuration decides).
REFINE_SHARE = 0.1
#: The refinement on the complex eigenproblem takes at most this many Gauss-Newton steps
#: (fewer when a step moves no loss factor by more than 0.1 % of its value).
REFINE_STEPS = 6
#: A loss factor whose std would exceed this (half the allowed range 0..2) is not
#: determined by the data: the result is ``not_identifiable``, with no values.
UNDETERMINED_STD = 0.5 * MAX_LOSS_FACTOR
STATUSES = ("converged", "poor_fit", "not_identifiable")


@dataclass(frozen=True)
class DampingResult:
    """Identified loss factors: ``targets`` (material, damping parameter) with ``values``
    and ``std`` [-] (NaN when not identifiable); ``status`` one of ``STATUSES`` and a
    ``message``; ``condition_number`` of the loss-factor columns and its ``verdict``;
    ``residuals``: one row per measured mode used (configuration, mode, measured and model
    damping ratio, the measured one's std, its group of close modes and lambda share in
    it: within a group only the weighted mean is modelled, mode by mode damping mixes
    them); chi^2 against the scatter with ``dof`` and ``p_value``; ``method``:
    "first_order" or "complex"; ``notes``."""

    status: str
    message: str
    targets: tuple[tuple[str, str], ...]
    values: np.ndarray
    std: np.ndarray
    condition_number: float
    verdict: Verdict
    residuals: pd.DataFrame
    chi2: float = math.nan
    dof: int = 0
    p_value: float = math.nan
    scatter_stated: bool = False
    method: str = "first_order"
    at_bound: tuple[bool, ...] = ()
    notes: tuple[str, ...] = field(default=())

    @property
    def converged(self) -> bool:
        return self.status == "converged"

    @property
    def rms_rel_error(self) -> float:
        """RMS of (model - measured) / measured damping ratio over the rows used."""
        r = self.residuals
        if r.empty or r["model_damping_ratio"].isna().all():
            return math.nan
        # close modes are one group (their lambda-weighted mean is what the model predicts)
        weighted = r[["measured_damping_ratio", "model_damping_ratio"]].mul(r["weight"], axis=0)
        groups = weighted.groupby(r["group"]).sum()
        return float(
            np.sqrt(np.mean((groups["model_damping_ratio"] / groups["measured_damping_ratio"] - 1) ** 2))
        )

    def value(self, material: str, kind: str) -> float:
        return float(self.values[self.targets.index((material, kind))])

    def std_of(self, material: str, kind: str) -> float:
        return float(self.std[self.targets.index((material, kind))])

    @property
    def scatter(self) -> str:
        """Where the damping scatter came from."""
        return (
            "damping_std"
            if self.scatter_stated
            else f"assumed {100 * ASSUMED_DAMPING_STD_REL:g} % of each damping ratio (no damping_std given)"
        )

    def to_dict(self) -> dict:
        """The fit JSON's ``"damping"`` block (no NaN: null where a value does not exist)."""
        rows = [
            {
                "configuration": r.configuration,
                "mode": int(r.mode),
                "measured_damping_ratio": float(r.measured),
                "damping_std": float(r.std),
                "model_damping_ratio": finite_or_none(r.model),
                "group": int(r.group),
            }
            for r in self.residuals.rename(
                columns={
                    "measured_damping_ratio": "measured",
                    "damping_std": "std",
                    "model_damping_ratio": "model",
                }
            ).itertuples()
        ]
        return {
            "status": self.status,
            "message": self.message,
            "method": self.method,
            "condition_number": finite_or_none(self.condition_number),
            "verdict": self.verdict,
            "rms_rel_error": finite_or_none(self.rms_rel_error),
            "chi2": finite_or_none(self.chi2),
            "dof": self.dof,
            "p_value": finite_or_none(self.p_value),
            "scatter": self.scatter,
            "parameters": [
                {"material": m, "parameter": k, "value": finite_or_none(v), "std": finite_or_none(s)}
                for (m, k), v, s in zip(self.targets, self.values, self.std)
            ],
            "notes": list(self.notes),
            "residuals": rows,
        }


def damping_targets(model: SpecimenModel) -> list[tuple[str, str]]:
    """(material, damping parameter) of every loss factor the spec asks to identify."""
    return [(m.name, kind) for m in model.specimen.materials.values() for kind in m.identify_damping]


@dataclass(frozen=True)
class _Rows:
    """The measured modes used, grouped: ``group`` per row; per group (in order) the
    weights (lambda share) of its rows."""

    table: pd.DataFrame  # configuration, mode, model index, lambda, eta, eta_std, group
    n_groups: int

    @property
    def weights(self) -> np.ndarray:
        """Each row's share of its group's lambda."""
        return (self.table["lambda"] / self.table.groupby("group")["lambda"].transform("sum")).to_numpy()

    def combine(self, per_row: np.ndarray) -> np.ndarray:
        """Lambda-weighted group sums of a per-row quantity (rows or rows x columns)."""
        out = np.zeros((self.n_groups,) + per_row.shape[1:])
        np.add.at(out, self.table["group"].to_numpy(), (self.weights.T * per_row.T).T)
        return out

    def combined_std(self) -> np.ndarray:
        out = np.zeros(self.n_groups)
        np.add.at(out, self.table["group"].to_numpy(), (self.weights * self.table["eta_std"].to_numpy()) ** 2)
        return np.sqrt(out)


def _rows(model: SpecimenModel, measurements: Measurements, pairings: dict) -> tuple[_Rows, list[str]]:
    """The measured modes with a damping ratio, their model modes and groups of close modes."""
    notes, records = [], []
    group = 0
    for c in model.specimen.configurations:
        frame = measurements.of(c.name)
        if frame.empty or (pairings is not None and c.name not in pairings):
            continue
        lam = model.solve(c.name).modes.eigenvalues
        index = frame["mode"].to_numpy() - 1 if pairings is None else np.asarray(pairings[c.name].indices)
        zeta = frame["damping_ratio"].to_numpy()
        eta = loss_from_ratio(zeta)
        given = frame["damping_std"].to_numpy()
        slope = loss_slope(zeta)
        std = slope * np.where(np.isfinite(given), given, ASSUMED_DAMPING_STD_REL * zeta)
        measured = {int(i): k for k, i in enumerate(index) if np.isfinite(zeta[k])}
        loss = np.zeros(len(lam))
        for i, k in measured.items():
            loss[i] = eta[k]
        for members in close_groups(lam, loss):
            if not any(i in measured for i in members):
                continue
            if not all(i in measured for i in members):
                ranks = ", ".join(str(int(frame["mode"].iloc[measured[i]])) for i in members if i in measured)
                notes.append(
                    f"{c.name}: mode(s) {ranks} left out of the damping fit: damping mixes them with a close "
                    "mode that has no measured damping ratio"
                )
                continue
            for i in members:
                k = measured[i]
                records.append(
                    {
                        "configuration": c.name,
                        "mode": int(frame["mode"].iloc[k]),
                        "model_index": i,
                        "lambda": lam[i],
                        "eta": eta[k],
                        "eta_std": std[k],
                        "zeta": zeta[k],
                        "zeta_std": std[k] / slope[k],
                        "group": group,
                        "row": list(model.specimen.configurations).index(c) * model.options.modes + i,
                    }
                )
            if len(members) > 1:
                notes.append(
                    f"{c.name}: modes "
                    f"{', '.join(str(int(frame['mode'].iloc[measured[i]])) for i in members)} "
                    "are close: damping mixes them, their lambda-weighted mean loss factor is fitted"
                )
            group += 1
    table = pd.DataFrame.from_records(
        records,
        columns=[
            "configuration",
            "mode",
            "model_index",
            "lambda",
            "eta",
            "eta_std",
            "zeta",
            "zeta_std",
            "group",
            "row",
        ],
    )
    return _Rows(table, group), notes


def identify_damping(
    model: SpecimenModel,
    measurements: Measurements,
    pairings: dict | None = None,
    targets: list[tuple[str, str]] | None = None,
) -> DampingResult | None:
    """The loss factors ``targets`` (default: the spec's ``identify_damping``) of a fitted
    ``model`` from the measured damping ratios of the modes ``pairings`` pairs (a
    ``FitResult``'s; None: ranked measurements, mode k with model mode k).  None when
    nothing is to be identified."""
    targets = damping_targets(model) if targets is None else list(targets)
    if not targets:
        return None
    nothing = np.full(len(targets), math.nan)
    rows, notes = _rows(model, measurements, pairings)
    empty = pd.DataFrame(
        columns=[
            "configuration",
            "mode",
            "measured_damping_ratio",
            "damping_std",
            "model_damping_ratio",
            "group",
            "weight",
        ]
    )
    if rows.table.empty:
        return DampingResult(
            "not_identifiable",
            "no measured damping ratios (a damping_ratio column): the loss factors cannot be identified",
            tuple(targets),
            nothing,
            nothing,
            math.nan,
            Verdict.SINGULAR,
            empty,
            notes=tuple(notes),
        )
    index = rows.table["row"].to_numpy()
    columns = loss_columns(model, targets)[index]
    known = known_targets(model)
    materials = model.specimen.materials
    given = np.array([materials[m].loss_factor(k) for m, k in known])
    unstated = sorted({m for m, k in known if getattr(materials[m], k) is None})
    if unstated:
        notes.append(f"no loss factor given for {', '.join(unstated)}: taken as 0 (elastic)")
    known_columns = loss_columns(model, known)[index] if known else np.zeros((len(index), 0))
    known_part = known_columns @ given
    a = rows.combine(columns)
    b = rows.combine(rows.table["eta"].to_numpy() - known_part)
    sigma = rows.combined_std()
    condition = float(np.linalg.cond(a)) if len(a) >= len(targets) else math.inf
    verdict = condition_verdict(condition)
    scatter_stated = bool(measurements.table["damping_std"].notna().any())
    if len(a) < len(targets) or verdict == Verdict.SINGULAR:
        why = (
            f"{len(a)} independent damped modes for {len(targets)} loss factors"
            if len(a) < len(targets)
            else f"the loss-factor columns are singular (condition number {condition:.3g})"
        )
        return DampingResult(
            "not_identifiable",
            f"the layers' loss factors are not identifiable: {why}; add "
            "configurations that change the layers' share of the strain energy (plan-tests check)",
            tuple(targets),
            nothing,
            nothing,
            condition,
            verdict,
            _residual_table(rows, None),
            notes=tuple(notes),
            scatter_stated=scatter_stated,
        )
    weighted = a / sigma[:, None]
    solution = lsq_linear(weighted, b / sigma, bounds=(0.0, MAX_LOSS_FACTOR), method="bvls")
    x, method = solution.x, "first_order"
    model_eta = columns @ x + known_part
    # Energy-weighted RMS loss factor of each mode: first order errs by O(its square).
    weights = np.hstack([columns, known_columns])
    spread = np.sqrt((weights @ np.concatenate([x, given]) ** 2) / np.maximum(weights.sum(axis=1), 1e-12))
    if model.options.theory == "single_layer" and spread.max(initial=0.0) > LARGE_LOSS:
        exact = _complex_rows(_with_losses(model, targets, x), rows)
        if np.max(np.abs(rows.combine(exact - model_eta)) / sigma) > REFINE_SHARE:
            x, model_eta = _complex_refit(model, rows, targets, x, weighted, sigma)
            method = "complex"
            notes.append(
                f"a loss factor above {LARGE_LOSS:g} made first order err by over {REFINE_SHARE:g} std: "
                "refined on the complex eigenproblem"
            )
    r = (rows.combine(model_eta) - rows.combine(rows.table["eta"].to_numpy())) / sigma
    chi2 = float(r @ r)
    dof = len(r) - len(targets)
    p_value = float(stats.chi2.sf(chi2, dof)) if dof > 0 else 1.0
    # Linear in the loss factors to O(eta^2): the first-order columns are the Jacobian.
    jacobian = weighted
    covariance = np.linalg.pinv(jacobian.T @ jacobian)
    std = np.sqrt(np.clip(np.diag(covariance), 0, None))
    if not scatter_stated and dof > 0 and chi2 > dof:
        std *= math.sqrt(chi2 / dof)
        notes.append(
            f"no damping_std given: the std are scaled by the misfit (reduced chi^2 {chi2 / dof:.3g} "
            f"against the assumed {100 * ASSUMED_DAMPING_STD_REL:g} %)"
        )
    vague = [f"{m}.{k}" for (m, k), sd in zip(targets, std) if not sd <= UNDETERMINED_STD]
    if vague:
        return DampingResult(
            "not_identifiable",
            f"the layers' loss factors are not identifiable: the std of "
            f"{', '.join(vague)} would exceed {UNDETERMINED_STD:g} (condition number "
            f"{condition:.3g}); "
            "add configurations that change the layers' share of the strain energy (plan-tests "
            "check)",
            tuple(targets),
            nothing,
            nothing,
            condition,
            verdict,
            _residual_table(rows, None),
            notes=tuple(notes),
            scatter_stated=scatter_stated,
        )
    at_bound = tuple(bool(v <= 1e-12 or v >= MAX_LOSS_FACTOR - 1e-12) for v in x)
    if p_value < CHI2_TEST_LEVEL:
        status = "poor_fit"
        message = (
            f"the layers' loss factors do not explain the measured damping: chi^2 {chi2:.3g} for {dof} "
            "degrees "
            f"of freedom (p = {p_value:.2g}); an extra damping (suspension, sensor cable, air) or a wrong "
            "scatter?"
        )
    else:
        status = "converged"
        message = (
            f"the measured damping is consistent with the scatter "
            f"(chi^2 {chi2:.3g} for {dof} degrees of freedom)"
        )
    if verdict == Verdict.ILL_CONDITIONED:
        notes.append(
            f"the loss-factor columns are ill-conditioned (condition number {condition:.3g}): large std"
        )
    return DampingResult(
        status,
        message,
        tuple(targets),
        x,
        std,
        condition,
        verdict,
        _residual_table(rows, model_eta),
        chi2,
        dof,
        p_value,
        scatter_stated,
        method,
        at_bound,
        tuple(notes),
    )


def _with_losses(model: SpecimenModel, targets, x) -> SpecimenModel:
    changes: dict[str, dict] = {}
    for (name, kind), value in zip(targets, x):
        kinds = ("eta_E1", "eta_E2", "eta_G12") if kind == "eta" else (kind,)
        changes.setdefault(name, {}).update({k: float(value) for k in kinds})
    materials = [replace(model.specimen.materials[n], **c) for n, c in changes.items()]
    return model.with_specimen(model.specimen.with_materials(materials))


def _complex_rows(model: SpecimenModel, rows: _Rows) -> np.ndarray:
    table = rows.table
    out = np.empty(len(table))
    for name in dict.fromkeys(table["configuration"]):
        here = (table["configuration"] == name).to_numpy()
        out[here] = complex_loss_factors(model, name)[table["model_index"].to_numpy()[here]]
    return out


def _complex_refit(model, rows: _Rows, targets, start, weighted, sigma):
    """Least squares on the complex eigenproblem by at most ``REFINE_STEPS`` Gauss-Newton
    steps with the first-order columns as the Jacobian (exact to O(eta^2), so each step
    gains a factor ~eta^2; the bounds kept by ``lsq_linear``).  Returns the values and the
    model loss factors."""
    measured = rows.combine(rows.table["eta"].to_numpy())
    x = start
    for _ in range(REFINE_STEPS):
        model_eta = _complex_rows(_with_losses(model, targets, x), rows)
        r = (measured - rows.combine(model_eta)) / sigma
        step = lsq_linear(weighted, r, bounds=(-x, MAX_LOSS_FACTOR - x), method="bvls").x
        x = np.clip(x + step, 0.0, MAX_LOSS_FACTOR)
        if np.all(np.abs(step) <= 1e-3 * np.maximum(np.abs(x), 1e-6)):
            break
    return x, _complex_rows(_with_losses(model, targets, x), rows)


def _residual_table(rows: _Rows, model_eta: np.ndarray | None) -> pd.DataFrame:
    t = rows.table
    model = ratio_from_loss(model_eta) if model_eta is not None else np.full(len(t), np.nan)
    weight = t["lambda"] / t.groupby("group")["lambda"].transform("sum")
    return pd.DataFrame(
        {
            "configuration": t["configuration"],
            "mode": t["mode"],
            "measured_damping_ratio": t["zeta"],
            "damping_std": t["zeta_std"],
            "model_damping_ratio": model,
            "group": t["group"],
            "weight": weight,
        }
    )
