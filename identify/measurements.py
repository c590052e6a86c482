"""Measured resonance frequencies (CSV), validated against the spec they belong to.

Format (see the measurement CSV in the docs): ``configuration,mode,frequency_hz,std_hz``
with ``mode`` (1-based rank among the elastic modes) and ``std_hz`` optional.  An optional
``label`` column names a mode's nodal pattern as the model prints it, e.g. ``(1,2)``; when
given it fixes which model mode a measured one is paired with.  ``damping_ratio`` (zeta,
the modal loss factor is 2 zeta) and its standard uncertainty ``damping_std`` (same unit)
may be given, as ``identify-layers peaks`` writes them: a damping identification uses
them.

Without ``mode`` the file is a peak list, as recordings give it: some modes missing,
some peaks spurious.  Its rows get mode 0 (no rank) and the fit matches them to model
modes itself (``identify.engine.matching``).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd

from fem.errors import MeasurementError
from fem.model import SpecimenModel
from fem.solver.mode_shapes import pattern
from fem.validation import suggestion

REQUIRED = ("configuration", "frequency_hz")
OPTIONAL = ("mode", "std_hz", "label", "damping_ratio", "damping_std")
#: The mode number of a peak that has no rank yet (a peak list).
UNRANKED = 0
MAX_MODE = 60


@dataclass(frozen=True)
class ModeShape:
    """One measured mode's shape: the deflection at points of the plate (roving hammer,
    laser vibrometer), any common scale and sign.  ``xy`` [m] from the plate's corner at
    the origin, x along its length; ``amplitude`` complex, one per point."""

    configuration: str
    frequency_hz: float
    xy: np.ndarray
    amplitude: np.ndarray


@dataclass(frozen=True)
class MeasuredShapes:
    """The shapes measured for some peaks, each named by its peak's frequency."""

    shapes: tuple[ModeShape, ...]
    source: str = "<shapes>"

    def of(self, configuration: str, frequency_hz: float) -> ModeShape | None:
        """The shape measured at this peak (its frequency as the measurements hold it), or None."""
        for shape in self.shapes:
            if (
                shape.configuration == configuration
                and abs(shape.frequency_hz - frequency_hz) <= 1e-9 * frequency_hz
            ):
                return shape
        return None


@dataclass(frozen=True)
class Measurements:
    """A validated table: one row per measured frequency, sorted by configuration
    (spec order) and mode (peak lists: by frequency).  Columns: configuration, mode
    (``UNRANKED`` in a peak list), frequency_hz, std_hz (NaN when not given), label
    (empty when not given), damping_ratio and damping_std (NaN when not given); the
    measured mode shapes of some rows, when given (``shapes``)."""

    table: pd.DataFrame
    source: str = "<measurements>"
    shapes: MeasuredShapes | None = None

    @cached_property
    def has_std(self) -> bool:
        """Every row has its std_hz (cached: the fit's residuals ask at every evaluation,
        and the pandas check cost 0.8 ms, 3 % of a long plate's diagnosis)."""
        return bool(self.table["std_hz"].notna().all())

    @property
    def ranked(self) -> bool:
        """Every row has its mode number (else a peak list the fit matches itself)."""
        return bool((self.table["mode"] != UNRANKED).all())

    def rows(self, index) -> Measurements:
        """The measurements of these rows (positions), renumbered."""
        return replace(self, table=self.table.iloc[list(index)].reset_index(drop=True))

    @property
    def configurations(self) -> list[str]:
        return list(dict.fromkeys(self.table["configuration"]))

    def of(self, configuration: str) -> pd.DataFrame:
        return self.table[self.table["configuration"] == configuration]

    def __len__(self) -> int:
        return len(self.table)

    @property
    def pinned(self) -> np.ndarray:
        """Per row: its mode is pinned by a label or a measured shape, not by frequency alone."""
        return np.array(
            [
                bool(label) or shape is not None
                for label, shape in zip(self.table["label"], self.shapes_of(self.table))
            ],
            dtype=bool,
        )

    def shapes_of(self, rows: pd.DataFrame) -> list[ModeShape | None]:
        """The measured shape of each of these rows (None where there is none)."""
        if self.shapes is None:
            return [None] * len(rows)
        return [self.shapes.of(c, f) for c, f in zip(rows["configuration"], rows["frequency_hz"])]


def _fail(source: str, message: str) -> MeasurementError:
    return MeasurementError(f"{source}: {message}")


def checked_columns(
    frame: pd.DataFrame, required, optional, source: str, what_rows: str
) -> tuple[pd.DataFrame, np.ndarray]:
    """A copy of a raw table with its column names stripped, every column known and the
    required ones there, and its CSV line numbers (the header is line 1); ``what_rows``
    tells an empty table what to give."""
    frame = frame.copy()
    frame.columns = [str(c).strip() for c in frame.columns]
    for column in frame.columns:
        if column not in required + optional:
            raise _fail(source, f"unknown column '{column}'; {suggestion(column, required + optional)}")
    for column in required:
        if column not in frame.columns:
            raise _fail(source, f"missing column '{column}' (need {', '.join(required)})")
    if frame.empty:
        raise _fail(source, f"no rows: {what_rows}")
    return frame, frame.index.to_numpy() + 2


