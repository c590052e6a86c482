"""Mode shapes from roving-hammer recordings: the poles from the points' peak lists, then
each point's residues by linear least squares in the frequency domain (LSFD) with the
poles fixed.

A roving-hammer test keeps the sensor at one place and hits a grid of points, a few
hits each.  Point j's FRF (H1 over its hits, :mod:`identify.recordings.frf`) is modelled
as

    H_j(s) = s^k [ sum_r R_jr / (s - p_r) + conj(R_jr) / (s - conj p_r) + L_j / s^2 + U_j ],

s = i w, with k = 0, 1, 2 for a displacement, velocity or acceleration response (the
bracket is the receptance).  L_j / s^2 is the lower residual (the modes below the band:
the rigid-body and suspension modes, mass-like) and U_j the upper one (the modes above:
stiffness-like); in an accelerance they read L_j (a constant: the mass line) and U_j s^2.
Both are complex: the out-of-band modes' damping gives them a small quadrature part.  The
residue R_jr is phi_r(point j) phi_r(sensor) / (2 i w_dr m_r) for a real mode, so mode r's
residues over the points are its shape at the points, to a factor common to all of them.

Poles.  Every point's recordings get their own peak list
(:func:`identify.recordings.peaks.extract_peaks`), and a mode is a peak that recurs at
several points: the peaks of all points sorted by frequency, chained while neighbours lie
within ``LINK`` of a half-power half-bandwidth, a chain kept when ``MIN_POINTS_SHARE`` of
the points (two at least) found it; its frequency and damping ratio are the medians over
the points whose SNR is within ``SNR_SPAN`` of the best.  That is robust where the
alternatives are not: the average of all points' FRFs cancels a mode whose shape changes
sign over the grid (every mode but the first few), and a single driving point misses the
modes with a node there; a noise peak at one point finds no partner and is dropped.  A
mode at a node of the sensor is missing from every point's FRF alike: no pole is missed
that the data hold.  Two modes closer than a half-power bandwidth come out as one pole,
as in the peak list, and their shapes as one mixed shape.

Residues.  With the poles fixed (moved by each point's exponential window, as its FRF
was), the model is linear in (Re R, Im R, Re L, Im L, Re U, Im U): one real least-squares
problem per point (real and imaginary parts of the lines stacked), its columns scaled to
unit norm, solved by SVD, on the lines from ``MARGIN`` half-power half-bandwidths below
the lowest pole to as many above the highest (inside every point's peak band).  The standard
error of a residue is the complex one, sqrt(var Re R + var Im R) = sqrt(E|R_fit - R|^2),
from sigma^2 (J^T J)^-1 with sigma^2 the residual sum of squares over its degrees of
freedom (white noise of equal variance on every line assumed).

Shapes.  Mode r's residues over the points are rotated to their best real direction
(the angle theta = arg(sum_j R_jr^2) / 2 maximises sum_j Re(R_jr e^-i theta)^2) and scaled
so the largest |amplitude| is 1, its real part positive.  The modal phase collinearity
MPC = (|sum_j R_jr^2| / sum_j |R_jr|^2)^2 (Pappa, Elliott and Schenk, 1993: the squared
ratio (l1 - l2) / (l1 + l2) of the eigenvalues of the real and imaginary parts' 2 x 2
matrix) is 1 for a real (normal) mode and 0 for a travelling wave.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from fem.errors import MeasurementError
from fem.io import write_text

from .peaks import CSV_COLUMNS as PEAK_COLUMNS
from .peaks import PeakList, extract_peaks
from .readers import READERS, read_points

#: Power k of s = i w that turns a receptance into the response's FRF.
POWER = {"displacement": 0, "velocity": 1, "acceleration": 2}
#: Peaks of two points are one mode while they lie within this fraction of the mode's
#: half-power half-bandwidth (zeta f): a point's pole scatters by a few % of it (the
#: hits' scatter), two modes a bandwidth apart stay two.
LINK = 0.5
#: A mode must be found at this share of the points (and at two at least): a plate mode
#: with a nodal line through a row of a 5 x 4 grid is still found at 3/4 of its points,
#: a noise peak at one.
MIN_POINTS_SHARE = 0.2
#: A point's pole counts in the mode's median when its SNR is within this factor of the
#: best point's: near a node the local fit's pole is noise.
SNR_SPAN = 10.0
#: LSFD lines reach this many half-power half-bandwidths beyond the outer poles: there
#: the outer modes are down to 1/sqrt(1 + MARGIN^2) = 0.1 of their peaks, so the residual
#: terms are fitted where they, not the modes, shape the FRF.
MARGIN = 10.0
#: The SHAPES.csv columns.
CSV_COLUMNS = ["configuration", "frequency_hz", "x_mm", "y_mm", "amplitude", "amplitude_imag"]


@dataclass(frozen=True, eq=False)
class LSFDFit:
    """Residues by LSFD of FRFs on common lines with fixed poles (module docstring).

    residues: (modes, points) complex R [response unit / force unit x (rad/s)^(1 - k)];
    residue_std: (modes, points) their complex standard errors; lower, upper: (points,)
    complex L and U; rms: (points,) RMS residual per line [response unit / force unit];
    condition: the condition number of the column-scaled basis."""

    residues: np.ndarray
    residue_std: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    rms: np.ndarray
    condition: float


def lsfd(frequency_hz, h, poles, quantity: str = "acceleration") -> LSFDFit:
    """Residues of the poles ``poles`` [rad/s] (upper half-plane: -zeta w + i w_d) in the
    FRFs ``h`` ((points, lines) or (lines,), complex, response / force) on the lines
    ``frequency_hz`` [Hz] (all used: select the band first), the response being
    ``quantity`` (displacement, velocity or acceleration), with lower and upper residual
    terms (module docstring)."""
    f = np.asarray(frequency_hz, dtype=float)
    h = np.atleast_2d(np.asarray(h, dtype=complex))
    p = np.atleast_1d(np.asarray(poles, dtype=complex))
    if quantity not in POWER:
        raise MeasurementError(
            f"quantity = {quantity!r} is not a response LSFD can model; allowed: {', '.join(POWER)}"
        )
    m, n = len(p), 2 * len(p) + 4
    if 2 * len(f) < n + 2 or h.shape[1] != len(f):
        raise MeasurementError(
            f"the FRFs hold {h.shape[1]} lines on {len(f)} frequencies; LSFD of {m} modes needs "
            f"the same lines, at least {n // 2 + 1} of them: widen the band or record longer hits"
        )
    s = 2j * np.pi * f[:, None]
    a, b = 1 / (s - p), 1 / (s - p.conj())
    one = np.ones_like(s)
    columns = np.hstack([a + b, 1j * (a - b), 1 / s**2, 1j / s**2, one, 1j * one]) * s ** POWER[quantity]
    basis = np.concatenate([columns.real, columns.imag])
    scale = np.linalg.norm(basis, axis=0)
    u, singular, vt = np.linalg.svd(basis / scale, full_matrices=False)
    data = np.concatenate([h.T.real, h.T.imag])  # (2 lines, points)
    solve = vt.T / singular  # (columns, columns): the scaled basis' pseudo-inverse is solve @ u.T
    coef = (solve @ (u.T @ data)) / scale[:, None]
    residual = basis @ coef - data
    sigma2 = np.sum(residual**2, axis=0) / (basis.shape[0] - n)
    variance = (np.sum(solve**2, axis=1) / scale**2)[:, None] * sigma2  # diag of sigma^2 (B^T B)^-1
    return LSFDFit(
        coef[:m] + 1j * coef[m : 2 * m],
        np.sqrt(variance[:m] + variance[m : 2 * m]),
        coef[2 * m] + 1j * coef[2 * m + 1],
        coef[2 * m + 2] + 1j * coef[2 * m + 3],
        np.sqrt(np.sum(residual**2, axis=0) / len(f)),
        float(singular[0] / singular[-1]),
    )


def normalised(residues: np.ndarray, std: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Shapes (modes, points) from residues: rotated to their best real direction, scaled
    to a largest |amplitude| of 1 (its real part positive); the standard errors scaled
    alike."""
    r = np.atleast_2d(residues)
    turned = r * np.exp(-0.5j * np.angle(np.sum(r**2, axis=1)))[:, None]
    largest = turned[np.arange(len(r)), np.argmax(np.abs(turned), axis=1)]
    size = np.where(largest.real < 0, -np.abs(largest), np.abs(largest))
    factor = 1 / np.where(size != 0, size, 1.0)
    return turned * factor[:, None], None if std is None else np.atleast_2d(std) * np.abs(factor)[:, None]


