"""Measured mode shapes (CSV), validated against the spec and the measured peaks.

Format (see the shape CSV in the docs): ``configuration, frequency_hz, x_mm, y_mm,
amplitude`` and optionally ``amplitude_imag``, one row per mode and point, as a
roving-hammer or laser-vibrometer test gives them.  ``frequency_hz`` names the measured
peak (as written in the measurement file, to ``PEAK_MATCH`` or better); points are in the
spec's plate coordinates, from the corner at the origin, as for a point mass; amplitudes
are in any common scale and sign per mode.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from fem.errors import MeasurementError
from fem.model import SpecimenModel
from fem.validation import suggestion

from .measurements import MeasuredShapes, Measurements, ModeShape, checked_columns, read_table

REQUIRED = ("configuration", "frequency_hz", "x_mm", "y_mm", "amplitude")
OPTIONAL = ("amplitude_imag",)
#: A shape names its peak by frequency to this relative tolerance (the contract's 0.1 %).
PEAK_MATCH = 1e-3
#: Fewest points of a shape: with fewer, any two shapes look alike (a MAC of two points
#: is 1 for every pair of modes whose two values have the same ratio).
MIN_POINTS = 4
#: Points may lie this far outside the plate [m] (a grid point on the edge, rounded).
EDGE_SLACK = 1e-3
#: All points within this fraction of the plate's size from the origin: coordinates
#: written in metres where millimetres were asked for.
UNIT_SLIP = 0.02


def _fail(source: str, message: str) -> MeasurementError:
    return MeasurementError(f"{source}: {message}")


def _numbers(frame: pd.DataFrame, column: str, source: str, line: np.ndarray) -> np.ndarray:
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise _fail(source, f"line {line[bad[0]]}: {column} = {frame[column].iloc[bad[0]]!r} is not a number")
    return values


def _peak(
    measurements: Measurements, configuration: str, frequency_hz: float, source: str, line: int
) -> float:
    """The measured peak a shape names: its frequency as the measurements hold it."""
    peaks = measurements.of(configuration)["frequency_hz"].to_numpy()
    nearest = peaks[np.argmin(np.abs(peaks - frequency_hz))]
    if abs(nearest / frequency_hz - 1) > PEAK_MATCH:
        raise _fail(
            source,
            f"line {line}: frequency_hz = {frequency_hz:g} names no measured peak of {configuration!r} "
            f"(the nearest is {nearest:g} Hz; a shape names its peak to {PEAK_MATCH:.1%}): write the peak's "
            "frequency as the measurement file has it",
        )
    return float(nearest)


def _shape(
    group: pd.DataFrame, model: SpecimenModel, source: str, line: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Points [m] and complex amplitudes of one mode's rows, checked."""
    where = f"lines {line[0]}-{line[-1]}"
    if len(group) < MIN_POINTS:
        raise _fail(
            source,
            f"{where}: {len(group)} points; a shape needs at least {MIN_POINTS} to be told from "
            "another mode's",
        )
    xy = 1e-3 * group[["x_mm", "y_mm"]].to_numpy()
    length, width = model.specimen.length, model.specimen.width
    outside = (
        (xy[:, 0] < -EDGE_SLACK)
        | (xy[:, 0] > length + EDGE_SLACK)
        | (xy[:, 1] < -EDGE_SLACK)
        | (xy[:, 1] > width + EDGE_SLACK)
    )
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise _fail(
            source,
            f"line {line[k]}: point ({1e3 * xy[k, 0]:g}, {1e3 * xy[k, 1]:g}) mm lies outside the "
            f"{1e3 * length:g} x {1e3 * width:g} mm plate; points are measured from its corner at the "
            "origin, "
            "x along its length",
        )
    xy = np.clip(xy, 0.0, [length, width])
    if np.all(xy[:, 0] <= UNIT_SLIP * length) and np.all(xy[:, 1] <= UNIT_SLIP * width):
        raise _fail(
            source,
            f"{where}: every point lies within {UNIT_SLIP:.0%} of the corner (largest x_mm "
            f"{1e3 * xy[:, 0].max():g}): coordinates in metres? x_mm and y_mm are millimetres",
        )
    _, first = np.unique(np.round(xy, 6), axis=0, return_index=True)
    if len(first) < len(xy):
        k = int(np.setdiff1d(np.arange(len(xy)), first)[0])
        raise _fail(
            source,
            f"line {line[k]}: point ({1e3 * xy[k, 0]:g}, {1e3 * xy[k, 1]:g}) mm is given twice for this mode",
        )
    amplitude = group["amplitude"].to_numpy() + 1j * group["amplitude_imag"].to_numpy()
    if not np.any(amplitude):
        raise _fail(source, f"{where}: every amplitude is zero")
    return xy, amplitude


def parse_shapes(
    frame: pd.DataFrame, model: SpecimenModel, measurements: Measurements, source: str = "<shapes>"
) -> MeasuredShapes:
    """Validate a raw shape table against the spec and the measured peaks; rows are
    reported by CSV line number."""
    frame, line = checked_columns(frame, REQUIRED, OPTIONAL, source, "give one row per mode and point")
    known = measurements.configurations
    for i, name in enumerate(frame["configuration"]):
        if pd.isna(name) or str(name).strip() not in known:
            raise _fail(
                source,
                f"line {line[i]}: configuration = {name!r} has no measured peaks; "
                f"{suggestion(name, known).replace('allowed:', 'the measurements have:')}",
            )
    frame["configuration"] = frame["configuration"].map(lambda s: str(s).strip())
    for column in ("frequency_hz", "x_mm", "y_mm", "amplitude"):
        frame[column] = _numbers(frame, column, source, line)
    frame["amplitude_imag"] = (
        _numbers(frame, "amplitude_imag", source, line) if "amplitude_imag" in frame else 0.0
    )
    frame["_line"] = line
    shapes, named = [], {}
    for (name, frequency), group in frame.groupby(["configuration", "frequency_hz"], sort=False):
        rows = group["_line"].to_numpy()
        peak = _peak(measurements, name, frequency, source, int(rows[0]))
        if (name, peak) in named:
            raise _fail(
                source,
                f"line {rows[0]}: frequency_hz = {frequency:g} and {named[name, peak]:g} name the same "
                f"peak of {name!r} ({peak:g} Hz); give one shape per peak",
            )
        named[name, peak] = frequency
        xy, amplitude = _shape(group, model, source, rows)
        shapes.append(ModeShape(name, peak, xy, amplitude))
    return MeasuredShapes(tuple(shapes), source)


def shapes_frame(shapes: MeasuredShapes) -> pd.DataFrame:
    """The shapes as the shape CSV holds them (one row per mode and point, mm)."""
    return pd.DataFrame(
        [
            {
                "configuration": s.configuration,
                "frequency_hz": s.frequency_hz,
                "x_mm": 1e3 * x,
                "y_mm": 1e3 * y,
                "amplitude": a.real,
                "amplitude_imag": a.imag,
            }
            for s in shapes.shapes
            for (x, y), a in zip(s.xy, s.amplitude)
        ]
    )


def load_shapes(path: str | Path, model: SpecimenModel, measurements: Measurements) -> Measurements:
    """The measurements with the shapes of a shape CSV attached."""
    shapes = parse_shapes(read_table(path, "shape file"), model, measurements, str(path))
    return replace(measurements, shapes=shapes)


__all__ = ["load_shapes", "parse_shapes", "shapes_frame", "PEAK_MATCH"]