def parse_measurements(
    frame: pd.DataFrame, model: SpecimenModel, source: str = "<measurements>"
) -> Measurements:
    """Validate a raw table against the model's configurations; rows are reported by CSV
    line number.  ``frame``: a data frame, or what makes one (a list of row dicts, a
    dict of columns)."""
    if not isinstance(frame, pd.DataFrame):
        try:
            frame = pd.DataFrame(frame)
        except (TypeError, ValueError) as exc:
            raise _fail(
                source,
                f"need a table (a data frame, a list of row dicts or a dict of columns), not "
                f"{type(frame).__name__}: {exc}",
            ) from None
    frame, line = checked_columns(frame, REQUIRED, OPTIONAL, source, "give at least one measured frequency")

    known = [c.name for c in model.specimen.configurations]
    for i, name in enumerate(frame["configuration"]):
        if pd.isna(name) or str(name).strip() not in known:
            raise _fail(
                source,
                f"line {line[i]}: configuration = {name!r} is not in the spec; "
                f"{suggestion(name, known).replace('allowed:', 'the spec has:')}",
            )
    frame["configuration"] = frame["configuration"].map(lambda s: str(s).strip())

    frequency = pd.to_numeric(frame["frequency_hz"], errors="coerce")
    for i, (raw, f) in enumerate(zip(frame["frequency_hz"], frequency)):
        if not np.isfinite(f):
            raise _fail(
                source, f"line {line[i]}: frequency_hz = {raw!r} is not a number; give the frequency in Hz"
            )
        if f <= 0:
            raise _fail(source, f"line {line[i]}: frequency_hz = {f:g} must be positive")
    frame["frequency_hz"] = frequency.astype(float)

    if "std_hz" in frame.columns:
        std = pd.to_numeric(frame["std_hz"], errors="coerce")
        given = std.notna()
        if given.any() and not given.all():
            i = int(np.flatnonzero(~given.to_numpy())[0])
            raise _fail(source, f"line {line[i]}: std_hz is missing; give it for every row or for none")
        for i, s in enumerate(std):
            if given.all() and not (np.isfinite(s) and s > 0):
                raise _fail(source, f"line {line[i]}: std_hz = {s!r} must be a positive number of Hz")
        frame["std_hz"] = std.astype(float)
    else:
        frame["std_hz"] = np.nan

    if "mode" in frame.columns:
        mode = pd.to_numeric(frame["mode"], errors="coerce")
        for i, (raw, m) in enumerate(zip(frame["mode"], mode)):
            if not (np.isfinite(m) and m == int(m) and 1 <= m <= MAX_MODE):
                raise _fail(
                    source, f"line {line[i]}: mode = {raw!r}: need the elastic mode's rank, 1 to {MAX_MODE}"
                )
        frame["mode"] = mode.astype(int)
    else:
        frame["mode"] = UNRANKED
    if "damping_ratio" in frame.columns:
        damping = pd.to_numeric(frame["damping_ratio"], errors="coerce")
        for i, (raw, d) in enumerate(zip(frame["damping_ratio"], damping)):
            if not pd.isna(raw) and not (np.isfinite(d) and 0 < d < 0.5):
                raise _fail(
                    source,
                    f"line {line[i]}: damping_ratio = {raw!r}: need a ratio above 0 and below 0.5 (0.01 for "
                    "1 %), "
                    "or leave it empty",
                )
        frame["damping_ratio"] = damping.astype(float)
    else:
        frame["damping_ratio"] = np.nan
    if "damping_std" in frame.columns:
        damping_std = pd.to_numeric(frame["damping_std"], errors="coerce")
        for i, (raw, s, d) in enumerate(zip(frame["damping_std"], damping_std, frame["damping_ratio"])):
            if pd.isna(raw):
                continue
            if not (np.isfinite(s) and s > 0):
                raise _fail(
                    source,
                    f"line {line[i]}: damping_std = {raw!r}: need a positive std of the damping ratio "
                    "(0.0003 for 3 % of 0.01), or leave it empty",
                )
            if pd.isna(d):
                raise _fail(
                    source,
                    f"line {line[i]}: damping_std = {raw!r} without a damping_ratio; give both or neither",
                )
        frame["damping_std"] = damping_std.astype(float)
    else:
        frame["damping_std"] = np.nan
    frame["label"] = (
        frame["label"].map(lambda v: "" if pd.isna(v) else str(v).strip()) if "label" in frame.columns else ""
    )
    for i, label in enumerate(frame["label"]):
        if label and pattern(label) is None:
            raise _fail(
                source,
                f"line {line[i]}: label = {label!r} is not a nodal pattern; write it as predict "
                'prints it, e.g. "(1,2)" or "(0,2)+(2,0)" (quoted in the CSV), or leave it empty',
            )

    duplicated = frame.duplicated(["configuration", "mode"], keep=False) & (frame["mode"] != UNRANKED)
    if duplicated.any():
        rows = frame[duplicated]
        raise _fail(
            source,
            f"lines {', '.join(map(str, line[duplicated.to_numpy()]))}: configuration "
            f"{rows['configuration'].iloc[0]!r} mode {rows['mode'].iloc[0]} is given more than once",
        )
    peaks = frame[frame["mode"] == UNRANKED].groupby("configuration", sort=False).size()
    if (peaks > MAX_MODE).any():
        raise _fail(
            source,
            f"configuration {peaks.idxmax()!r} has {peaks.max()} peaks without mode numbers; at most "
            f"{MAX_MODE} can be matched to model modes: keep the strongest peaks of the band you fit (e.g. "
            "peaks --band LOW HIGH)",
        )
    frame["_order"] = frame["configuration"].map({name: i for i, name in enumerate(known)})
    frame = frame.sort_values(["_order", "mode", "frequency_hz"], kind="stable").drop(columns="_order")
    frame = frame.reset_index(drop=True)
    for name, group in frame.groupby("configuration", sort=False):
        f = group["frequency_hz"].to_numpy()
        bad = np.flatnonzero(np.diff(f) < 0)
        if bad.size:
            a, b = group.iloc[bad[0]], group.iloc[bad[0] + 1]
            raise _fail(
                source,
                f"configuration {name!r}: mode {b['mode']} ({b['frequency_hz']:g} Hz) is below mode "
                f"{a['mode']} ({a['frequency_hz']:g} Hz); mode numbers are ranks, so frequencies must rise",
            )
    columns = ["configuration", "mode", "frequency_hz", "std_hz", "label", "damping_ratio", "damping_std"]
    return Measurements(frame[columns], source)