def mpc(shapes: np.ndarray) -> np.ndarray:
    """Modal phase collinearity (module docstring) of each row of (modes, points) [-]."""
    r = np.atleast_2d(shapes)
    power = np.sum(np.abs(r) ** 2, axis=1)
    return np.where(power > 0, (np.abs(np.sum(r**2, axis=1)) / np.where(power > 0, power, 1)) ** 2, np.nan)


@dataclass(frozen=True, eq=False)
class ShapeEstimate:
    """Mode shapes of one configuration from a roving-hammer test.

    points: point, x_mm, y_mm [mm] (the order of the shapes' columns).  modes: one row per
    mode: frequency_hz [Hz] (undamped natural frequency of the pole), std_hz [Hz] (standard
    error of that median over the points, NaN from fewer than two), damping_ratio [-],
    damping_std [-], points_found (points whose peak list had it), mpc [-] and
    max_shape_std [-] (largest standard error of its normalised shape).  residues:
    (modes, points) LSFD residues (:class:`LSFDFit`); shapes: (modes, points) normalised
    (:func:`normalised`); shape_std: their standard errors.  band_hz: the lines fitted
    [Hz] (module docstring; inside every point's peak band).  peak_lists: each point's.
    """

    configuration: str
    points: pd.DataFrame
    modes: pd.DataFrame
    residues: np.ndarray
    shapes: np.ndarray
    shape_std: np.ndarray
    band_hz: tuple[float, float]
    peak_lists: dict[str, PeakList]
    notes: tuple[str, ...] = ()

    def to_frame(self) -> pd.DataFrame:
        """The SHAPES.csv table: one row per mode and point."""
        n_modes, n_points = self.shapes.shape
        return pd.DataFrame(
            {
                "configuration": self.configuration,
                "frequency_hz": np.repeat(self.modes["frequency_hz"].to_numpy(), n_points),
                "x_mm": np.tile(self.points["x_mm"].to_numpy(), n_modes),
                "y_mm": np.tile(self.points["y_mm"].to_numpy(), n_modes),
                "amplitude": self.shapes.real.ravel(),
                "amplitude_imag": self.shapes.imag.ravel(),
            }
        )[CSV_COLUMNS]

    def to_dict(self) -> dict:
        """The ``peaks --points --json`` document: the modes (with MPC and the points that
        found each) and every shape per point with its standard error."""
        points = self.points.to_dict(orient="records")
        return {
            "configuration": self.configuration,
            "band_hz": list(self.band_hz),
            "peaks": self.modes.to_dict(orient="records"),
            "shapes": [
                {
                    "frequency_hz": float(f),
                    "mpc": float(m),
                    "points": [
                        dict(p, amplitude=float(a.real), amplitude_imag=float(a.imag), std=float(e))
                        for p, a, e in zip(points, shape, std)
                    ],
                }
                for f, m, shape, std in zip(
                    self.modes["frequency_hz"], self.modes["mpc"], self.shapes, self.shape_std
                )
            ],
            "notes": list(self.notes),
        }

    def write_peaks_csv(self, path: str | Path) -> None:
        """The modes as a peak list (``configuration,frequency_hz,std_hz,damping_ratio,
        damping_std``, ``%.7g`` as ``PeakList.write_csv`` writes it): the MEASUREMENTS
        whose peaks SHAPES.csv names."""
        frame = self.modes.assign(configuration=self.configuration)[PEAK_COLUMNS]
        write_text(path, frame.to_csv(index=False, float_format="%.7g"))

    def write_csv(self, path: str | Path) -> None:
        """SHAPES.csv, written atomically: frequency_hz printed as the peak list prints it
        (``%.7g``), so it names the same peak, the amplitudes to 7 digits too, the points
        as given."""
        frame = self.to_frame()
        for column in ("frequency_hz", "amplitude", "amplitude_imag"):
            frame[column] = frame[column].map("{:.7g}".format)
        write_text(path, frame.to_csv(index=False))

    def report(self) -> str:
        lines = [
            f"Mode shapes of {self.configuration!r}: {len(self.points)} points, "
            f"{sum(pl.frf.n_hits for pl in self.peak_lists.values())} hits",
            "",
            "  frequency_hz      std_hz  damping_ratio  points   MPC  max shape std",
        ]
        for row in self.modes.itertuples(index=False):
            lines.append(
                f"  {row.frequency_hz:12.3f}  {row.std_hz:10.3g}  {row.damping_ratio:13.4g}  "
                f"{row.points_found:6d}  {row.mpc:.3f}  {row.max_shape_std:13.3g}"
            )
        if self.notes:
            lines += ["", "Notes:", *(f"  - {note}" for note in self.notes)]
        return "\n".join(lines) + "\n"


