"""Reading an identification: text report, JSON (DESIGN.md shape), CSV tables and plots."""
from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from fem.io import to_json, write_text

from .measurements import Measurements
from .parameters import UNITS, display, json_key

if TYPE_CHECKING:
    from .result import FitResult


def residual_table(measurements: Measurements, model_hz: np.ndarray) -> pd.DataFrame:
    """Per measured mode: measured and model frequency, relative error, error / std."""
    table = measurements.table
    out = pd.DataFrame({
        "configuration": table["configuration"], "mode": table["mode"],
        "measured_hz": table["frequency_hz"], "model_hz": model_hz,
        "rel_error": model_hz / table["frequency_hz"] - 1,
    })
    if measurements.has_std:
        out["error_over_std"] = (out["model_hz"] - out["measured_hz"]) / table["std_hz"]
    return out


def fit_residuals(result: FitResult) -> pd.DataFrame:
    """The residual rows of a fit (DESIGN.md): every measured frequency with the model
    mode it is paired with (1-based; None for a peak left out), measured and model (or,
    left out, the nearest mode's) frequency, relative error, matched; ranked data also
    keep the rank given (``measured_mode``) and the error in std when std_hz is given."""
    if result.peaks is not None:
        from .peak_lists import peak_table

        return peak_table(result.peaks)
    table = result.measurements.table
    configs = table["configuration"].to_numpy()
    modes = np.zeros(len(table), dtype=int)
    for name, pairing in result.pairings.items():
        modes[configs == name] = pairing.indices + 1
    out = residual_table(result.measurements, result.model_hz)
    out.insert(1, "measured_mode", out.pop("mode"))
    out.insert(1, "mode", modes)
    out["matched"] = True
    return out


def history_table(result: FitResult) -> pd.DataFrame:
    """One row per iteration: parameter values (display units), RMS error, step, damping."""
    rows = []
    for it in result.history:
        row = {"iteration": it.number, "rms_rel_error": it.rms_rel_error, "step": it.step, "damping": it.damping}
        row.update({f"{p.name}_{UNITS[p.kind][0] or '-'}": display(p, v) for p, v in zip(result.parameters, it.values)})
        rows.append(row)
    return pd.DataFrame(rows)


def _finite(x: float):
    return float(x) if math.isfinite(x) else None


def to_dict(result: FitResult) -> dict:
    """The fit JSON of DESIGN.md, with status, conditioning, warnings and history added."""
    materials: dict[str, dict] = {}
    effects: dict[str, dict] = {}
    for p, value, sd, flags in zip(result.parameters, result.values, result.uncertainty.std, result.uncertainty.flags):
        kind = result.effect_of.get(p)
        if kind or p.target not in result.specimen.materials:
            entry = effects.setdefault(kind or p.target, {"std": {}, "flags": {}})
            key = json_key(p) if p.kind not in ("angle", "thickness") else f"{p.target}.{json_key(p)}"
        else:
            entry = materials.setdefault(p.target, {"std": {}, "flags": {}})
            key = json_key(p)
        entry[key] = display(p, value)
        entry["std"][key] = _finite(display(p, sd))
        if flags:
            entry["flags"][key] = list(flags)
    u, st = result.uncertainty, result.statistics
    return {
        "converged": result.converged,
        "status": result.status.value,
        "message": result.message,
        "iterations": result.iterations,
        "materials": materials,
        "effects": effects,
        "residuals": fit_residuals(result).to_dict(orient="records"),
        "causes": [c.to_dict() for c in result.causes],
        "rms_rel_error": result.rms_rel_error,
        "condition_number": _finite(u.condition_number),
        "verdict": u.verdict,
        "reduced_chi2": _finite(st.reduced_chi2) if st.scatter_known else None,
        "noise_source": st.noise_source,
        "statistics": st.to_dict(),
        "weak_combinations": list(u.weak_combinations),
        "correlation": {"parameters": [p.name for p in result.parameters],
                        "matrix": [[_finite(x) for x in row] for row in u.correlation]},
        "warnings": list(result.warnings),
        "history": history_table(result).to_dict(orient="records"),
    }


def before_after_table(before: FitResult, after: FitResult) -> pd.DataFrame:
    """Relative error per measured mode without and with the effects switched on."""
    table = before.measurements.table
    return pd.DataFrame({"configuration": table["configuration"], "mode": table["mode"],
                         "measured_hz": table["frequency_hz"], "rel_error_before": before.rel_error,
                         "rel_error_after": after.rel_error})


