"""Reading an identification: text report, JSON (the ``fit --json`` shape), CSV tables and plots.
Formats the fit result it is handed (duck-typed: it imports no result module).  Text and
HTML round every value to its uncertainty (``rounding``); JSON and CSV keep full precision."""

from __future__ import annotations

import html
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from fem.io import report_folder, to_json, write_text
from fem.numbers import finite_or_none

from ..engine.ambiguity import IMAGE_KINDS
from ..engine.objective import solving_model
from ..engine.parameters import UNITS, display, json_key
from . import damping_report
from . import html_report as h
from .html_report import blank_missing
from .plots import plot_before_after, plot_convergence, plot_mode_shapes, plot_residuals
from .residuals import before_after_table, fit_correlations, fit_residuals
from .rounding import percent, status_line, with_std
from .shape_plots import (
    plot_mac_matrices,
    plot_nodal_lines,
    plot_shape_maps,
    plot_shape_point_map,
    shape_lines,
)


def parameter_table(result) -> pd.DataFrame:
    """One row per identified parameter in display units: value, std, unit, relative
    std [%], flags, and what it belongs to (a material, or an effect)."""
    rows = []
    for p, value, sd, flags in zip(
        result.parameters, result.values, result.uncertainty.std, result.uncertainty.flags
    ):
        rows.append(
            {
                "parameter": p.name,
                "of": result.effect_of.get(
                    p, "material" if p.target in result.specimen.materials else "layer"
                ),
                "value": display(p, value),
                "std": display(p, sd) if math.isfinite(sd) else float("nan"),
                "unit": UNITS[p.kind][0],
                "std_percent": 100 * sd / abs(value) if value and math.isfinite(sd) else float("nan"),
                "flags": "; ".join(flags),
            }
        )
    table = pd.DataFrame(rows)
    return (
        table
        if result.damping is None
        else pd.concat([table, damping_report.parameter_rows(result.damping)], ignore_index=True)
    )


def history_table(result) -> pd.DataFrame:
    """One row per iteration: parameter values (display units), RMS error, step, damping."""
    rows = []
    for it in result.history:
        row = {
            "iteration": it.number,
            "rms_rel_error": it.rms_rel_error,
            "step": it.step,
            "damping": it.damping,
        }
        row.update(
            {
                f"{p.name}_{UNITS[p.kind][0] or '-'}": display(p, v)
                for p, v in zip(result.parameters, it.values)
            }
        )
        rows.append(row)
    return pd.DataFrame(rows)


def to_dict(result) -> dict:
    """The fit JSON (``fit --json``): status, materials and effects with std, residuals,
    conditioning, statistics, warnings, history and why the iterations stopped."""
    materials: dict[str, dict] = {}
    effects: dict[str, dict] = {}
    for p, value, sd, flags in zip(
        result.parameters, result.values, result.uncertainty.std, result.uncertainty.flags
    ):
        kind = result.effect_of.get(p)
        if kind or p.target not in result.specimen.materials:
            entry = effects.setdefault(kind or p.target, {"std": {}, "flags": {}})
            key = json_key(p) if p.kind not in ("angle", "thickness") else f"{p.target}.{json_key(p)}"
        else:
            entry = materials.setdefault(p.target, {"std": {}, "flags": {}})
            key = json_key(p)
        entry[key] = display(p, value)
        entry["std"][key] = finite_or_none(display(p, sd))
        if flags:
            entry["flags"][key] = list(flags)
        for follower, ratio in getattr(p, "followers", ()):  # a tied scale (``ties``): its members too
            entry[json_key(follower)] = display(follower, ratio * value)
            entry["std"][json_key(follower)] = finite_or_none(display(follower, ratio * sd))
            entry["flags"][json_key(follower)] = [f"tied: {follower.kind} = {ratio:.4g} x {p.kind}"]
    for kind, text in result.effect_notes:  # every effect switched on, with what was decided
        effects.setdefault(kind, {"std": {}, "flags": {}}).setdefault("notes", []).append(text)
    u, st = result.uncertainty, result.statistics
    shapes = {name: c.to_dict() for name, c in fit_correlations(result).items()}
    return damping_report.merge_into(
        {
            "converged": result.converged,
            "status": result.status.value,
            "message": result.message,
            "iterations": result.iterations,
            "stop_reason": result.stop.code if result.stop is not None else None,
            "materials": materials,
            "effects": effects,
            "residuals": fit_residuals(result).to_dict(orient="records"),
            "causes": [c.to_dict() for c in result.causes],
            "budget": result.budget.to_dict() if result.budget is not None else None,
            "rms_rel_error": result.rms_rel_error,
            "condition_number": finite_or_none(u.condition_number),
            "verdict": u.verdict,
            "reduced_chi2": finite_or_none(st.reduced_chi2) if st.scatter_known else None,
            "noise_source": st.noise_source,
            "statistics": st.to_dict(),
            "weak_combinations": list(u.weak_combinations),
            "correlation": {
                "parameters": [p.name for p in result.parameters],
                "matrix": [[finite_or_none(x) for x in row] for row in u.correlation],
            },
            "warnings": list(result.warnings),
            "images": [
                {
                    "image": name,
                    "values": {
                        p.name: display(p, v)
                        for p, v in zip(result.parameters, image)
                        if p.kind in IMAGE_KINDS
                    },
                }
                for name, image in result.images
            ],
            "history": history_table(result).to_dict(orient="records"),
            "mac_matrix": shapes,
        },
        result.damping,
        result.model,
    )


