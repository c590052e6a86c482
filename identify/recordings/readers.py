"""Impact-test recordings (CSV, WAV, UFF type 58, MATLAB .mat, NI TDMS) read into hits,
validated at the entry.

A *hit* is one tap: the force and the response sampled at one rate, in the recording's
own (arbitrary) units.  A UFF58 FRF record (function type 4) is already averaged by the
acquisition and is kept as a :class:`MeasuredFRF`; a UFF58 pair of time records
(function type 1: excitation force and response) is a hit.  Several files are several
hits on one configuration, unless their FRF records measure several nodes: then they are
a multi-point test (:func:`read_uff_points`: each node's FRFs and its coordinates, for
the mode shapes).

Every problem is one line of :class:`fem.errors.MeasurementError` naming the file, the
field and value, what is allowed and a fix.
"""

from __future__ import annotations

import difflib
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from fem.errors import MeasurementError

RESPONSE_COLUMNS = ("acceleration", "velocity", "displacement", "response")
CSV_COLUMNS = ("time_s", "force") + RESPONSE_COLUMNS
MIN_SAMPLES = 256
#: Relative disagreement allowed between a stated sample rate and the time column's.
RATE_TOLERANCE = 1e-4
#: Lowest sample rate [Hz] a plate's modes can be recorded at (a 150 mm plate's first mode
#: lies near 100 Hz); below it a time column is in ms, or the rate is mistyped.
MIN_SAMPLE_RATE = 500.0
#: UFF58 specific data types (ordinate): response quantity by code, and the force codes.
UFF_RESPONSE = {8: "displacement", 11: "velocity", 12: "acceleration"}
UFF_FORCE = (9, 13)
UFF_TIME, UFF_FRF = 1, 4
#: UFF58 function types a multi-point export carries beside its FRFs and the shapes do
#: not use: auto and cross spectra, coherence (skipped, and said so).
UFF_BESIDE_FRFS = {2: "auto spectrum", 3: "cross spectrum", 6: "coherence"}


@dataclass(frozen=True)
class Hit:
    """One tap: ``force`` (None for a response-only WAV) and ``response`` samples at
    ``sample_rate`` [Hz]; ``quantity`` names the response (acceleration, velocity,
    displacement or response)."""

    source: str
    sample_rate: float
    response: np.ndarray
    force: np.ndarray | None = None
    quantity: str = "acceleration"

    @property
    def duration_s(self) -> float:
        return len(self.response) / self.sample_rate


@dataclass(frozen=True)
class MeasuredFRF:
    """An FRF averaged by the acquisition: ``frf`` (complex, response / force) on the
    evenly spaced ``frequency_hz`` [Hz]."""

    source: str
    frequency_hz: np.ndarray
    frf: np.ndarray
    quantity: str = "acceleration"


Recording = Hit | MeasuredFRF


def _fail(source, message: str) -> MeasurementError:
    return MeasurementError(f"{source}: {message}")