def _check_points(recordings_by_point, points) -> pd.DataFrame:
    """The points table (point, x_mm, y_mm; a DataFrame or a CSV path) matched to the
    recordings' points, in the table's order."""
    points = read_points(points)
    table = pd.DataFrame({"point": points["point"].astype(str)})
    for axis in ("x_mm", "y_mm"):
        table[axis] = pd.to_numeric(points[axis], errors="coerce").to_numpy()
        bad = np.flatnonzero(~np.isfinite(table[axis].to_numpy()))
        if bad.size:
            value = points[axis].iloc[bad[0]]
            shown = repr(value) if isinstance(value, str) else str(value)
            raise MeasurementError(
                f"points: {axis} of point {table['point'].iloc[bad[0]]!r} is {shown}, not a finite "
                "number; give its position in mm from the plate's corner"
            )
    twice = table["point"].duplicated(keep=False)
    if twice.any():
        name = table["point"][twice].iloc[0]
        rows = [int(i) + 1 for i in np.flatnonzero(table["point"] == name)]
        raise MeasurementError(
            f"points: point {name!r} is listed {len(rows)} times (rows {rows}); give each point once"
        )
    same = table.duplicated(["x_mm", "y_mm"], keep=False)
    if same.any():
        first = table[same].iloc[0]
        others = table["point"][same & (table["x_mm"] == first["x_mm"]) & (table["y_mm"] == first["y_mm"])]
        raise MeasurementError(
            f"points: {', '.join(map(repr, others))} share x_mm, y_mm = ({first['x_mm']:g}, "
            f"{first['y_mm']:g}); a shape needs one point per position: merge their recordings"
        )
    if not isinstance(recordings_by_point, dict) or not recordings_by_point:
        raise MeasurementError(
            "recordings_by_point must map each point to its recordings, e.g. "
            "{'P1': ['P1/hit1.csv', 'P1/hit2.csv'], ...}"
        )
    given = {str(k): v for k, v in recordings_by_point.items()}
    unplaced = [k for k in given if k not in set(table["point"])]
    if unplaced:
        raise MeasurementError(
            f"recordings_by_point: point {unplaced[0]!r} has recordings but no row in points; "
            "add its x_mm, y_mm to the points table"
        )
    for name, x, y in table.itertuples(index=False):
        recordings = given.get(name)
        if recordings is None or (isinstance(recordings, (list, tuple)) and not recordings):
            raise MeasurementError(
                f"recordings_by_point: point {name!r} (x_mm = {x:g}, y_mm = {y:g}) has no "
                "recordings; give its hit files or drop its row from points"
            )
    if len(table) < 2:
        raise MeasurementError(f"points: {len(table)} point given; a mode shape needs at least 2 points")
    return table.reset_index(drop=True)