def _formatted(frame: pd.DataFrame, formats: dict[str, Callable[[float], str]]) -> pd.DataFrame:
    """``frame`` with the named columns turned into text (blank where a value is missing)."""
    out = frame.copy()
    for column, fmt in formats.items():
        if column in out:
            out[column] = [fmt(float(x)) if x is not None and not pd.isna(x) else "" for x in out[column]]
    return out


def _error_percent(rel: float) -> str:
    return f"{100 * rel:+.3g}"


#: How residual and before/after tables show their numbers: frequencies as measured (to
#: 6 significant digits), relative errors in per cent to 3, errors over std to 2 decimals.
RESIDUAL_FORMATS: dict[str, Callable[[float], str]] = {
    "measured_hz": lambda x: f"{x:.6g}",
    "model_hz": lambda x: f"{x:.6g}",
    "rel_error": _error_percent,
    "rel_error_before": _error_percent,
    "rel_error_after": _error_percent,
    "error_over_std": lambda x: f"{x:+.2f}",
    "mac": lambda x: f"{x:.3f}",
}


def shown_residuals(rows: pd.DataFrame) -> pd.DataFrame:
    """The residual rows as a report prints them: relative errors in % (column
    ``error_%``), frequencies to 6 significant digits."""
    out = _formatted(rows, RESIDUAL_FORMATS)
    return out.rename(columns={"rel_error": "error_%"})


def shown_before_after(rows: pd.DataFrame) -> pd.DataFrame:
    """The before/after table as a report prints it: errors in %."""
    return _formatted(rows, RESIDUAL_FORMATS).rename(
        columns={"rel_error_before": "error_before_%", "rel_error_after": "error_after_%"}
    )


def shown_parameters(parameters: pd.DataFrame) -> pd.DataFrame:
    """The parameter table as a report prints it: ``value ± std`` rounded to two
    significant digits of the std, with the relative std in % (parameters.csv keeps
    the full precision)."""
    text = [
        with_std(v, s, u if isinstance(u, str) else "")
        for v, s, u in zip(parameters["value"], parameters["std"], parameters["unit"], strict=True)
    ]
    return pd.DataFrame(
        {
            "parameter": parameters["parameter"],
            "of": parameters["of"],
            "value ± std (rel.)": text,
            "flags": parameters["flags"],
        }
    )


def parameter_lines(result, name_width: int) -> list[str]:
    """One line per parameter of a fit: its name (padded to ``name_width``), value ± std
    in display units with the relative std, and its flags."""
    u = result.uncertainty
    lines = []
    for p, value, sd, flags in zip(result.parameters, result.values, u.std, u.flags):
        shown = with_std(display(p, value), display(p, sd), UNITS[p.kind][0])
        lines.append(f"  {p.name:{name_width}s} {shown:38s} {'; '.join(flags)}".rstrip())
    return lines