def _check_samples(source, name: str, values: np.ndarray, first_line: int = 0) -> np.ndarray:
    """Finite float samples, at least MIN_SAMPLES of them; ``first_line`` > 0 numbers CSV lines."""
    values = np.asarray(values, dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        where = f"line {bad[0] + first_line}: " if first_line else f"sample {bad[0]}: "
        raise _fail(
            source,
            f"{where}{name} = {values[bad[0]]} is not a finite number ({bad.size} such samples); "
            "remove or re-export the damaged samples",
        )
    if len(values) < MIN_SAMPLES:
        raise _fail(
            source,
            f"{name} has {len(values)} samples, need at least {MIN_SAMPLES}; "
            "record the whole hit (about 2 s)",
        )
    return values


#: Values of a printed column read to find its format (digits, decimals).
FORMAT_SAMPLE = 2000
#: Jitter of the time column accepted beyond its printed precision, as a fraction of a step.
STEP_JITTER = 1e-3


def printed_quantum(text: pd.Series, value: np.ndarray) -> np.ndarray:
    """The resolution of each number ``value`` of a printed column (a unit of its last
    digit): the finer of the column's fixed decimals (``%.6f``: 1e-6) and its significant
    digits at that value (``%.7g``: 1e-6 at 1.5, 1e-11 at 2.08e-05).  Printers drop
    trailing zeros ("0", "1.5"), so the column's most digits count for every value.  A
    column is written with one format: its digits are read off ``text``, the column's
    first ``FORMAT_SAMPLE`` printed values (parsing every text value of a 2-s, 48-kHz
    record cost 1.5 s)."""
    parts = text.astype(str).str.strip().str.extract(r"^[-+]?(\d*)(?:\.(\d*))?(?:[eE]([-+]?\d+))?$")
    whole, decimals = parts[0].fillna(""), parts[1].fillna("")
    exponent = pd.to_numeric(parts[2], errors="coerce").fillna(0).to_numpy()
    places = (decimals.str.len().to_numpy() - exponent).max()
    digits = (whole + decimals).str.lstrip("0").str.len().max()
    value = np.abs(value)
    with np.errstate(divide="ignore"):
        significant = np.where(value > 0, 10.0 ** (np.floor(np.log10(value)) - max(digits, 1) + 1), 0.0)
    return np.maximum(10.0**-places, significant)


def _rate_from_time(
    source, time: np.ndarray, stated: float | None, quantum: np.ndarray | None = None
) -> float:
    """The sample rate [Hz] of a time column: 1 / the slope of the least-squares line
    through (sample index, time).  Each step may differ from the line's by the printed
    precision of its two ends (half a unit of the last digit each: a column written
    with ``%.7g`` reads 2.08e-05 and 2.09e-05 s at 48 kHz) plus ``STEP_JITTER`` of a
    step; a larger difference is a gap (dropped samples) and is refused at its line."""
    n = len(time)
    index = np.arange(n) - (n - 1) / 2
    dt = float(index @ (time - time.mean()) / (index @ index))
    quantum = np.zeros(n) if quantum is None else quantum
    if dt <= 0 or 0.5 * quantum.max() > 0.5 * dt:
        raise _fail(
            source,
            f"time_s does not resolve the samples (printed to {quantum.max():g} s, step {dt:g} s); "
            "export time with more digits, or drop the time_s column and give --sample-rate",
        )
    step = np.diff(time)
    allowed = 0.5 * (quantum[:-1] + quantum[1:]) + STEP_JITTER * dt
    back = np.flatnonzero(step <= 0)
    if back.size:
        i = back[0]
        raise _fail(
            source,
            f"line {i + 3}: time_s = {time[i + 1]:g} is not after {time[i]:g}; time must increase "
            "monotonically: sort the rows or remove repeated samples",
        )
    uneven = np.flatnonzero(np.abs(step - dt) > allowed)
    if uneven.size:
        i = uneven[0]
        raise _fail(
            source,
            f"line {i + 3}: time step {step[i]:g} s differs from the least-squares step {dt:g} s by more "
            "than the "
            f"column's printed precision ({allowed[i]:.2g} s): samples dropped? the samples must be evenly "
            "spaced: re-export without gaps",
        )
    rate = _snap(1.0 / dt)
    if rate < MIN_SAMPLE_RATE:
        raise _fail(
            source,
            f"time_s gives a sample rate of {rate:.6g} Hz, below {MIN_SAMPLE_RATE:g} Hz; is the time "
            "column in ms? give time_s in seconds (or drop it and give --sample-rate)",
        )
    if stated is not None and abs(rate / stated - 1) > RATE_TOLERANCE:
        raise _fail(
            source,
            f"time_s gives a sample rate of {rate:.6g} Hz but sample_rate = {stated:g} Hz; "
            "drop the stated rate or the time_s column",
        )
    return stated if stated is not None else rate


def _snap(rate: float) -> float:
    """A rate within 1e-5 of a whole number of Hz is that number (time columns and UFF
    increments are written with few digits)."""
    return float(round(rate)) if abs(rate - round(rate)) < 1e-5 * rate else rate


def _check_rate(source, rate) -> float:
    if rate is None or not np.isfinite(rate) or rate <= 0:
        raise _fail(source, f"sample_rate = {rate!r} must be a positive number of Hz, e.g. 48000")
    if rate < MIN_SAMPLE_RATE:
        raise _fail(
            source, f"sample_rate = {rate:g} Hz is below {MIN_SAMPLE_RATE:g} Hz; give it in Hz, e.g. 48000"
        )
    return float(rate)


def read_csv(path: str | Path, sample_rate: float | None = None) -> Hit:
    """One hit from a CSV time series: ``time_s`` (or ``sample_rate`` [Hz]), ``force``
    and one response column (acceleration, velocity, displacement or response)."""
    source = Path(path).name
    try:
        frame = pd.read_csv(path)
    except pd.errors.EmptyDataError:
        raise _fail(source, "the file is empty; export the hit's time series with a header line") from None
    except (OSError, UnicodeDecodeError, pd.errors.ParserError) as exc:
        raise _fail(
            source, f"cannot read as CSV ({str(exc).splitlines()[0]}); give a comma-separated text file"
        ) from None
    frame.columns = [str(c).strip() for c in frame.columns]
    for column in frame.columns:
        if column not in CSV_COLUMNS:
            close = difflib.get_close_matches(column, CSV_COLUMNS, n=1)
            hint = f"did you mean '{close[0]}'?" if close else "rename it or remove it"
            raise _fail(source, f"unknown column '{column}' (allowed: {', '.join(CSV_COLUMNS)}); {hint}")
    responses = [c for c in RESPONSE_COLUMNS if c in frame.columns]
    if "force" not in frame.columns:
        raise _fail(
            source,
            f"missing column 'force' (columns: {', '.join(frame.columns)}); add the hammer's force channel",
        )
    if len(responses) != 1:
        found = ", ".join(responses) or "none"
        raise _fail(
            source,
            f"need exactly one response column of {', '.join(RESPONSE_COLUMNS)}, found {found}; "
            "keep one sensor per file",
        )
    if frame.empty:
        raise _fail(source, "no rows: the file has a header but no samples")
    # Numbers are parsed once, by the C parser; only a column it left as text is looked at.
    numeric = frame.apply(
        lambda c: c if pd.api.types.is_numeric_dtype(c) else pd.to_numeric(c, errors="coerce")
    )
    for column in frame.columns:
        text = frame[column][numeric[column].isna() & frame[column].notna()]
        if len(text):
            raise _fail(
                source,
                f"line {text.index[0] + 2}: {column} = {text.iloc[0]!r} is not a number; "
                "fix or remove that row",
            )
    if "time_s" in frame.columns:
        time = _check_samples(source, "time_s", numeric["time_s"], first_line=2)
        rate = _rate_from_time(
            source,
            time,
            None if sample_rate is None else _check_rate(source, sample_rate),
            printed_quantum(_printed_time(path), time),
        )
    elif sample_rate is None:
        raise _fail(
            source,
            "no time_s column and no sample rate; add a time_s column or give the sample rate "
            "(--sample-rate HZ)",
        )
    else:
        rate = _check_rate(source, sample_rate)
    force = _check_samples(source, "force", numeric["force"], first_line=2)
    response = _check_samples(source, responses[0], numeric[responses[0]], first_line=2)
    return Hit(source, rate, response, force, responses[0])


def _printed_time(path) -> pd.Series:
    """The first ``FORMAT_SAMPLE`` values of a CSV's time_s column as printed."""
    return pd.read_csv(
        path, usecols=lambda c: str(c).strip() == "time_s", dtype=str, nrows=FORMAT_SAMPLE
    ).iloc[:, 0]


def read_wav(path: str | Path, sample_rate: float | None = None) -> Hit:
    """One hit from a WAV file: channels (force, response), or (response) alone."""
    from scipy.io import wavfile

    source = Path(path).name
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", wavfile.WavFileWarning)  # unknown chunks (metadata) are skipped
            rate, data = wavfile.read(path)
    except (OSError, ValueError, EOFError) as exc:
        raise _fail(
            source,
            f"cannot read as WAV ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
            "give a PCM or float WAV file",
        ) from None
    if sample_rate is not None and abs(rate / _check_rate(source, sample_rate) - 1) > RATE_TOLERANCE:
        raise _fail(
            source,
            f"the WAV header says {rate} Hz but sample_rate = {sample_rate:g} Hz; "
            "drop the stated rate or re-export the file",
        )
    data = np.asarray(data, dtype=float)
    data = data[:, None] if data.ndim == 1 else data
    if data.shape[1] not in (1, 2):
        raise _fail(
            source,
            f"{data.shape[1]} channels; allowed: 2 (force, response) or 1 (response); "
            "export the hammer and one sensor only",
        )
    response = _check_samples(source, "response channel", data[:, -1])
    force = _check_samples(source, "force channel", data[:, 0]) if data.shape[1] == 2 else None
    return Hit(source, float(rate), response, force, "response")


def _uff_quantity(source, record: dict, key: str) -> str:
    code = int(record.get(key, 0))
    if code not in UFF_RESPONSE:
        raise _fail(
            source,
            f"record '{record.get('id1', '')}': {key} = {code} is not a response; allowed "
            f"{', '.join(f'{k} ({v})' for k, v in UFF_RESPONSE.items())}; set the response's data type",
        )
    return UFF_RESPONSE[code]


def _uff_sets(path: str | Path, header_only: bool = False) -> list[dict]:
    """Every data set of a universal file as pyuff reads it (type-58 records checked
    whole unless ``header_only``)."""
    import pyuff

    source = Path(path).name
    try:
        sets = pyuff.UFF(str(path)).read_sets(header_only=header_only) if Path(path).stat().st_size else []
    except Exception as exc:  # noqa: BLE001 - pyuff raises bare Exception on malformed files
        raise _fail(
            source,
            f"cannot read as UFF ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
            "give a universal file with type-58 records",
        ) from None
    sets = [sets] if isinstance(sets, dict) else sets
    for r in sets:  # pyuff returns a truncated record's points without complaint
        if (
            r.get("type") == 58
            and not header_only
            and len(r["data"]) != int(r.get("num_pts", len(r["data"])))
        ):
            raise _fail(
                source,
                f"record '{r.get('id1', '')}' holds {len(r['data'])} of its num_pts = {r['num_pts']} "
                "points (truncated file); export it again",
            )
    return sets


def read_uff(path: str | Path, sample_rate: float | None = None) -> list[Recording]:
    """UFF type-58 records: each FRF record (function type 4) as a MeasuredFRF, or a
    pair of time records (function type 1, force and response) as one Hit."""
    source = Path(path).name
    records = [r for r in _uff_sets(path) if r.get("type") == 58]
    if not records:
        raise _fail(
            source, "no type-58 record; export the FRF or the force and response time records as UFF58"
        )
    frfs = [r for r in records if r["func_type"] == UFF_FRF]
    times = [r for r in records if r["func_type"] == UFF_TIME]
    others = sorted({int(r["func_type"]) for r in records} - {UFF_FRF, UFF_TIME})
    if others:
        raise _fail(
            source,
            f"function type {others[0]} is not supported; allowed: {UFF_TIME} (time response) "
            f"or {UFF_FRF} (FRF): export those",
        )
    out: list[Recording] = [_uff_frf(source, r) for r in frfs]
    if times:
        out.append(_uff_hit(source, times, sample_rate))
    return out


#: Relative precision of an uneven-abscissa UFF58 record's printed x values (E13.5: 6 digits).
UFF_X_PRECISION = 1e-5


def _uff_step(source: str, r: dict) -> float:
    """The record's abscissa step: ``abscissa_inc`` when evenly spaced (abscissa_spacing
    1); for abscissa_spacing 0 (x values listed, as some front ends write even data) the
    least-squares step of the listed x, which must be even to their printed precision."""
    if int(r.get("abscissa_spacing", 1)) == 1:
        return float(r["abscissa_inc"])
    x = np.asarray(r["x"], dtype=float)
    try:
        return 1.0 / _rate_from_time(source, x, None, UFF_X_PRECISION * np.abs(x))
    except MeasurementError as error:
        raise _fail(
            source,
            f"record '{r.get('id1', '')}': abscissa_spacing = 0 and the listed abscissa is uneven "
            f"({str(error).split(': ', 1)[1].split(';')[0]}); export the record on evenly spaced "
            "lines",
        ) from None


def _uff_frf(source: str, r: dict) -> MeasuredFRF:
    step = _uff_step(source, r)
    frf = np.asarray(r["data"], dtype=complex)
    bad = np.flatnonzero(~np.isfinite(frf))
    if bad.size or len(frf) < 16:
        raise _fail(
            source,
            f"record '{r.get('id1', '')}': FRF has {bad.size} non-finite values of {len(frf)} "
            "(need at least 16 finite lines); re-export the FRF",
        )
    quantity = _uff_quantity(source, r, "ordinate_spec_data_type")
    return MeasuredFRF(
        source, float(np.asarray(r["x"], dtype=float)[0]) + step * np.arange(len(frf)), frf, quantity
    )


def _uff_hit(source: str, times: list[dict], sample_rate: float | None) -> Hit:
    force = [r for r in times if int(r.get("ordinate_spec_data_type", 0)) in UFF_FORCE]
    response = [r for r in times if int(r.get("ordinate_spec_data_type", 0)) in UFF_RESPONSE]
    if len(force) != 1 or len(response) != 1 or len(times) != 2:
        raise _fail(
            source,
            f"{len(times)} time records with {len(force)} force and {len(response)} response; "
            "need one force record (data type 13) and one response record (8, 11 or 12) per file",
        )
    rates = [_snap(1.0 / _uff_step(source, r)) for r in (force[0], response[0])]
    if abs(rates[0] / rates[1] - 1) > RATE_TOLERANCE:
        raise _fail(
            source,
            f"force sampled at {rates[0]:g} Hz, response at {rates[1]:g} Hz; record both channels "
            "at one rate",
        )
    if sample_rate is not None and abs(rates[0] / _check_rate(source, sample_rate) - 1) > RATE_TOLERANCE:
        raise _fail(
            source,
            f"the records say {rates[0]:.6g} Hz but sample_rate = {sample_rate:g} Hz; drop the stated rate",
        )
    f = _check_samples(source, "force record", force[0]["data"])
    y = _check_samples(source, "response record", response[0]["data"])
    if len(f) != len(y):
        raise _fail(source, f"force has {len(f)} samples, response {len(y)}; export both over the same time")
    return Hit(source, rates[0], y, f, _uff_quantity(source, response[0], "ordinate_spec_data_type"))


#: UFF58 direction codes (response and reference direction fields).
UFF_DIRECTIONS = {
    0: "scalar",
    1: "+X",
    -1: "-X",
    2: "+Y",
    -2: "-Y",
    3: "+Z",
    -3: "-Z",
    4: "+X rotation",
    -4: "-X rotation",
    5: "+Y rotation",
    -5: "-Y rotation",
    6: "+Z rotation",
    -6: "-Z rotation",
}
#: The plate normal's codes and the sign that turns an FRF measured along them into +Z.
UFF_NORMAL = {3: 1.0, -3: -1.0}
UFF_SUFFIXES = (".uff", ".unv")
#: Node coordinates without a units data set (164) are taken as metres when every one
#: lies below this (in the file's units): no plate tested this way is 5 m long, and no
#: grid in mm fits inside 5 mm.
METRES_BELOW = 5.0
#: Decimals [mm] kept of converted node coordinates (1 nm, far below any measurement):
#: the same grid in metres and in mm gives the same points (0.038 m is 38.00000000000001 mm).
MM_DECIMALS = 6
#: Two data sets' coordinates of one node agree within this [mm] plus ``UFF_X_PRECISION``
#: of the coordinate (data set 15 prints 6 digits): the same grid exported in metres and
#: in mm agrees, a node moved by a thousandth of a millimetre or more does not.
SAME_NODE_MM = 1e-3
#: Points measured more than once that a note names with their records (the rest counted).
REPEATS_SHOWN = 5


@dataclass(frozen=True, eq=False)
class MultiPointUFF:
    """A multi-point test read from universal files, as
    :func:`identify.recordings.shapes.estimate_shapes` takes it.

    recordings_by_point: point name (the node number) -> its FRF records (MeasuredFRF,
    turned to +Z); points: point, x_mm, y_mm [mm] (the measured nodes); roving:
    "response" (vibrometer, roving sensor: one reference, several response nodes) or
    "reference" (roving hammer: one response node, several reference nodes); notes."""

    recordings_by_point: dict[str, list[MeasuredFRF]]
    points: pd.DataFrame
    roving: str
    notes: tuple[str, ...] = ()


def _node_name(value) -> str:
    """A node number as a point name ("7" for 7, 7.0 or " 07")."""
    text = str(value).strip()
    try:
        return str(int(float(text)))
    except ValueError:
        return text


def _frf_nodes(records) -> tuple[set, set]:
    """The response nodes and the reference nodes of the FRF records (function type 4)."""
    frfs = [r for r in records if r.get("func_type") == UFF_FRF]
    return {int(r["rsp_node"]) for r in frfs}, {int(r["ref_node"]) for r in frfs}


def is_multi_point_uff(paths) -> bool:
    """True when every path is an existing UFF file and their FRF records (function type 4)
    measure several points: several response nodes or several reference nodes (headers
    only are read)."""
    paths = [Path(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]
    if not paths or not all(p.suffix.lower() in UFF_SUFFIXES and p.is_file() for p in paths):
        return False
    records = [r for p in paths for r in _uff_sets(p, header_only=True) if r.get("type") == 58]
    responses, references = _frf_nodes(records)
    return len(responses) > 1 or len(references) > 1


def read_points(points) -> pd.DataFrame:
    """A points table of a multi-point test: a DataFrame or a CSV path with the columns
    point (a name, or a UFF node number), x_mm, y_mm [mm, from the plate's corner at the
    origin]; its columns checked, its values as given."""
    if isinstance(points, (str, Path)):
        path = Path(points)
        try:
            points = pd.read_csv(path, dtype={"point": str}, skipinitialspace=True, comment="#")
        except FileNotFoundError:
            raise MeasurementError(f"points table {str(path)!r} does not exist") from None
        except (OSError, ValueError) as exc:
            raise MeasurementError(
                f"points table {str(path)!r} cannot be read as a CSV ({exc}); give a table with "
                "columns point, x_mm, y_mm"
            ) from None
    if not isinstance(points, pd.DataFrame):
        raise MeasurementError(
            f"points must be a table (columns point, x_mm, y_mm), not {type(points).__name__}"
        )
    missing = [c for c in ("point", "x_mm", "y_mm") if c not in points.columns]
    if missing:
        raise MeasurementError(
            f"points: column {missing[0]!r} is missing (columns: {', '.join(map(str, points.columns))}"
            "); give point (a name, or the UFF node number), x_mm, y_mm (mm from the plate's "
            "corner at the origin)"
        )
    return points


def _points_csv(points) -> pd.DataFrame:
    """A points table (``read_points``), its point names as node numbers."""
    points = read_points(points)
    return points.assign(point=points["point"].map(_node_name))


#: Where a data set gives a node's position: the file, the data set type (15 or 2411) and
#: the coordinates x, y, z in the file's length unit.
NodePosition = tuple[str, int, tuple[float, float, float]]


def _geometry(sets: list[tuple[str, dict]]) -> tuple[dict[str, list[NodePosition]], float | None]:
    """Every position data sets 15 and 2411 give each node, in file order and the files'
    units, and the units' length factor (data set 164: file units per metre; None without
    one)."""
    nodes, factors = {}, {}
    for source, s in sets:
        if s.get("type") in (15, 2411):
            for n, x, y, z in zip(s["node_nums"], s["x"], s["y"], s["z"]):
                nodes.setdefault(_node_name(n), []).append(
                    (source, int(s["type"]), (float(x), float(y), float(z)))
                )
        elif s.get("type") == 164:
            factors[float(s["length"])] = source
    if len(factors) > 1:
        raise MeasurementError(
            f"{', '.join(factors.values())}: data sets 164 give different length units "
            f"({', '.join(f'{f:g}' for f in factors)} per metre); export every file in one unit system"
        )
    return nodes, next(iter(factors), None)


def _position_mm(name: str, given: list[NodePosition], to_mm: float) -> tuple[float, float]:
    """Node ``name``'s x, y [mm] (z ignored), the same in every position ``given`` it
    (``_geometry``) within ``SAME_NODE_MM`` plus ``UFF_X_PRECISION`` of the coordinate;
    ``to_mm``: mm per file unit."""
    (source, kind, xyz), *others = given
    xy = np.array(xyz[:2]) * to_mm
    for other_source, other_kind, other_xyz in others:
        other_xy = np.array(other_xyz[:2]) * to_mm
        if np.any(
            np.abs(other_xy - xy) > SAME_NODE_MM + UFF_X_PRECISION * np.maximum(abs(xy), abs(other_xy))
        ):
            shown = [", ".join(f"{round(float(c), 4):.10g}" for c in v) for v in (xy, other_xy)]
            files = source if other_source == source else f"{source}, {other_source}"
            raise _fail(
                files,
                f"node {name} is at (x_mm, y_mm) = ({shown[0]}) in {source} (data set {kind}) but "
                f"({shown[1]}) in {other_source} (data set {other_kind}); correct the wrong one, or give one "
                "points table for every node (--points POINTS.csv: point = node number, x_mm, y_mm), which "
                "replaces the files' geometry",
            )
    return round(float(xy[0]), MM_DECIMALS), round(float(xy[1]), MM_DECIMALS)


def _check_repeat(
    source: str,
    record: str,
    name: str,
    frf: MeasuredFRF,
    earlier_ids: list[tuple[str, str]],
    earlier: list[MeasuredFRF],
) -> None:
    """A repeated record ``record`` of node ``name`` (turned to +Z) against the node's
    ``earlier`` records (their sources and ids ``earlier_ids``): averaged later, it must
    measure the same quantity and must not be a copy of one of them."""
    for (other_source, other_record), other in zip(earlier_ids, earlier, strict=True):
        if other.quantity != frf.quantity:
            raise _fail(
                source,
                f"record '{record}' (node {name}) measures {frf.quantity} but {other_source}'s record "
                f"'{other_record}' of the same node measures {other.quantity}; a point's repeated FRFs are "
                "averaged: export them as one quantity, or drop one",
            )
        if np.array_equal(other.frf, frf.frf):
            raise _fail(
                source,
                f"record '{record}' (node {name}) holds the same FRF as {other_source}'s record "
                f"'{other_record}': one measurement read twice would pass for a repeat; give each file and "
                "each record once",
            )


def read_uff_points(paths, points=None) -> MultiPointUFF:
    """A multi-point test from universal files ``paths``: data set 58 FRFs (function type
    4) of several points along the plate normal (+Z or -Z, turned to +Z) with one
    reference (a vibrometer or roving sensor) or one response node (a roving hammer), and
    the points' coordinates from data sets 15 or 2411 in the files (units from data set
    164; z ignored) or from ``points`` (a table or CSV: point = node number, x_mm, y_mm
    [mm] in the plate's frame), which then replace the files' geometry.

    A measured node placed twice (two files, or two data sets) must sit at the same x, y
    (within ``SAME_NODE_MM`` [mm] plus ``UFF_X_PRECISION`` of the value). A point with
    several FRF records keeps them all (``estimate_shapes`` averages them, each one hit),
    said in a note; a record given twice, or a repeat of another response quantity, is
    refused."""
    paths = [Path(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]
    sets = []
    for path in paths:
        if path.suffix.lower() not in UFF_SUFFIXES or not path.is_file():
            raise _fail(path.name, f"not an existing UFF file ({', '.join(UFF_SUFFIXES)}); check the path")
        sets += [(path.name, s) for s in _uff_sets(path)]
    records = [(source, s) for source, s in sets if s.get("type") == 58]
    if not records:
        raise _fail(
            ", ".join(p.name for p in paths), "no type-58 record; export the FRFs of every point as UFF58"
        )
    beside = [r for _, r in records if int(r["func_type"]) in UFF_BESIDE_FRFS]
    records = [(source, r) for source, r in records if int(r["func_type"]) not in UFF_BESIDE_FRFS]
    if not records:
        raise _fail(
            ", ".join(p.name for p in paths),
            "no FRF record (function type 4) beside the spectra and "
            "coherences; export the FRFs of every point",
        )
    for source, r in records:
        if r["func_type"] != UFF_FRF:
            raise _fail(
                source,
                f"record '{r.get('id1', '')}': func_type = {r['func_type']} is not an FRF; a "
                f"multi-point test is read from FRFs (function type {UFF_FRF}; spectra and coherences beside "
                "them are skipped): export the FRFs without time records",
            )
    responses, references = _frf_nodes(r for _, r in records)
    where = ", ".join(p.name for p in paths)
    if len(responses) > 1 and len(references) > 1:
        raise _fail(
            where,
            f"FRFs of {len(responses)} response nodes and {len(references)} reference nodes; a shape "
            "needs one fixed end: export one reference's FRFs (or one response node's, for a roving hammer)",
        )
    if len(responses) == 1 and len(references) == 1:
        raise _fail(
            where,
            f"every FRF has response node {responses.pop()} and reference node {references.pop()}: one "
            "point, not a multi-point test; export the FRFs of every point (or read these as the hits of "
            "one point: peaks without --shapes-out)",
        )
    roving = "response" if len(responses) > 1 else "reference"
    node_key, direction_key = ("rsp_node", "rsp_dir") if roving == "response" else ("ref_node", "ref_dir")
    fixed_key = "ref_dir" if roving == "response" else "rsp_dir"
    first = _uff_frf(*records[0])
    by_point: dict[str, list[MeasuredFRF]] = {}
    record_of: dict[str, list[tuple[str, str]]] = {}
    for source, r in records:
        name = _node_name(r[node_key])
        direction = int(r[direction_key])
        if direction not in UFF_NORMAL:
            raise _fail(
                source,
                f"record '{r.get('id1', '')}' (node {name}): {direction_key} = {direction} "
                f"({UFF_DIRECTIONS.get(direction, 'unknown')}) is not the plate normal; allowed +Z (3) or "
                "-Z (-3): export the FRFs measured normal to the plate's face",
            )
        frf = _uff_frf(source, r)
        if len(frf.frequency_hz) != len(first.frequency_hz) or not np.allclose(
            frf.frequency_hz, first.frequency_hz, rtol=1e-9, atol=1e-9
        ):
            raise _fail(
                source,
                f"record '{r.get('id1', '')}' (node {name}): {len(frf.frequency_hz)} lines from "
                f"{frf.frequency_hz[0]:g} Hz by {frf.frequency_hz[1] - frf.frequency_hz[0]:g} Hz, but "
                f"{first.source}'s first record has {len(first.frequency_hz)} from {first.frequency_hz[0]:g} "
                f"Hz by {first.frequency_hz[1] - first.frequency_hz[0]:g} Hz; export every FRF on the same "
                "frequency lines",
            )
        sign = UFF_NORMAL[direction] * UFF_NORMAL.get(int(r[fixed_key]), 1.0)
        turned = MeasuredFRF(f"{source} node {name}", frf.frequency_hz, sign * frf.frf, frf.quantity)
        _check_repeat(source, r.get("id1", ""), name, turned, record_of.get(name, []), by_point.get(name, []))
        by_point.setdefault(name, []).append(turned)
        record_of.setdefault(name, []).append((source, r.get("id1", "")))
    notes = (
        [
            f"skipped {len(beside)} record(s) of "
            + ", ".join(sorted({UFF_BESIDE_FRFS[int(r["func_type"])] for r in beside}))
            + " (the shapes come from the FRFs)"
        ]
        if beside
        else []
    )
    repeated = {n: ids for n, ids in record_of.items() if len(ids) > 1}
    if repeated:
        shown = "; ".join(
            f"node {n}: " + ", ".join(f"{s} '{i}'" for s, i in ids)
            for n, ids in list(repeated.items())[:REPEATS_SHOWN]
        )
        more = f"; and {len(repeated) - REPEATS_SHOWN} more" if len(repeated) > REPEATS_SHOWN else ""
        notes.append(
            f"{len(repeated)} point(s) measured more than once, their FRFs averaged (the mean on their "
            f"common frequency lines, each record counting as one hit): {shown}{more}"
        )
    if points is not None:
        table = _points_csv(points)
        frame = table.loc[table["point"].isin(by_point), ["point", "x_mm", "y_mm"]].reset_index(drop=True)
        missing_fix = "add its row (point = node number, x_mm, y_mm) to the points table"
    else:
        nodes, per_metre = _geometry(sets)
        measured = {n: nodes[n] for n in by_point if n in nodes}
        values = np.abs([c for given in measured.values() for _, _, xyz in given for c in xyz])
        if per_metre is None and len(values) and values.max() < METRES_BELOW:
            per_metre = 1.0
            notes.append(
                f"no units data set (164) and every node coordinate below {METRES_BELOW:g}: taken as metres"
            )
        to_mm = 1000.0 / per_metre if per_metre is not None else 1.0
        frame = pd.DataFrame(
            [(n, *_position_mm(n, measured[n], to_mm)) for n in sorted(measured, key=int)],
            columns=["point", "x_mm", "y_mm"],
        )
        missing_fix = (
            "export the geometry (data set 15 or 2411) with the FRFs, or give a points table (--points)"
        )
    for name, ((source, record), *_) in record_of.items():
        if name not in set(frame["point"]):
            raise _fail(source, f"record '{record}': {node_key} = {name} has no coordinates; {missing_fix}")
    return MultiPointUFF({n: by_point[n] for n in frame["point"]}, frame, roving, tuple(notes))


def _hit_from_channels(source: str, channels: dict, sample_rate: float | None, kind: str) -> Hit:
    """A hit from named channels (MAT variables, TDMS channels): ``force``, one response
    channel, and ``time_s`` or a sample rate."""
    responses = [c for c in RESPONSE_COLUMNS if c in channels]
    if "force" not in channels or len(responses) != 1:
        raise _fail(
            source,
            f"{kind} holds {', '.join(sorted(channels)) or 'nothing'}; need 'force' and exactly one "
            f"of {', '.join(RESPONSE_COLUMNS)} (and 'time_s' or a sample rate): rename the channels",
        )
    force = _check_samples(source, "force", np.ravel(channels["force"]))
    response = _check_samples(source, responses[0], np.ravel(channels[responses[0]]))
    if len(force) != len(response):
        raise _fail(
            source,
            f"force has {len(force)} samples, {responses[0]} {len(response)}; export both over the same time",
        )
    stated = None if sample_rate is None else _check_rate(source, sample_rate)
    if "time_s" in channels:
        stored = np.ravel(channels["time_s"])
        # float32 time
        quantum = 2 * np.spacing(np.abs(stored)).astype(float) if stored.dtype.kind == "f" else None
        rate = _rate_from_time(source, _check_samples(source, "time_s", stored), stated, quantum)
    elif stated is None:
        raise _fail(
            source,
            f"no time_s and no sample rate in the {kind}; add a sample_rate variable or give "
            "--sample-rate HZ",
        )
    else:
        rate = stated
    return Hit(source, rate, response, force, responses[0])


def read_mat(path: str | Path, sample_rate: float | None = None) -> Hit:
    """One hit from a MATLAB file (v4-v7, scipy.io.loadmat): vectors ``force`` and one
    response (acceleration, velocity, displacement or response), and ``time_s`` or a
    scalar ``sample_rate`` [Hz] (or the ``sample_rate`` argument)."""
    from scipy.io import loadmat
    from scipy.io.matlab import MatReadError

    source = Path(path).name
    try:
        data = loadmat(path, squeeze_me=True)
    except NotImplementedError:
        raise _fail(source, "MATLAB v7.3 (HDF5) file; save it with save(..., '-v7')") from None
    except (OSError, ValueError, TypeError, MatReadError) as exc:
        raise _fail(
            source,
            f"cannot read as a MAT file ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
            "save the hit's vectors with MATLAB's save or scipy.io.savemat",
        ) from None
    channels = {k: v for k, v in data.items() if not k.startswith("__")}
    if "sample_rate" in channels:
        rate = float(np.ravel(channels.pop("sample_rate"))[0])
        if sample_rate is not None and abs(rate / _check_rate(source, sample_rate) - 1) > RATE_TOLERANCE:
            raise _fail(
                source, f"the file says sample_rate = {rate:g} Hz but {sample_rate:g} Hz was given; drop one"
            )
        sample_rate = _check_rate(source, rate)
    return _hit_from_channels(source, channels, sample_rate, "MAT file")


def read_tdms(path: str | Path, sample_rate: float | None = None) -> Hit:
    """One hit from an NI TDMS file (npTDMS): channels named ``force`` and one response
    (any group); the sample rate from the channels' ``wf_increment`` [s] (or
    ``sample_rate``)."""
    from nptdms import TdmsFile

    source = Path(path).name
    try:
        tdms = TdmsFile.read(path)
    except Exception as exc:  # noqa: BLE001 - npTDMS raises bare errors of several kinds on damaged files
        raise _fail(
            source,
            f"cannot read as TDMS ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
            "give a TDMS file written by LabVIEW, DAQmx or npTDMS",
        ) from None
    found = {ch.name.strip().lower(): ch for group in tdms.groups() for ch in group.channels()}
    steps = {float(ch.properties["wf_increment"]) for ch in found.values() if "wf_increment" in ch.properties}
    if len(steps) > 1:
        raise _fail(
            source,
            f"channels sampled at different rates ({', '.join(f'{1 / d:g}' for d in sorted(steps))} Hz); "
            "record force and response at one rate",
        )
    if steps:
        rate = _snap(1.0 / steps.pop())
        if sample_rate is not None and abs(rate / _check_rate(source, sample_rate) - 1) > RATE_TOLERANCE:
            raise _fail(
                source,
                f"wf_increment gives {rate:g} Hz but sample_rate = {sample_rate:g} Hz; drop the stated rate",
            )
        sample_rate = rate
    return _hit_from_channels(source, {k: ch[:] for k, ch in found.items()}, sample_rate, "TDMS file")


READERS = {
    ".csv": read_csv,
    ".wav": read_wav,
    ".uff": read_uff,
    ".unv": read_uff,
    ".mat": read_mat,
    ".tdms": read_tdms,
}


def read_recordings(paths, sample_rate: float | None = None) -> list[Recording]:
    """Read every file (CSV, WAV, UFF/UNV, MAT, TDMS) of one configuration and check they belong
    together (:func:`check_together`)."""
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    out: list[Recording] = []
    for path in paths:
        path = Path(path)
        reader = READERS.get(path.suffix.lower())
        if reader is None:
            raise _fail(
                path.name, f"file type '{path.suffix}' is not supported; allowed: {', '.join(READERS)}"
            )
        if not path.is_file():
            raise _fail(path.name, "no such file; check the path")
        read = reader(path, sample_rate)
        out.extend(read if isinstance(read, list) else [read])
    return check_together(out)


def _same_samples(a: Hit, b: Hit) -> bool:
    return (
        np.array_equal(a.response, b.response)
        and (a.force is None) == (b.force is None)
        and (a.force is None or np.array_equal(a.force, b.force))
    )


def check_together(records: list[Recording]) -> list[Recording]:
    """The recordings of one configuration: one kind (time hits or FRFs), one sample
    rate, one response quantity, a force channel in all or none, no hit given twice."""
    out = list(records)
    if not out:
        raise MeasurementError("no recordings given; pass at least one CSV, WAV or UFF file")
    hits = [r for r in out if isinstance(r, Hit)]
    if hits and len(hits) != len(out):
        raise _fail(
            next(r for r in out if isinstance(r, MeasuredFRF)).source,
            "mixes an averaged FRF with time hits; give either time records or FRFs for one configuration",
        )
    for r in out[1:]:
        if r.quantity != out[0].quantity:
            raise _fail(
                r.source,
                f"response is {r.quantity} but {out[0].source} has {out[0].quantity}; "
                "give one sensor's recordings per configuration",
            )
    for i, h in enumerate(hits):
        twin = next((g for g in hits[:i] if _same_samples(g, h)), None)
        if twin is not None:
            raise _fail(
                h.source,
                f"holds the same samples as {twin.source}: one hit given twice would fake a "
                "zero scatter; give each hit once",
            )
    for h in hits[1:]:
        if abs(h.sample_rate / hits[0].sample_rate - 1) > RATE_TOLERANCE:
            raise _fail(
                h.source,
                f"sample rate {h.sample_rate:g} Hz differs from {hits[0].source}'s "
                f"{hits[0].sample_rate:g} Hz; record every hit at one rate",
            )
        if (h.force is None) != (hits[0].force is None):
            raise _fail(
                h.source,
                "has a force channel where " + hits[0].source + " has none (or the reverse); "
                "give the force for every hit or for none",
            )
    return out