def report_text(result: FitResult) -> str:
    """Fixed sections: statistics, parameters +- std with flags, correlations, residuals,
    the error per mode before and after the effects (when they were free), warnings."""
    u, st = result.uncertainty, result.statistics
    before = result.baseline
    chi2 = (f"  reduced chi^2          {st.reduced_chi2:.3g} (1 = the stated scatter)" if st.scatter_known else
            f"  misfit / scatter       {st.misfit_over_scatter:.3g} (against an assumed 0.1 %: no std_hz given)")
    lines = [f"== identification: {result.status.value} ==", f"   {result.message}"]
    if result.causes:
        lines += ["", "likely causes (share of the misfit each accounts for)"]
        lines += [f"  {100 * c.score:5.0f} %  {c.kind}: {c.text}" for c in result.causes]
    lines += ["", "statistics",
              f"  measured frequencies   {len(result.measurements)} in {len(result.measurements.configurations)} "
              f"configurations",
              f"  unknown parameters     {len(result.parameters)}",
              f"  iterations             {result.iterations}",
              f"  RMS relative error     {100 * result.rms_rel_error:.4f} %",
              chi2,
              f"  consistent with it     {'yes' if st.consistent else 'no'} (chi^2 test, p = {st.p_value:.2g}; "
              f"level 0.001)",
              f"  scatter from           {st.noise_source}",
              f"  condition number       {u.condition_number:.3g} ({u.verdict}; paper: good < 1e3, singular > 1e7)"]
    lines += ["", "parameters (value +- 1 std)"]
    for p, value, sd, flags in zip(result.parameters, result.values, u.std, u.flags):
        unit = UNITS[p.kind][0]
        shown = display(p, value)
        sd_text = f"{display(p, sd):.4g}" if math.isfinite(sd) else "n/a"
        rel = f"({100 * sd / abs(value):.2g} %)" if math.isfinite(sd) and value else ""
        lines.append(f"  {p.name:28s} {shown:12.5g} +- {sd_text:>9s} {unit:7s} {rel:10s} {'; '.join(flags)}")
    strong = [(i, j) for i in range(len(result.parameters)) for j in range(i)
              if np.isfinite(u.correlation[i, j]) and abs(u.correlation[i, j]) > 0.9]
    lines += ["", "correlations above 0.9"]
    lines += [f"  {result.parameters[i].name} ~ {result.parameters[j].name}: {u.correlation[i, j]:+.3f}"
              for i, j in strong] or ["  none"]
    lines += ["", "weakly identifiable combinations (singular value < 1e-3 of the largest)"]
    lines += [f"  {c}" for c in u.weak_combinations] or ["  none"]
    lines += ["", "residuals (mode: the model mode each measured frequency is paired with)",
              fit_residuals(result).to_string(index=False, float_format=lambda x: f"{x:.6g}")]
    if before is not None:
        kinds = ", ".join(sorted(set(result.effect_of.values()))) or "the spec's effects"
        lines += ["", f"error per mode before and after adding {kinds} (RMS {100 * before.rms_rel_error:.4g} % -> "
                  f"{100 * result.rms_rel_error:.4g} %)",
                  before_after_table(before, result).to_string(index=False, float_format=lambda x: f"{x:.4g}")]
    lines += ["", "warnings"] + ([f"  - {w}" for w in result.warnings] or ["  none"])
    return "\n".join(lines) + "\n"


def write_report(result: FitResult, folder: str | Path) -> Path:
    """A report folder: report.txt, fit.json, residuals.csv, history.csv and plots (and the
    error per mode before and after the effects when they were free)."""
    from .plots import plot_before_after, plot_convergence, plot_residuals

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_text(folder / "report.txt", report_text(result))
    if result.baseline is not None:
        write_text(folder / "before_after.csv", before_after_table(result.baseline, result).to_csv(index=False))
        plot_before_after(result.baseline, result, ", ".join(sorted(set(result.effect_of.values()))) or "effects",
                          folder / "before_after.png")
    write_text(folder / "fit.json", to_json(to_dict(result)))
    write_text(folder / "residuals.csv", fit_residuals(result).to_csv(index=False))
    write_text(folder / "history.csv", history_table(result).to_csv(index=False))
    plot_convergence(result, folder / "convergence.png")
    plot_residuals(result, folder / "residuals.png")
    return folder