def report_text(result) -> str:
    """Fixed sections: statistics, parameters +- std with flags, correlations, residuals,
    the error per mode before and after the effects (when they were free), warnings."""
    u, st = result.uncertainty, result.statistics
    before = result.baseline
    reduced = (
        f"{st.reduced_chi2:.3g}"
        if math.isfinite(st.reduced_chi2)
        else "n/a (as many unknowns as frequencies)"
    )
    chi2 = (
        f"  reduced chi^2          {reduced} (1 = the stated scatter)"
        if st.scatter_known
        else f"  misfit / scatter       {st.misfit_over_scatter:.3g} "
        "(against an assumed 0.1 %: no std_hz given)"
    )
    lines = ["== identification ==", f"   {status_line(result.status.value, result.message)}"]
    if result.causes:
        lines += ["", "likely causes (share of the misfit each accounts for)"]
        lines += [f"  {100 * c.score:5.0f} %  {c.kind}: {c.text}" for c in result.causes]
    lines += [
        "",
        "statistics",
        f"  measured frequencies   {len(result.measurements)} in {len(result.measurements.configurations)} "
        f"configurations",
        f"  unknown parameters     {len(result.parameters)}",
        f"  iterations             {result.iterations}",
        f"  RMS relative error     {percent(result.rms_rel_error, 3)}",
        chi2,
        f"  consistent with it     {'yes' if st.consistent else 'no'} (chi^2 test, p = {st.p_value:.2g}; "
        f"level 0.001)",
        f"  scatter from           {st.noise_source}",
        f"  condition number       {u.condition_number:.3g} ({u.verdict}; paper: good < 1e3, singular > 1e7)",
    ]
    lines += ["", "parameters (value ± 1 std, rounded to two digits of the std; relative std)"]
    lines += parameter_lines(result, 28)
    strong = [
        (i, j)
        for i in range(len(result.parameters))
        for j in range(i)
        if np.isfinite(u.correlation[i, j]) and abs(u.correlation[i, j]) > 0.9
    ]
    if result.budget is not None:
        lines += [
            "",
            "uncertainty budget (each input's share of the std, display units; total = the std above)",
            result.budget.table().to_string(index=False, float_format=lambda x: f"{x:.3g}"),
        ]
    lines += ["", "correlations above 0.9"]
    lines += [
        f"  {result.parameters[i].name} ~ {result.parameters[j].name}: {u.correlation[i, j]:+.3f}"
        for i, j in strong
    ] or ["  none"]
    lines += ["", "weakly identifiable combinations (singular value < 1e-3 of the largest)"]
    lines += [f"  {c}" for c in u.weak_combinations] or ["  none"]
    lines += [
        "",
        "residuals (mode: the model mode each measured frequency is paired with)",
        blank_missing(shown_residuals(fit_residuals(result)), "-").to_string(index=False),
    ]
    correlations = fit_correlations(result)
    if correlations:
        lines += [
            "",
            "measured mode shapes (MAC at the measured points; residual: what the paired mode and its close "
            "neighbours cannot reproduce)",
            *shape_lines(correlations),
        ]
    if before is not None:
        kinds = ", ".join(sorted(set(result.effect_of.values()))) or "the spec's effects"
        lines += [
            "",
            f"error per mode before and after adding {kinds} (RMS {percent(before.rms_rel_error, 3)} -> "
            f"{percent(result.rms_rel_error, 3)})",
            blank_missing(shown_before_after(before_after_table(before, result)), "-").to_string(index=False),
        ]
    if result.damping is not None:
        lines += damping_report.text_section(result.damping)
    lines += ["", "warnings"] + ([f"  - {w}" for w in result.warnings] or ["  none"])
    return "\n".join(lines) + "\n"