def _poles(peak_lists: list[PeakList]) -> pd.DataFrame:
    """The modes found at several points (module docstring): frequency_hz, std_hz,
    damping_ratio, damping_std, points_found."""
    found = pd.concat(
        [
            pl.table[["frequency_hz", "damping_ratio", "snr"]].assign(point=j)
            for j, pl in enumerate(peak_lists)
        ],
        ignore_index=True,
    ).sort_values("frequency_hz")
    f, zeta = found["frequency_hz"].to_numpy(), found["damping_ratio"].to_numpy()
    half = zeta * f
    breaks = np.flatnonzero(np.diff(f) > LINK * 0.5 * (half[1:] + half[:-1])) + 1
    need = max(2, math.ceil(MIN_POINTS_SHARE * len(peak_lists)))
    rows = []
    for chain in np.split(np.arange(len(f)), breaks):
        members = found.iloc[chain]
        if members["point"].nunique() < need:
            continue
        best = members[members["snr"] >= members["snr"].max() / SNR_SPAN]
        rows.append(
            {
                "frequency_hz": float(np.median(best["frequency_hz"])),
                "std_hz": _median_error(best["frequency_hz"]),
                "damping_ratio": float(np.median(best["damping_ratio"])),
                "damping_std": _median_error(best["damping_ratio"]),
                "points_found": int(members["point"].nunique()),
            }
        )
    return pd.DataFrame(
        rows, columns=["frequency_hz", "std_hz", "damping_ratio", "damping_std", "points_found"]
    )


