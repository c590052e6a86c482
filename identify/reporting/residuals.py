"""The residual rows of a fit or a comparison: measured against model per configuration
and mode.  Formats what it is handed (a fit result, duck-typed: ``peaks``,
``measurements``, ``model_hz``, ``pairings``, ``model``); imports no result module."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..engine.objective import solving_model
from ..engine.pairing import ShapeCorrelation, shape_correlation
from ..engine.peak_assignment import peak_table
from ..measurements import MeasuredShapes, Measurements


def residual_table(measurements: Measurements, model_hz: np.ndarray) -> pd.DataFrame:
    """Per measured mode: measured and model frequency, relative error, error / std."""
    table = measurements.table
    out = pd.DataFrame(
        {
            "configuration": table["configuration"],
            "mode": table["mode"],
            "measured_hz": table["frequency_hz"],
            "model_hz": model_hz,
            "rel_error": model_hz / table["frequency_hz"] - 1,
        }
    )
    if measurements.has_std:
        out["error_over_std"] = (out["model_hz"] - out["measured_hz"]) / table["std_hz"]
    return out


def fit_residuals(result) -> pd.DataFrame:
    """The residual rows of a fit (``fit --json`` "residuals"): every measured frequency with the model
    mode it is paired with (1-based), measured and model frequency, relative error,
    matched, and a note (a peak left out has None for mode, model frequency and error,
    and its note says why, naming the nearest mode); ranked data also
    keep the rank given (``measured_mode``) and the error in std when std_hz is given;
    with measured shapes, each shape's MAC with its paired mode (``mac``)."""
    out = _paired_rows(result)
    out.insert(2, "label", _model_labels(result, out))
    return with_macs(out, _correlations(result, out))


def _paired_rows(result) -> pd.DataFrame:
    """The residual rows of a fit before the model modes' labels and the shapes' MACs."""
    if result.peaks is not None:
        out = peak_table(result.peaks)
    else:
        table = result.measurements.table
        configs = table["configuration"].to_numpy()
        modes = np.zeros(len(table), dtype=int)
        for name, pairing in result.pairings.items():
            modes[configs == name] = pairing.indices + 1
        out = residual_table(result.measurements, result.model_hz)
        out.insert(1, "measured_mode", out.pop("mode"))
        out.insert(1, "mode", modes)
        out["matched"] = True
        out["note"] = ""
    return out


def shape_correlations(
    model, measurements: Measurements, rows: pd.DataFrame, shapes: MeasuredShapes | None
) -> dict[str, ShapeCorrelation]:
    """Per configuration, the measured ``shapes`` against the modes of ``model`` as the
    fit of ``measurements`` solves it, each shape's peak paired as the residual ``rows``
    say (``mode``: the model mode, 1-based; None or 0 for a peak left out)."""
    if shapes is None:
        return {}
    solver = solving_model(model, measurements)
    out = {}
    for name in dict.fromkeys(rows["configuration"]):
        mine = rows[rows["configuration"] == name]
        found = [(shapes.of(name, f), m) for f, m in zip(mine["measured_hz"], mine["mode"])]
        found = [
            (shape, int(m) - 1 if m is not None and not pd.isna(m) and m > 0 else -1)
            for shape, m in found
            if shape is not None
        ]
        if found:
            solution = solver.solve(name)
            paired = np.array([m if m < len(solution.frequencies_hz) else -1 for _, m in found])
            out[name] = shape_correlation(solution, [shape for shape, _ in found], paired)
    return out


def with_macs(rows: pd.DataFrame, correlations: dict[str, ShapeCorrelation]) -> pd.DataFrame:
    """The residual rows with a ``mac`` column (each measured shape's MAC with its paired
    model mode; None where the peak has no shape or was left out), when shapes were given."""
    if not correlations:
        return rows
    macs = {
        (c.configuration, f): m for c in correlations.values() for f, m in zip(c.measured_hz, c.paired_mac)
    }
    out = rows.copy()
    out["mac"] = [
        None if pd.isna(m := macs.get((name, f), np.nan)) else float(m)
        for name, f in zip(rows["configuration"], rows["measured_hz"])
    ]
    return out


def fit_correlations(result) -> dict[str, ShapeCorrelation]:
    """The shape correlations of a fit (duck-typed result), {} without measured shapes."""
    return _correlations(result, _paired_rows(result))


def _correlations(result, rows: pd.DataFrame) -> dict[str, ShapeCorrelation]:
    measurements = result.peaks.measurements if result.peaks is not None else result.measurements
    return shape_correlations(result.model, result.measurements, rows, measurements.shapes)


def _model_labels(result, rows: pd.DataFrame) -> list[str]:
    """The nodal pattern of the model mode each residual row is paired with ('' when
    left out)."""
    solver = solving_model(result.model, result.measurements)
    labels = {c: solver.solve(c).labels for c in result.measurements.configurations}
    out = []
    for name, mode in zip(rows["configuration"], rows["mode"]):
        known = labels.get(name, ())
        out.append(
            known[int(mode) - 1] if mode is not None and not pd.isna(mode) and 0 < mode <= len(known) else ""
        )
    return out


def _row_errors(result) -> tuple[pd.DataFrame, np.ndarray]:
    """The measured rows a result speaks of (for a peak list: every peak, matched or
    not) and the relative error per row (object array, None for a peak left out)."""
    if result.peaks is not None:
        table = result.peaks.measurements.table
        error = result.peaks.model_hz / table["frequency_hz"].to_numpy() - 1
        return table, np.array(
            [e if m else None for e, m in zip(error, result.peaks.matched, strict=True)], dtype=object
        )
    return result.measurements.table, result.rel_error.astype(object)


def before_after_table(before, after) -> pd.DataFrame:
    """Relative error per measured row without and with the effects switched on.  For a
    peak list the rows are the peaks (the two fits may match different ones: a peak left
    out by one has None there); ``mode`` is the rank given, or for a peak the mode it is
    matched to after the effects."""
    table, error_before = _row_errors(before)
    _, error_after = _row_errors(after)
    if after.peaks is not None:
        modes = pd.Series([int(m) if m > 0 else None for m in after.peaks.modes], dtype=object)
    else:
        modes = table["mode"].to_numpy()
    return pd.DataFrame(
        {
            "configuration": table["configuration"].to_numpy(),
            "mode": modes,
            "measured_hz": table["frequency_hz"].to_numpy(),
            "rel_error_before": error_before,
            "rel_error_after": error_after,
        }
    )


__all__ = [
    "before_after_table",
    "fit_correlations",
    "fit_residuals",
    "residual_table",
    "shape_correlations",
    "with_macs",
]