def fit_sections(
    result, parameters: pd.DataFrame | None = None, residuals: pd.DataFrame | None = None
) -> list[tuple[str, str]]:
    """The (heading, HTML) sections of a fit, as report.html and the notebook view show
    them: likely causes, parameters, budget, statistics, residuals, warnings."""
    parameters = parameter_table(result) if parameters is None else parameters
    residuals = fit_residuals(result) if residuals is None else residuals
    st, u = result.statistics, result.uncertainty
    statistics = pd.DataFrame(
        {
            "quantity": [
                "measured frequencies",
                "configurations",
                "unknown parameters",
                "iterations",
                "RMS relative error [%]",
                "misfit / scatter",
                "chi^2 test p-value",
                "scatter from",
                "condition number",
                "verdict",
            ],
            "value": [
                str(st.n),
                str(len(result.measurements.configurations)),
                str(st.k),
                str(result.iterations),
                percent(st.rms_rel_error, 3).removesuffix(" %"),
                f"{st.misfit_over_scatter:.3g}",
                f"{st.p_value:.3g}",
                st.noise_source,
                f"{u.condition_number:.3g}",
                u.verdict,
            ],
        }
    )
    sections = []
    if result.causes:
        sections.append(
            ("Likely causes", h.notes(f"{100 * c.score:.0f} %: {c.kind}: {c.text}" for c in result.causes))
        )
    sections += [("Parameters (value ± 1 std)", h.table(shown_parameters(parameters)))]
    if result.budget is not None:
        sections.append(
            (
                "Uncertainty budget",
                '<p class="small">each known input\'s and the measurement '
                "scatter's share of each parameter's std (display units); total = the std above</p>"
                + h.table(result.budget.table(), "{:.3g}"),
            )
        )
    sections += [
        ("Statistics", h.table(statistics)),
        (
            "Residuals and pairing",
            '<p class="small">mode: the model mode each measured frequency is paired '
            "with; label: its nodal pattern; error_%: (model - measured) / measured in %</p>"
            + h.table(shown_residuals(residuals)),
        ),
        *(
            [
                (
                    "Damping",
                    h.notes([f"{result.damping.status}: {result.damping.message}", *result.damping.notes])
                    + h.table(result.damping.residuals.drop(columns="weight"), "{:.4g}"),
                )
            ]
            if result.damping is not None
            else []
        ),
        ("Warnings and notes", h.notes(result.warnings)),
    ]
    return sections


def fit_view(result) -> str:
    """The notebook view of a fit (``FitResult._repr_html_``): its status and sections."""
    return h.view(
        f"Layer identification: {result.specimen.name}",
        (result.status.value, result.message, result.converged),
        fit_sections(result),
    )


def write_report(result, folder: str | Path) -> Path:
    """A report folder (written whole or not at all, see ``fem.io.report_folder``):
    report.html (self-contained), report.txt, parameters.csv, fit.json, residuals.csv,
    history.csv and the figures (and the error per mode before and after the effects when
    they were free)."""
    with report_folder(folder) as tmp:
        _write_report_files(result, tmp)
    return Path(folder)


def _write_report_files(result, folder: Path) -> None:
    write_text(folder / "report.txt", report_text(result))
    parameters = parameter_table(result)
    write_text(folder / "parameters.csv", parameters.to_csv(index=False))
    residuals = fit_residuals(result)
    write_text(folder / "fit.json", to_json(to_dict(result)))
    write_text(folder / "residuals.csv", residuals.to_csv(index=False))
    write_text(folder / "history.csv", history_table(result).to_csv(index=False))
    figures = [
        (
            plot_residuals(result, folder / "residuals.png"),
            "error per measured mode (model - measured), with the measurement std as bars",
        ),
        (plot_convergence(result, folder / "convergence.png"), "parameters and misfit against iteration"),
        (
            plot_mode_shapes(result, folder / "mode_shapes.png"),
            "the model's paired mode shapes (deflection, nodal lines in black)",
        ),
    ]
    figures += shape_figures(
        fit_correlations(result), solving_model(result.model, result.measurements), folder
    )
    if result.baseline is not None:
        kinds = ", ".join(sorted(set(result.effect_of.values()))) or "effects"
        write_text(
            folder / "before_after.csv", before_after_table(result.baseline, result).to_csv(index=False)
        )
        figures.append(
            (
                plot_before_after(result.baseline, result, kinds, folder / "before_after.png"),
                f"error per mode without and with {kinds}",
            )
        )
    if result.damping is not None:
        write_text(folder / "damping.csv", result.damping.residuals.to_csv(index=False))
        figures.append(
            (
                damping_report.plot_damping(result.damping, folder / "damping.png"),
                "modal loss factors per configuration: measured (1 std bars) and model",
            )
        )
    sections = fit_sections(result, parameters, residuals)
    sections.insert(-1, ("Figures", "".join(h.figure(path, caption) for path, caption in figures)))
    header = h.provenance(
        "identification (identify-layers fit)",
        result.specimen.name,
        result.model.source,
        result.measurements.source,
    )
    page = h.document(
        f"Layer identification: {result.specimen.name}",
        header,
        (result.status.value, result.message, result.converged),
        sections,
    )
    write_text(folder / "report.html", page)