def _median_error(values: pd.Series) -> float:
    """Standard error of a median of normal samples: sqrt(pi / 2) s / sqrt(n) (NaN, n < 2)."""
    n = len(values)
    return float(math.sqrt(math.pi / 2) * np.std(values, ddof=1) / math.sqrt(n)) if n >= 2 else math.nan


def recordings_in_folders(
    points, folder: str | Path | None = None
) -> tuple[dict[str, list[Path]], pd.DataFrame]:
    """A roving-hammer test laid out on disk: a points table (CSV: point, x_mm, y_mm) and,
    in ``folder`` (default: the table's own folder), one sub-folder per point named as in
    the table holding that point's hits (as ``tap_simulation.write_roving`` writes them).
    Returns the recordings per point and the table read."""
    table = read_points(points)
    root = Path(folder) if folder is not None else Path(points).parent
    out = {}
    for name in table["point"].astype(str):
        where = root / name
        files = sorted(f for f in where.glob("*") if f.suffix.lower() in READERS) if where.is_dir() else []
        if not files:
            raise MeasurementError(
                f"point {name!r}: no recordings in {str(where)!r} (expected its hits there as "
                f"{', '.join(READERS)} files, one file a hit)"
            )
        out[name] = files
    return out, table


def estimate_shapes(
    recordings_by_point: dict,
    points,
    configuration: str = "original",
    sample_rate: float | None = None,
    band_hz: tuple[float, float] | None = None,
    guide_hz=None,
) -> ShapeEstimate:
    """Mode shapes of one configuration from a roving-hammer test (module docstring).

    recordings_by_point: point name -> its recordings (file paths, or records already read,
    as :func:`identify.recordings.peaks.extract_peaks` takes them).  points: a table or a
    CSV path with columns point, x_mm, y_mm [mm] (the spec's plate coordinates, from the
    corner at the origin).  sample_rate [Hz], band_hz (low, high) [Hz], guide_hz [Hz]: as
    for ``extract_peaks``, applied at every point."""
    table = _check_points(recordings_by_point, points)
    given = {str(k): v for k, v in recordings_by_point.items()}
    peak_lists = {}
    for name in table["point"]:
        try:
            peak_lists[name] = extract_peaks(given[name], configuration, sample_rate, band_hz, guide_hz)
        except MeasurementError as exc:
            raise MeasurementError(f"point {name!r}: {exc}") from None
        if not peak_lists[name].frf.has_force:
            raise MeasurementError(
                f"point {name!r}: its recordings have no force channel; a roving-hammer shape "
                "needs each point's force (the response alone scales with how hard it was hit): "
                "record the hammer's force too"
            )
    lists = list(peak_lists.values())
    modes = _poles(lists)
    notes = []
    if modes.empty:
        raise MeasurementError(
            f"no mode was found at {max(2, math.ceil(MIN_POINTS_SHARE * len(lists)))} or more "
            "points; check the band and that the sensor stays on the plate"
        )
    zeta, w = modes["damping_ratio"].to_numpy(), 2 * np.pi * modes["frequency_hz"].to_numpy()
    pole = -zeta * w + 1j * w * np.sqrt(1 - zeta**2)
    half_hz = zeta * modes["frequency_hz"].to_numpy()
    band = (
        max(modes["frequency_hz"].iloc[0] - MARGIN * half_hz[0], *(pl.band_hz[0] for pl in lists)),
        min(modes["frequency_hz"].iloc[-1] + MARGIN * half_hz[-1], *(pl.band_hz[1] for pl in lists)),
    )
    residues = np.empty((len(modes), len(table)), dtype=complex)
    std = np.empty((len(modes), len(table)))
    for j, pl in enumerate(lists):
        frf = pl.frf
        quantity = frf.quantity if frf.quantity in POWER else "acceleration"
        if quantity != frf.quantity:
            notes.append(f"point {table['point'][j]!r}: response {frf.quantity!r} taken as an acceleration")
        lines = frf.lines(band)
        fit = lsfd(frf.frequency_hz[lines], frf.h1[lines], pole - frf.decay_rate, quantity)
        residues[:, j], std[:, j] = fit.residues[:, 0], fit.residue_std[:, 0]
    shapes, shape_std = normalised(residues, std)
    modes = modes.assign(mpc=mpc(residues), max_shape_std=shape_std.max(axis=1))
    return ShapeEstimate(
        configuration, table, modes, residues, shapes, shape_std, band, peak_lists, tuple(notes)
    )