def read_table(path: str | Path, what: str) -> pd.DataFrame:
    """A UTF-8 CSV file as a data frame (``#`` comments skipped), or a one-line error
    naming the file (``what``: "measurement file", "shape file", ...)."""
    path = Path(path)
    where = f"{what} {str(path)!r}"
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MeasurementError(f"{where} does not exist") from None
    except IsADirectoryError:
        raise MeasurementError(f"{where} is a folder; give the CSV file") from None
    except OSError as exc:
        raise MeasurementError(f"{where} cannot be read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise MeasurementError(
            f"{where} is not UTF-8 text (a binary file, or saved as UTF-16?): save it as a UTF-8 CSV"
        ) from None
    _check_field_counts(text, where)
    try:
        return pd.read_csv(io.StringIO(text), skipinitialspace=True, comment="#", index_col=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise MeasurementError(f"{where} is not a readable CSV: {exc}") from None


def load_measurements(path: str | Path, model: SpecimenModel) -> Measurements:
    """Read a measurement CSV and validate it against the model's configurations.

    The file is UTF-8 CSV (``#`` lines are comments) with one row per measured frequency
    [Hz]; every row's configuration must be one of the model's, and rows are reported by
    their line number in the file.

    Parameters
    ----------
    path : str or pathlib.Path
        The measurement CSV.
    model : SpecimenModel
        The model the measurements are checked against (``fem.load_spec``).

    Returns
    -------
    Measurements
        The validated table (frequencies in Hz).

    Raises
    ------
    MeasurementError
        The file does not exist, cannot be read or is not UTF-8 text, or a row does not
        match the header or the model's configurations.

    Examples
    --------
    >>> import identify
    >>> from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
    >>> model = identify.load_spec(COATED_PLATE)
    >>> data = identify.load_measurements(COATED_PLATE_MEASURED, model)
    >>> data.configurations, len(data.table)
    (['original', 'brass_bottom', 'brass_top'], 15)
    """
    return parse_measurements(read_table(path, "measurement file"), model, str(path))


def _check_field_counts(text: str, where: str) -> None:
    """Every data row has as many fields as the header; an unquoted label like (1,2)
    splits in two, so say how to write it."""
    rows = [
        (n, row)
        for n, row in enumerate(csv.reader(io.StringIO(text)), 1)
        if row and not row[0].lstrip().startswith("#")
    ]
    if not rows:
        raise MeasurementError(f"{where} is empty: give a header line and one row per measured value")
    width = len(rows[0][1])
    for n, row in rows[1:]:
        if len(row) > width:
            raise MeasurementError(
                f"{where}: line {n} has {len(row)} fields for the header's {width}; a label with a "
                'comma must be quoted, e.g. "(1,2)"'
            )