def shape_figures(correlations: dict, solver, folder: Path, shape_map=None) -> list[tuple[Path, str]]:
    """The measured shapes' figures (none without shapes): MAC matrices, nodal lines,
    the maps of where the shapes disagree and, when given, where a point mass would
    explain them (``shape_map``), drawn into ``folder``."""
    if not correlations:
        return []
    specimen = solver.specimen
    solutions = {name: solver.solve(name) for name in correlations}
    out = [
        (
            plot_mac_matrices(correlations, folder / "mac_matrix.png"),
            "MAC of each measured shape with each model mode (the pairing used outlined)",
        ),
        (
            plot_nodal_lines(correlations, solutions, folder / "nodal_lines.png"),
            "model mode shapes with their nodal lines (black) and the measured nodal lines (dashed red)",
        ),
        (
            plot_shape_maps(correlations, specimen.length, specimen.width, folder / "shape_maps.png"),
            "where on the plate the shapes disagree: shape residual and COMAC at the points measured",
        ),
    ]
    if shape_map is not None:
        out.append(
            (
                plot_shape_point_map(
                    shape_map,
                    correlations,
                    specimen.length,
                    specimen.width,
                    folder / "shape_point_mass_map.png",
                ),
                "share of the shapes' residual a point mass would explain at each point of the plate",
            )
        )
    return out


@dataclass(frozen=True)
class AnalysisReport:
    """What a compare or diagnose report shows: the page's ``title``; its provenance header
    names the ``analysis``, the ``model``'s specimen and the sources of the ``model`` and
    the ``measurements``; ``text`` is its body, ``files`` (name -> content) are written
    beside it, each of the ``figures`` (callable(path) -> path, file name, caption) is
    drawn by its callable into the file named, and a ``comparison`` that has measured
    shapes adds their figures (``shape_figures``)."""

    title: str
    analysis: str
    model: object
    measurements: object
    text: str
    files: dict[str, str]
    figures: list[tuple[Callable[[Path], Path], str, str]]
    comparison: object = None


def write_analysis_report(folder: str | Path, report: AnalysisReport) -> Path:
    """A compare or diagnose report folder, written whole or not at all: the report's
    ``text`` as the body of report.html (with the provenance header and the figures
    embedded), its files and figures beside it."""
    comparison, model = report.comparison, report.model
    with report_folder(folder) as tmp:
        for name, content in report.files.items():
            write_text(tmp / name, content)
        drawn = [(draw(tmp / name), caption) for draw, name, caption in report.figures]
        if comparison is not None and comparison.shapes:
            drawn += shape_figures(comparison.shapes, comparison.solver, tmp, comparison.shape_map)
        header = h.provenance(report.analysis, model.specimen.name, model.source, report.measurements.source)
        sections = [
            ("Report", f"<pre>{html.escape(report.text)}</pre>"),
            ("Figures", "".join(h.figure(path, caption) for path, caption in drawn)),
        ]
        write_text(tmp / "report.html", h.document(report.title, header, None, sections))
    return Path(folder)
