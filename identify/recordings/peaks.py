"""Modal peaks of one configuration from its impact-test recordings.

The pipeline: recordings -> hits (:mod:`identify.recordings.readers`) -> averaged FRF H1 with
coherence (:mod:`identify.recordings.frf`) -> poles -> a peak list.

Poles.  The band is cut into sub-bands of a few modes each (:func:`sub_bands`), and the
LSCF estimator (least-squares complex frequency domain, :mod:`identify.recordings.lscf`)
is run on H1 over each for orders (degree / 2) 1, 2, ..., up to about twice its modes:
the stabilisation diagram.  (sdypy-EMA's LSCF, the same estimator on the whole band, was
used before: its import took 0.6 s, pyplot included, and its full-band orders up to 100
spent 0.4 s in the roots of their polynomials, together three quarters of ``peaks`` on a
38-mode plate; ``tests/identify/recordings/test_lscf.py`` checks the two agree.)  A pole is
*stable* when the previous order of its sub-band has one within ``freq_tol`` in
frequency and ``damp_tol`` in damping (``PeakPolicy``); stable poles closer than a
quarter of their half-power half-bandwidth are one column, and a column stable in at
least ``stable_fraction`` of its sub-band's orders is a mode candidate.  Each candidate is
refined by a local pole-residue fit on H1 (variable projection: complex residues, the
neighbouring modes' poles with free residues so a strong neighbour's skirt does not bias
it, and a linear residual term; the poles by Gauss-Newton steps with the exact
Jacobian, or ``scipy.optimize.least_squares`` where those do not converge; overlapping
candidates are fitted together), kept when its modal peak stands ``snr_min`` times above the fit's residual,
and cross-checked against peak picking (local maxima of |H1| in dB with their prominence,
as ``scipy.signal.find_peaks`` defines them, :mod:`identify.recordings.maxima`; Gaussian
interpolation: ``peak_hz``).  Two modes closer than a quarter half-bandwidth
(e.g. a square plate's pair 0.01 % apart) make one column and are reported as one peak:
one sensor cannot tell them apart.  ``frequency_hz`` is the undamped natural frequency
|p| / 2 pi of the pole p (what an FE model predicts), ``damping_ratio`` -Re p / |p|.

Scatter.  The same local fit, seeded with the H1 poles, estimates every mode on each hit's
FRF H_k = Y_k / X_k (all hits at once, :func:`refined_per_record`).  ``std_hz`` is the
standard error of ``frequency_hz``:

    std_hz = s / c4(n) * sqrt(sum_k w_k^2)

with s the sample standard deviation of the n per-hit frequencies, c4(n) its small-sample
bias factor (E[s] = c4 sigma) and w_k the hit's weight in H1 at the mode (|X_k|^2 /
sum |X|^2; 1/n for equal hits), because H1 = sum_k w_k H_k puts the H1 pole at the
weighted mean of the hits' poles to first order.  It is the standard deviation of
``frequency_hz`` over repeated sessions of as many hits (hit-to-hit scatter and noise),
not the model's error; its mean over sessions matches the observed scatter (tests and
``benchmarks.peaks``: ratio 0.97-1.09).  With n hits it is itself uncertain by about
1 / sqrt(2 (n - 1)) (35 % at 5 hits) and (frequency_hz - truth) / std_hz follows
Student's t with n - 1 degrees of freedom.  A mode with fewer than two hit estimates gets
the median relative std of the other modes (flag ``std_pooled``); one hit (or one FRF
record): NaN for all (the CSV's std_hz column is then empty, i.e. not given).

Exponential window: frequencies and damping ratios are corrected with
:func:`identify.recordings.frf.correct_for_window` (true pole = windowed pole + r).

Response-only recordings (a one-channel WAV, e.g. a microphone): no force, so no FRF and
no coherence.  The hits' averaged response spectrum is the FRF times the hammer's force
spectrum, which is smooth and nearly flat over the band a short pulse excites, so the
same poles, stabilisation and local fits find the modes and their damping (free decay).
Every mode is flagged
``response_only`` (its quality) and a note says so.  (Picking peaks alone, as before, took
the leakage ripple and noise of a 40 dB recording for 114 "modes" of a 25-mode band.)

Flags (``quality`` is the first that applies, else "good"): ``response_only`` (no force
channel, see above), ``suspension`` (below
``frf.SUSPENSION_HZ``: a rigid-body mode on the suspension, kept only when the caller's
band reaches down there; the default band starts at that frequency, so suspension peaks
are left out and named in the notes), ``low_coherence`` (gamma^2 < ``coherence_min`` at
the peak), ``weak`` (prominence < ``weak_db`` in |H1| or no local maximum of its own,
or SNR < ``weak_snr`` x ``snr_min``), ``close`` (another mode within two half-power bandwidths),
``single_hit`` (fewer than two hit estimates), ``guided`` (found only by looking near a
``guide_hz`` frequency), ``std_pooled``, ``unpicked`` (no peak picked on |H1| within
the mode's half-power half-bandwidth: ``peak_hz`` is missing, null in JSON and blank in
the report, never NaN).  Peaks picked on |H1| with no stable pole (a
suspension, an anti-resonance's neighbour, a cable) are left out and named in the notes.
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.special import gammaln

from fem.errors import MeasurementError
from fem.io import write_text
from fem.solver.threads import one_blas_thread

from ..reporting.peaks_report import peak_list_text, plot_peaks
from . import frf as frf_module
from .frf import AveragedFRF, Rejection, correct_for_window
from .lscf import lscf_poles
from .maxima import find_peaks, local_maxima, prominences
from .readers import Hit, MeasuredFRF, check_together, read_recordings


@dataclass(frozen=True)
class PeakPolicy:
    """What ``peaks`` counts as a mode, in one place (``extract_peaks(..., policy=)``;
    the defaults are ``PEAK_POLICY``, tabled in docs/recordings.md).

    Stabilisation: ``freq_tol`` and ``damp_tol``, the relative change of frequency and of
    damping within which a pole is stable from one order to the next; a column must be
    stable in ``stable_fraction`` of the orders of its sub-band.

    Sub-bands (:func:`sub_bands`): about ``peaks_per_sub_band`` peaks picked on |H1| per
    sub-band and at least ``min_sub_band_lines`` lines, each fitted on its core widened by
    ``sub_band_overlap`` of its width either side, up to the order (degree / 2) 2 x the
    picked peaks on the fitted lines + ``extra_orders``, within ``min_order``..``max_order``
    and at most one order per ``lines_per_order`` lines: noise peaks inflate the count of
    picked peaks, and a model with more freedom than that fits the noise (at 20 dB SNR a
    mode's pole then wanders by 20 % in damping from order to order and is never stable;
    the full-band estimator used before had 28).

    A mode: a damping ratio below ``max_damping`` (above it, not a plate mode nor a
    computational pole worth keeping); its modal peak |A| / |Re p| at least ``snr_min``
    times the local fit's RMS residual per line (``snr_guided`` near a guide frequency,
    within ``guide_rel`` of it, where the hits must also confirm it, scattering by at most
    ``guided_scatter`` of its half-power bandwidth: a weak real mode in 3e-3 noise
    scatters by 0.2-0.4, noise fitted as a mode near a node by 1.5).

    Flags and notes: ``weak`` below ``weak_db`` of prominence in |H1| [dB] or below
    ``weak_snr`` x ``snr_min``; peaks picked on |H1| from ``pick_db`` (the lab's weakest
    modes stand 0.5 dB above their neighbourhood); ``low_coherence`` below
    ``coherence_min`` (gamma^2 at the peak); peaks below the band of ``suspension_db``
    prominence named as suspension modes (a suspension mode stands tall); the
    ``noted_peaks`` most prominent spurious peaks named."""

    freq_tol: float = 2e-3
    damp_tol: float = 0.10
    stable_fraction: float = 0.3
    peaks_per_sub_band: int = 8
    min_sub_band_lines: int = 800
    sub_band_overlap: float = 0.25
    extra_orders: int = 10
    min_order: int = 12
    max_order: int = 40
    lines_per_order: int = 28
    max_damping: float = 0.1
    snr_min: float = 10.0
    snr_guided: float = 3.0
    guide_rel: float = 0.03
    guided_scatter: float = 0.75
    weak_db: float = 1.0
    weak_snr: float = 3.0
    pick_db: float = 0.3
    coherence_min: float = 0.9
    suspension_db: float = 6.0
    noted_peaks: int = 8


#: The defaults.
PEAK_POLICY = PeakPolicy()

# Numerics of the local fits: how far they iterate, not what counts as a mode.
#: Local fits (:func:`_gauss_newton`): at most NEWTON_STEPS Gauss-Newton steps, converged
#: once the largest is below NEWTON_STEP in units of the pole's decay, so of its half-power
#: half-bandwidth (the steps shrink 10-100 times each, so the error left is a small part of
#: that, far below a hit-to-hit scatter of 2-10 % of it; std_hz and damping_std agree with
#: Levenberg-Marquardt's to 1e-4 of themselves, ``tests/identify/recordings/test_peaks.py``).
NEWTON_STEPS = 10
NEWTON_STEP = 1e-5
#: A hit's pole is converged once the step is below this fraction of its distance from the
#: H1 pole: a weak mode's hits scatter by half a half-bandwidth, where the steps shrink
#: only 2-3 times each, and an error of 1 % of that scatter is nothing to its standard
#: deviation (known to 35 % from 5 hits).
PER_HIT_RELATIVE = 1e-2
#: Half-width of a local fit's window, in half-power half-bandwidths (zeta f).
FIT_HALF_WIDTHS = 4.0
CSV_COLUMNS = ["configuration", "frequency_hz", "std_hz", "damping_ratio", "damping_std"]
FLAG_ORDER = (
    "response_only",
    "suspension",
    "low_coherence",
    "weak",
    "close",
    "single_hit",
    "guided",
    "std_pooled",
    "unpicked",
)


@dataclass(frozen=True, eq=False)
class Stabilisation:
    """The stabilisation diagram: every LSCF pole in the band with its model order
    (denominator degree), frequency [Hz] and damping ratio (window-corrected), and whether
    it is stable."""

    order: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    stable: np.ndarray
    pole: np.ndarray  # as identified on the (windowed) FRF [rad/s]
    sub_band: np.ndarray  # the sub-band each pole was found in (index into ``orders``)
    orders: np.ndarray  # how many orders each sub-band was fitted at (degrees 2, 4, ...)


@dataclass(frozen=True)
class SubBand:
    """A piece of the band: the poles in ``core_hz`` [Hz] are kept from an LSCF fit on
    ``fitted_hz`` (the core and some of its neighbours') of degrees 2 .. 2 x ``order``."""

    core_hz: tuple[float, float]
    fitted_hz: tuple[float, float]
    order: int


@dataclass(frozen=True, eq=False)
class PeakList:
    """The peaks of one configuration.

    table: one row per mode: frequency_hz [Hz], std_hz [Hz] (standard error of
    frequency_hz, see the module docstring), damping_ratio [-], coherence [-] (gamma^2
    at the peak), prominence_db [dB] (of the peak in |H1|, 0 when it has no local
    maximum of its own), snr [-] (modal peak / fit residual), hits (estimates behind
    std_hz), peak_hz [Hz] (peak picking with interpolation: the cross-check), quality
    and flags.  frf: the averaged FRF; band_hz: the searched band [Hz]; rejected: hits
    left out and why; notes: what was done and what was left out.
    """

    configuration: str
    table: pd.DataFrame
    frf: AveragedFRF
    band_hz: tuple[float, float]
    rejected: tuple[Rejection, ...] = ()
    notes: tuple[str, ...] = ()
    diagram: Stabilisation | None = None
    policy: PeakPolicy = PEAK_POLICY

    def __len__(self) -> int:
        return len(self.table)

    def to_frame(self) -> pd.DataFrame:
        return self.table.assign(configuration=self.configuration)[["configuration", *self.table.columns]]

    def to_dict(self) -> dict:
        """JSON-ready: NaN becomes None."""

        def plain(v):
            v = v.item() if isinstance(v, np.generic) else v
            return None if isinstance(v, float) and not math.isfinite(v) else v

        return {
            "configuration": self.configuration,
            "band_hz": list(self.band_hz),
            "hits_used": list(self.frf.sources),
            "exponential_window_rate": self.frf.decay_rate,
            "peaks": [{k: plain(v) for k, v in row.items()} for row in self.table.to_dict("records")],
            "rejected": [{"source": r.source, "reason": r.reason} for r in self.rejected],
            "notes": list(self.notes),
        }

    def report(self) -> str:
        """The text report (``reporting.peaks_report.peak_list_text``)."""
        return peak_list_text(self)

    def write_csv(self, path: str | Path) -> None:
        """The peak-list CSV: configuration,frequency_hz,std_hz,damping_ratio,damping_std."""
        write_text(path, self.to_frame()[CSV_COLUMNS].to_csv(index=False, float_format="%.7g"))

    def plot(self, directory: str | Path) -> list[Path]:
        return plot_peaks(self, directory, self.policy.coherence_min)


# --- local pole-residue fit ------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class LocalFit:
    """Poles [rad/s] of a local fit, each mode's SNR, and whether the fit converged
    with every pole inside its window."""

    pole: np.ndarray
    snr: np.ndarray
    ok: bool


def _stacked(m: np.ndarray) -> np.ndarray:
    """Complex (..., lines, columns) as real (..., 2 lines, columns): real parts over
    imaginary parts."""
    return np.concatenate([m.real, m.imag], axis=-2)


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``numpy.linalg.solve`` over a batch (records, n, n), NaN for a record whose matrix
    is singular (two free poles met, or one ran off) instead of an error for all."""
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        out = np.full(np.broadcast_shapes(a.shape[:-1], b.shape[:-2] + (a.shape[-1],)) + b.shape[-1:], np.nan)
        for j in range(len(a)):
            try:
                out[j] = np.linalg.solve(a[j], b[j])
            except np.linalg.LinAlgError:
                pass
        return out


class _Projection:
    """Variable projection of the local model (Golub & Pereyra 1973)

        sum_r A_r/(s - p_r) + conj(A_r)/(s - conj p_r) + c0 + c1 (w - wc)

    with real coefficients (Re A_r, Im A_r, c0, c1 complex), real-stacked (rows: real
    parts, then imaginary parts), for a batch of records at once (H1 alone, or every hit's
    FRF: the same lines and neighbours, each record its own poles and residues).  The
    columns that do not move, those of the fixed neighbours and of the residual terms,
    are projected out once (Q0 of their QR): for the free poles p(x) the free columns
    B(x) = (I - Q0 Q0^T) A_free(x) and the data (I - Q0 Q0^T) h give the same residual
    as the whole basis, r(x) = B c - h, with c(x) = B^+ h the free residues, and its
    exact Jacobian

        dr/dx_k = (I - Q0 Q0^T - Q Q^T) (dA/dx_k) c - Q R^-T (dA/dx_k)^T r

    (B = Q R).  Only the two columns of the pole moved by x_k depend on it, so each
    evaluation costs one QR of 2 columns a free pole and a few matrix products, batched
    over the records.  Pole r of record j is p_jr = -d_r exp(x_j,2r+1) + i (Im seed_r +
    d_r x_j,2r), d_r = |Re seed_r|."""

    def __init__(self, frequency_hz: np.ndarray, h: np.ndarray, seed: np.ndarray, fixed: np.ndarray):
        self.s = 2j * np.pi * frequency_hz
        centre = float(self.s.imag.mean())
        x = ((self.s.imag - centre) / centre)[:, None]
        a, b = 1 / (self.s[:, None] - fixed), 1 / (self.s[:, None] - fixed.conj())
        self.q0 = np.linalg.qr(
            _stacked(np.hstack([a + b, 1j * (a - b), np.ones_like(x), 1j * np.ones_like(x), x, 1j * x]))
        )[0]
        data = _stacked(np.atleast_2d(h).T).T  # (records, 2 lines)
        self.h = data - (data @ self.q0) @ self.q0.T
        self.seed = seed
        self.scale = np.abs(seed.real)
        self._at = None

    @property
    def records(self) -> int:
        return len(self.h)

    def pole(self, x: np.ndarray) -> np.ndarray:
        """(records, poles) [rad/s] at the parameters x (records, 2 poles)."""
        return -self.scale * np.exp(x[:, 1::2]) + 1j * (self.seed.imag + self.scale * x[:, 0::2])

    def _state(self, x: np.ndarray):
        if self._at is None or not np.array_equal(self._at[0], x):
            p = self.pole(x)
            a = 1 / (self.s[:, None] - p[:, None, :])  # (records, lines, poles)
            b = 1 / (self.s[:, None] - p.conj()[:, None, :])
            free = _stacked(np.concatenate([a + b, 1j * (a - b)], axis=-1))
            free -= self.q0 @ (self.q0.T @ free)
            q, r = np.linalg.qr(free)
            c = _solve(r, np.einsum("jlk,jl->jk", q, self.h)[..., None])[..., 0]
            self._at = (x.copy(), p, a, b, q, r, c, np.einsum("jlk,jk->jl", free, c) - self.h)
        return self._at[1:]

    def residual(self, x: np.ndarray) -> np.ndarray:
        """(records, 2 lines)."""
        return self._state(x)[-1]

    def residues(self, x: np.ndarray) -> np.ndarray:
        """The free poles' complex residues A_r at x, (records, poles)."""
        c = self._state(x)[-2]
        m = len(self.seed)
        return c[:, :m] + 1j * c[:, m:]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(records, 2 lines, 2 poles): each record's residual by its own parameters."""
        p, a, b, q, rmat, c, res = self._state(x)
        m = p.shape[1]
        plus, minus = a**2 + b**2, a**2 - b**2
        # d(column)/dx for the frequency (x_2r) and decay (x_2r+1) parameters of each free
        # pole: of its Re A column (d_re) and of its Im A column (d_im)
        d_re = np.empty((self.records, len(self.s), 2 * m), dtype=complex)
        d_im = np.empty_like(d_re)
        d_re[..., 0::2], d_re[..., 1::2] = 1j * self.scale * minus, p.real[:, None, :] * plus
        d_im[..., 0::2], d_im[..., 1::2] = -self.scale * plus, 1j * p.real[:, None, :] * minus
        pole_of = np.repeat(np.arange(m), 2)
        moved = _stacked(d_re * c[:, None, pole_of] + d_im * c[:, None, m + pole_of])  # (dA/dx_k) c
        first = moved - self.q0 @ (self.q0.T @ moved) - q @ (q.transpose(0, 2, 1) @ moved)
        v = np.zeros((self.records, 2 * m, 2 * m))
        k = np.arange(2 * m)
        v[:, pole_of, k] = np.einsum("jlk,jl->jk", _stacked(d_re), res)
        v[:, m + pole_of, k] = np.einsum("jlk,jl->jk", _stacked(d_im), res)
        return first - q @ _solve(rmat.transpose(0, 2, 1), v)


def _gauss_newton(problem: _Projection, relative: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Newton steps of ``problem`` from its seeds, every record at once: the
    parameters (records, 2 poles) and whether each record converged (its largest step
    below ``NEWTON_STEP``, or below ``relative`` x its largest parameter, within
    ``NEWTON_STEPS``; its residual below the start's)."""
    x = np.zeros((problem.records, 2 * len(problem.seed)))
    start = np.sum(problem.residual(x) ** 2, axis=1)
    done = np.zeros(problem.records, dtype=bool)
    with np.errstate(all="ignore"):
        for _ in range(NEWTON_STEPS):
            q, r = np.linalg.qr(problem.jacobian(x))
            step = -_solve(r, np.einsum("jlk,jl->jk", q, problem.residual(x))[..., None])[..., 0]
            step[done] = 0.0
            x = x + step
            done |= np.max(np.abs(step), axis=1) < np.maximum(
                NEWTON_STEP, relative * np.max(np.abs(x), axis=1)
            )
            if done.all():
                break
        done &= np.all(np.isfinite(problem.pole(x)), axis=1) & (
            np.sum(problem.residual(x) ** 2, axis=1) <= start
        )
    return x, done


def _least_squares(problem: _Projection) -> tuple[np.ndarray, bool]:
    """The parameters (1, 2 poles) of a one-record ``problem`` by
    ``scipy.optimize.least_squares`` (Levenberg-Marquardt), and whether it converged."""
    from scipy import optimize  # here: most fits converge without it (0.2 s of imports)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        result = optimize.least_squares(
            lambda y: problem.residual(y[None])[0],
            np.zeros(2 * len(problem.seed)),
            jac=lambda y: problem.jacobian(y[None])[0],
            method="lm",
            x_scale=1.0,
        )
    return result.x[None], bool(result.success)


def local_fit(
    frequency_hz: np.ndarray, h: np.ndarray, seed: np.ndarray, fixed: np.ndarray | None = None
) -> LocalFit:
    """Poles near ``seed`` [rad/s] fitted to the complex FRF ``h`` on ``frequency_hz``.

    Model: sum of conjugate pole pairs with complex residues, the neighbouring modes'
    ``fixed`` poles (residues fitted) and c0 + c1 (w - wc); the linear parameters are
    projected out (:class:`_Projection`), the poles (frequency shift and log decay, in
    units of each seed's decay) are found by Gauss-Newton steps with the exact Jacobian
    (:func:`_gauss_newton`) or, where those do not converge (a seed far from its pole),
    by Levenberg-Marquardt (:func:`_least_squares`).  snr: each mode's peak
    |A_r| / |Re p_r| over the RMS residual per line."""
    fixed = np.array([], dtype=complex) if fixed is None else fixed
    problem = _Projection(frequency_hz, h, seed, fixed)
    x, done = _gauss_newton(problem)
    success = bool(done[0])
    if not success:
        x, success = _least_squares(problem)
    p, r = problem.pole(x)[0], problem.residual(x)[0]
    rms = np.sqrt(np.sum(r**2) / len(frequency_hz)) + 1e-300
    inside = (p.imag / (2 * np.pi) > frequency_hz[0]) & (p.imag / (2 * np.pi) < frequency_hz[-1])
    decay = np.abs(p.real)
    # an undamped pole: 0, no peak
    snr = np.abs(problem.residues(x)[0]) / np.where(decay > 0, decay, np.inf) / rms
    return LocalFit(p, snr, success and bool(np.all(np.isfinite(p)) and inside.all()))


def refined_per_record(
    frequency_hz: np.ndarray, h: np.ndarray, pole: np.ndarray, fixed: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The poles ``pole`` [rad/s] (fitted on H1) refitted on each record of ``h``
    (records, lines), all records at once (:func:`_gauss_newton`; a hit's pole lies within
    a few % of a half-power bandwidth of H1's, the hit-to-hit scatter): (records, poles)
    and whether each record converged (each pole is judged by the caller: a weak
    neighbour that runs off must not take a strong mode's estimate with it); a record
    whose steps do not converge is refitted by Levenberg-Marquardt alone."""
    problem = _Projection(frequency_hz, h, pole, fixed)
    x, done = _gauss_newton(problem, PER_HIT_RELATIVE)
    for j in np.flatnonzero(~done):
        x[j], done[j] = (
            v[0] if isinstance(v, np.ndarray) else v
            for v in _least_squares(_Projection(frequency_hz, h[j], pole, fixed))
        )
    with np.errstate(all="ignore"):
        return problem.pole(x), done


def _half_window(frf: AveragedFRF, pole: np.ndarray) -> np.ndarray:
    """Half-width [Hz] of each pole's fit window: FIT_HALF_WIDTHS half-power
    half-bandwidths, at least two lines' worth."""
    return FIT_HALF_WIDTHS * np.maximum(np.abs(pole.real) / (2 * np.pi), 2 * frf.resolution_hz)


def _neighbourhoods(frf: AveragedFRF, seeds: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """For each seed: the poles fitted with it (those whose fit windows overlap its
    own), the fixed neighbours (every other seed inside the joint window, and the
    nearest one beyond each edge) and the window's lines.  Not transitive: in a dense
    band (a plate's modal density is constant, its half-bandwidths grow with
    frequency) overlapping windows would otherwise chain every mode into one fit."""
    f = seeds.imag / (2 * np.pi)
    half = _half_window(frf, seeds)
    order = np.argsort(f)
    out = []
    for i in range(len(seeds)):
        joint = np.flatnonzero(np.abs(f - f[i]) < half + half[i])
        joint = joint[np.argsort(f[joint])]
        lo, hi = (f[joint] - half[joint]).min(), (f[joint] + half[joint]).max()
        inside = (f >= lo) & (f <= hi)
        inside[joint] = False
        below, above = order[f[order] < lo], order[f[order] > hi]
        fixed = np.concatenate([below[-1:], np.flatnonzero(inside), above[:1]])
        out.append((joint, fixed, frf.lines((lo, hi))))
    return out


def _fit_all(
    frf: AveragedFRF, h: np.ndarray, seeds: np.ndarray, cache: dict | None = None, only=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local fits of every seed (or of the seeds at the indices ``only``) with its
    neighbourhood (:func:`_neighbourhoods`) on ``h``: poles, SNR, success per seed (NaN,
    0, False where not fitted).  ``cache`` (a dict kept by the caller for one ``h``) skips
    fits already made with the same free and fixed poles."""
    pole = np.full(len(seeds), np.nan + 0j)
    snr = np.zeros(len(seeds))
    ok = np.zeros(len(seeds), dtype=bool)
    cache = {} if cache is None else cache
    for i, (joint, fixed, lines) in enumerate(_neighbourhoods(frf, seeds)):
        if (only is not None and i not in only) or len(lines) < 2 * (len(joint) + len(fixed)) + 4:
            continue
        key = (seeds[joint].tobytes(), seeds[fixed].tobytes())
        if key not in cache:
            cache[key] = local_fit(frf.frequency_hz[lines], h[lines], seeds[joint], seeds[fixed])
        fit = cache[key]
        at = int(np.flatnonzero(joint == i)[0])
        pole[i], snr[i], ok[i] = fit.pole[at], fit.snr[at], fit.ok
    return pole, snr, ok


# --- stabilisation diagram ---------------------------------------------------------------


def sub_bands(
    frf: AveragedFRF, band_hz, picked: pd.DataFrame, policy: PeakPolicy = PEAK_POLICY
) -> list[SubBand]:
    """The band cut into equally wide sub-bands (a plate's modal density is constant) of
    about ``peaks_per_sub_band`` peaks of at least ``weak_db`` picked on |H1| (stand-ins
    for its modes) each and at least ``min_sub_band_lines`` lines, each cut moved half-way
    between the two such peaks either side of it (two cuts between the same peaks are
    one).  Each is fitted on its core widened by ``sub_band_overlap`` of its width either
    side (beyond the band too, where the FRF has lines), so that a mode near a cut or the
    band's edge is modelled with its neighbours and away from where the ends of the
    fitted lines meet on the circle (:data:`identify.recordings.lscf.ARC`), up to the
    order (degree / 2) 2 x the peaks on the fitted lines + ``extra_orders``
    (over-modelling: noise and the residual terms of the modes outside take computational
    poles), at least ``min_order``, at most ``max_order`` and one per ``lines_per_order``
    fitted lines (``policy``, a ``PeakPolicy``)."""
    lo, hi = band_hz
    f = picked["frequency_hz"].to_numpy()
    f = np.sort(f[(f > lo) & (f < hi) & (picked["prominence_db"].to_numpy() >= policy.weak_db)])
    most = max(1, len(frf.lines(band_hz)) // policy.min_sub_band_lines)
    count = int(np.clip(round(len(f) / policy.peaks_per_sub_band), 1, most))
    cuts = np.unique([lo, *(_between_peaks(lo + k * (hi - lo) / count, f) for k in range(1, count)), hi])
    out = []
    for a, b in itertools.pairwise(cuts):
        margin = policy.sub_band_overlap * (b - a)
        fitted = (max(frf.frequency_hz[1], a - margin), min(frf.frequency_hz[-1], b + margin))
        peaks = int(np.sum((f >= fitted[0]) & (f <= fitted[1])))
        highest = min(policy.max_order, len(frf.lines(fitted)) // policy.lines_per_order)
        order = np.clip(2 * peaks + policy.extra_orders, policy.min_order, highest)
        out.append(SubBand((a, b), fitted, int(order)))
    return out


def _between_peaks(cut: float, peaks_hz: np.ndarray) -> float:
    """``cut`` [Hz] moved half-way between the sorted ``peaks_hz`` either side of it."""
    i = int(np.searchsorted(peaks_hz, cut))
    return 0.5 * (peaks_hz[i - 1] + peaks_hz[i]) if 0 < i < len(peaks_hz) else cut


def stabilisation(frf: AveragedFRF, bands: list[SubBand], policy: PeakPolicy = PEAK_POLICY) -> Stabilisation:
    """LSCF poles (:func:`identify.recordings.lscf.lscf_poles`) of H1 on each sub-band for
    degrees 2, 4, ..., 2 x its order, those in its core kept, with stability between
    successive degrees (``policy.freq_tol``, ``policy.damp_tol``)."""
    orders, poles, part = [], [], []
    for k, sub in enumerate(bands):
        lines = frf.lines(sub.fitted_hz)
        degrees = list(range(2, 2 * sub.order + 1, 2))
        for degree, p in zip(
            degrees, lscf_poles(frf.frequency_hz[lines], frf.h1[lines], sub.fitted_hz, degrees)
        ):
            f, zeta = correct_for_window(p, frf.decay_rate)
            keep = (
                (p.imag > 0)
                & (p.real < 0)
                & (f >= sub.core_hz[0])
                & (f < sub.core_hz[1])
                & (zeta > 0)
                & (zeta < policy.max_damping)
            )
            orders.append(np.full(keep.sum(), degree))
            poles.append(p[keep])
            part.append(np.full(keep.sum(), k))
    order, pole, band = np.concatenate(orders), np.concatenate(poles), np.concatenate(part)
    f, zeta = correct_for_window(pole, frf.decay_rate)
    wf, wz = np.abs(pole), -pole.real / np.abs(pole)
    stable = np.zeros(len(pole), dtype=bool)
    for k in np.unique(band):
        for o in np.unique(order[band == k])[1:]:
            now, before = (order == o) & (band == k), (order == o - 2) & (band == k)
            if before.any():
                close_f = np.abs(wf[now][:, None] / wf[before] - 1) < policy.freq_tol
                close_z = np.abs(wz[now][:, None] / wz[before] - 1) < policy.damp_tol
                stable[now] = (close_f & close_z).any(axis=1)
    degrees = np.array([sub.order for sub in bands])
    return Stabilisation(order, f, zeta, stable, pole, band, degrees)


def _columns(diagram: Stabilisation, stable_fraction: float) -> np.ndarray:
    """Seed poles [rad/s] of the stable columns, each the median over its poles, kept when
    stable in at least ``stable_fraction`` of the orders of its sub-band (of the sub-bands
    it spans, near a cut: the larger).  A column is a single linkage of stable poles
    within a quarter of their half-power half-bandwidth, split in two (or more) where that
    many poles of one order lie in it in at least ``stable_fraction`` of the orders: an
    order gives one pole a mode, so those are close modes (a pair 0.2 % apart, each
    wider than their spacing) that the linkage chained."""
    keep = diagram.stable
    p, o, b = diagram.pole[keep], diagram.order[keep], diagram.sub_band[keep]
    if not len(p):
        return np.array([], dtype=complex)
    idx = np.argsort(p.imag)
    p, o, b = p[idx], o[idx], b[idx]
    gap = np.diff(p.imag) > 0.25 * np.abs(p.real[1:])
    seeds = []
    for members in np.split(np.arange(len(p)), np.flatnonzero(gap) + 1):
        orders = diagram.orders[b[members]].max()
        for column in _split(members, b, o, p, stable_fraction * orders):
            if len(set(zip(b[column], o[column]))) >= stable_fraction * orders:
                seeds.append(np.median(p[column].real) + 1j * np.median(p[column].imag))
    return np.array(seeds)


def _split(
    members: np.ndarray, band: np.ndarray, order: np.ndarray, pole: np.ndarray, enough: float
) -> list[np.ndarray]:
    """``members`` (indices, by frequency) as the columns of ``_columns``: one, or k where
    at least ``enough`` (sub-band, order) pairs hold k poles each and the k medians stand
    apart by more than the linkage's quarter of the narrower one's half-power
    half-bandwidth (closer, they are one mode whose pole splits in some orders: noise);
    the j-th pole of those orders is column j, every other pole joins the column whose
    median is nearest."""
    keys = list(zip(band[members], order[members]))
    count: dict = {}
    for key in keys:
        count[key] = count.get(key, 0) + 1
    k = max(count.values())
    while k > 1 and sum(c == k for c in count.values()) < enough:
        k -= 1
    if k == 1:
        return [members]
    rank, seen = np.full(len(members), -1), {}
    for i, key in enumerate(keys):
        if count[key] == k:
            rank[i] = seen.get(key, 0)
            seen[key] = rank[i] + 1
    centres = np.array([np.median(pole[members[rank == j]].imag) for j in range(k)])
    decays = np.array([np.median(np.abs(pole[members[rank == j]].real)) for j in range(k)])
    if np.any(np.diff(centres) <= 0.25 * np.minimum(decays[:-1], decays[1:])):
        return [members]  # a mode whose pole splits in some orders (noise), not two modes
    loose = rank < 0
    rank[loose] = np.argmin(np.abs(pole[members[loose]].imag[:, None] - centres), axis=1)
    return [members[rank == j] for j in range(k)]


# --- peak picking --------------------------------------------------------------------------


def picked_peaks(
    frequency_hz: np.ndarray,
    magnitude: np.ndarray,
    lines: np.ndarray,
    prominence_db: float = PEAK_POLICY.pick_db,
) -> pd.DataFrame:
    """Local maxima of 20 log10 |H| in ``lines`` with at least ``prominence_db``:
    frequency by Gaussian interpolation (a parabola through the three dB values)."""
    level = 20 * np.log10(np.abs(magnitude[lines]) + 1e-300)
    i, prom = find_peaks(level, prominence_db)
    keep = (i > 0) & (i < len(level) - 1)
    i, prom = i[keep], prom[keep]
    a, b, c = level[i - 1], level[i], level[i + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = np.where(a - 2 * b + c < 0, 0.5 * (a - c) / (a - 2 * b + c), 0.0)
    df = frequency_hz[1] - frequency_hz[0]
    return pd.DataFrame(
        {"frequency_hz": frequency_hz[lines][i] + shift * df, "prominence_db": prom, "line": lines[i]}
    )


def _prominences_at(frf: AveragedFRF, lines: np.ndarray, f: np.ndarray, half_bw: np.ndarray) -> np.ndarray:
    """Prominence [dB] of the most prominent local maximum of |H1| within half_bw[j] of
    each f[j] (0: none)."""
    level = 20 * np.log10(np.abs(frf.h1[lines]) + 1e-300)
    maxima = local_maxima(level)
    at, prominent = frf.frequency_hz[lines][maxima], prominences(level, maxima)
    out = np.zeros(len(f))
    for j in range(len(f)):
        near = np.abs(at - f[j]) <= half_bw[j]
        out[j] = prominent[near].max() if near.any() else 0.0
    return out


# --- the entry point -------------------------------------------------------------------


def _c4(n: np.ndarray) -> np.ndarray:
    n = np.asarray(n, dtype=float)
    return np.sqrt(2 / (n - 1)) * np.exp(gammaln(n / 2) - gammaln((n - 1) / 2))


def _check_band(band_hz, nyquist: float) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in band_hz)
    except (TypeError, ValueError):
        raise MeasurementError(
            f"band_hz = {band_hz!r} must be two frequencies (low, high) in Hz, e.g. (20, 1000)"
        ) from None
    if not (0 <= lo < hi <= nyquist):
        raise MeasurementError(
            f"band_hz = ({lo:g}, {hi:g}) must satisfy 0 <= low < high <= {nyquist:g} Hz (half the "
            "sample rate); give a band inside the measured range"
        )
    return lo, hi


def _check_guide(guide_hz) -> np.ndarray:
    try:
        guide = np.sort(np.atleast_1d(np.asarray(guide_hz, dtype=float)))
    except (TypeError, ValueError):
        guide = np.array([np.nan])
    if not len(guide) or not np.all(np.isfinite(guide) & (guide > 0)):
        raise MeasurementError(
            f"guide_hz = {guide_hz!r} must be positive frequencies in Hz, e.g. the model's "
            "[129.3, 191.2]; leave it out to search the whole band"
        )
    return guide


def _band(frf_records, hits, band_hz, guide_hz, nyquist) -> tuple[float, float]:
    if band_hz is not None:
        return _check_band(band_hz, nyquist)
    if hits:
        lo, hi = frf_module.default_band(hits)
    else:
        f = frf_records[0].frequency_hz
        lo, hi = max(frf_module.SUSPENSION_HZ, f[0]), f[-1]
    if guide_hz is not None and len(guide_hz):
        lo, hi = max(lo, 0.8 * min(guide_hz)), min(nyquist, 1.2 * max(guide_hz))
    return lo, hi


@one_blas_thread
def extract_peaks(
    recordings,
    configuration: str = "original",
    sample_rate: float | None = None,
    band_hz: tuple[float, float] | None = None,
    guide_hz=None,
    max_order: int | None = None,
    policy: PeakPolicy = PEAK_POLICY,
) -> PeakList:
    """The peak list of one configuration from its recordings.

    recordings: file paths (CSV, WAV, UFF/UNV; several files = several hits), or Hit /
    MeasuredFRF records already read.  sample_rate [Hz]: for CSV files without a time_s
    column (checked against the files otherwise).  band_hz: (low, high) [Hz] searched;
    default: from 20 Hz (suspension modes below) to where the hammer's force spectrum has
    dropped 10 dB, or 0.8-1.2 x the ``guide_hz`` range when given.  guide_hz: predicted
    model frequencies [Hz] (optional): modes not found near them are looked for harder
    (flag "guided").  max_order: the highest LSCF order (denominator degree / 2) of any
    sub-band (default ``policy.max_order``; each sub-band's from the peaks picked on it).
    policy: what counts as a mode (``PeakPolicy``; default ``PEAK_POLICY``).
    """
    if max_order is not None:
        policy = replace(policy, max_order=max_order)
    given = recordings if isinstance(recordings, (list, tuple)) else [recordings]
    if given and all(isinstance(r, (Hit, MeasuredFRF)) for r in given):
        records = check_together(given)
    else:
        records = read_recordings(recordings, sample_rate)
    hits = [r for r in records if isinstance(r, Hit)]
    frfs = [r for r in records if isinstance(r, MeasuredFRF)]
    nyquist = hits[0].sample_rate / 2 if hits else float(frfs[0].frequency_hz[-1])
    guide = None if guide_hz is None else _check_guide(guide_hz)
    band = _band(frfs, hits, band_hz, guide, nyquist)
    frf = frf_module.average_hits(hits, band) if hits else frf_module.from_measured(frfs)
    notes = list(frf.notes)
    lines = frf.lines(band)
    if len(lines) < 16:
        raise MeasurementError(
            f"band_hz = ({band[0]:g}, {band[1]:g}) holds {len(lines)} spectral lines; need at least "
            "16: widen the band or record longer hits"
        )
    picked = picked_peaks(frf.frequency_hz, frf.h1, lines, policy.pick_db)
    _note_below_band(frf, band, notes, policy.suspension_db)
    diagram = stabilisation(frf, sub_bands(frf, band, picked, policy), policy)
    seeds = _columns(diagram, policy.stable_fraction)
    found = _refine(frf, seeds, notes, policy)
    if guide is not None:
        found = _look_near_guides(frf, guide, picked, diagram, found, notes, policy)
    table = _table(frf, lines, found, picked, notes, policy)
    if frf.n_hits == 1:
        notes.append("one hit: std_hz cannot be estimated (NaN); repeat the hit for a scatter")
    return PeakList(configuration, table, frf, band, frf.rejected, tuple(notes), diagram, policy)


def _note_below_band(frf: AveragedFRF, band, notes: list[str], prominence_db: float) -> None:
    """Name the peaks below the band of ``prominence_db`` in ``notes`` (suspension modes)."""
    below = np.flatnonzero((frf.frequency_hz >= 1.0) & (frf.frequency_hz < band[0]))
    if len(below) >= 3:
        low = picked_peaks(frf.frequency_hz, frf.h1, below, prominence_db)
        if len(low):
            notes.append(
                f"peaks below the band at {', '.join(f'{f:.1f}' for f in low['frequency_hz'])} Hz "
                "(suspension modes of a free plate?) left out"
            )


@dataclass(frozen=True)
class _Poles:
    """The modes found: their poles [rad/s] as fitted on the windowed H1 (s = -sigma +
    i omega; ``correct_for_window`` gives frequency and damping), each one's SNR [-] (its
    peak over the local fit's residual) and whether each was found only by looking near
    a guide frequency."""

    pole: np.ndarray
    snr: np.ndarray
    guided: np.ndarray


def _refine(frf: AveragedFRF, seeds: np.ndarray, notes: list[str], policy: PeakPolicy) -> _Poles:
    """Fit the stable columns on H1; drop weak (``policy.snr_min``), too damped
    (``policy.max_damping``) or duplicated ones and refit."""
    cache: dict = {}
    while True:
        pole, snr, ok = _fit_all(frf, frf.h1, seeds, cache)
        f, zeta = correct_for_window(pole, frf.decay_rate)
        bad = ~ok | (snr < policy.snr_min) | ~(zeta > 0) | (zeta > policy.max_damping)
        dup = np.zeros(len(seeds), dtype=bool)
        order = np.argsort(f)
        for a, b in itertools.pairwise(order):
            if abs(pole[b].imag - pole[a].imag) < 0.1 * abs(pole[a].real):
                dup[a if snr[a] < snr[b] else b] = True
        drop = bad | dup
        if not drop.any():
            return _Poles(pole, snr, np.zeros(len(pole), dtype=bool))
        w = int(np.argmin(np.where(drop, snr, np.inf)))
        reason = (
            "the local fit failed"
            if not ok[w]
            else f"damping ratio {zeta[w]:.3g} outside (0, {policy.max_damping:g})"
            if not 0 < zeta[w] <= policy.max_damping
            else f"its peak is only {snr[w]:.1f} times the fit residual (need {policy.snr_min:g})"
            if snr[w] < policy.snr_min
            else "it duplicates a neighbour"
        )
        notes.append(f"stable pole near {seeds[w].imag / (2 * np.pi):.2f} Hz left out: {reason}")
        seeds = np.delete(seeds, w)


def _look_near_guides(frf, guide, picked, diagram, found: _Poles, notes, policy: PeakPolicy) -> _Poles:
    """For guide frequencies with no mode ``found`` within ``policy.guide_rel``: fit the
    best nearby picked peak, or the diagram's most persistent pole nearby, with the modes
    found as its neighbours; keep it at SNR >= ``policy.snr_guided`` when the hits confirm
    it (flag "guided")."""
    pole, snr, guided = found.pole, found.snr, found.guided
    f, _ = correct_for_window(pole, frf.decay_rate)
    for g in guide:
        if len(f) and np.min(np.abs(f / g - 1)) < policy.guide_rel:
            continue
        near = picked[np.abs(picked["frequency_hz"] / g - 1) < policy.guide_rel]
        if len(near):
            fp = float(near["frequency_hz"].iloc[np.argmax(near["prominence_db"])])
            candidates = diagram.pole[np.abs(diagram.frequency_hz / fp - 1) < policy.freq_tol * 5]
            # start: 0.5 % damping
            decay = np.median(candidates.real) if len(candidates) else -2 * np.pi * fp * 0.005
            seed = decay + 2j * np.pi * fp
        else:
            near_guide = np.abs(diagram.frequency_hz / g - 1) < policy.guide_rel
            if not near_guide.any():
                notes.append(f"nothing found near the guide frequency {g:.1f} Hz (node at the sensor?)")
                continue
            seed = _persistent(diagram.pole[near_guide], diagram.frequency_hz[near_guide], policy.freq_tol)
        # fitted with the modes found as its neighbours: a weak mode on a strong one's skirt
        p, s, ok = (x[-1:] for x in _fit_all(frf, frf.h1, np.append(pole, seed), only=(len(pole),)))
        fn, zeta = correct_for_window(p, frf.decay_rate)
        if (
            ok[0]
            and s[0] >= policy.snr_guided
            and 0 < zeta[0] < policy.max_damping
            and abs(fn[0] / g - 1) < policy.guide_rel
            and _on_the_hits(frf, np.append(pole, p), policy)
        ):
            pole, snr, guided = np.append(pole, p), np.append(snr, s), np.append(guided, True)
            notes.append(f"mode at {fn[0]:.2f} Hz found only by looking near the guide frequency {g:.1f} Hz")
        else:
            notes.append(f"nothing found near the guide frequency {g:.1f} Hz (node at the sensor?)")
    return _Poles(pole, snr, guided)


def _on_the_hits(frf: AveragedFRF, pole: np.ndarray, policy: PeakPolicy) -> bool:
    """Do the hits confirm the last of ``pole`` (with the others as its neighbours): found
    on at least half of the hits' own FRFs (of two at least; always, with one), their
    frequencies scattering by at most ``policy.guided_scatter`` of its half-power bandwidth?  A
    guided fit on H1 alone can make a weak "mode" of noise near a node (SNR 4-5, 1-2 %
    damping), which the hits then place anywhere in its window."""
    if frf.n_hits < 2:
        return True
    per_hit = _per_hit(frf, pole, policy.max_damping, only=(len(pole) - 1,))[0][:, -1]
    found = per_hit[np.isfinite(per_hit)]
    half_bandwidth = abs(pole[-1].real) / (2 * np.pi)
    return bool(
        len(found) >= max(2, math.ceil(frf.n_hits / 2))
        and np.std(found, ddof=1) <= policy.guided_scatter * 2 * half_bandwidth
    )


def _persistent(pole: np.ndarray, frequency_hz: np.ndarray, freq_tol: float) -> complex:
    """The pole [rad/s] the diagram returns to most often: the median of the poles within
    5 ``freq_tol`` of the one with most such neighbours (a column too unsteady to be
    stable, or a weak mode that is stable only in some orders)."""
    close = np.abs(frequency_hz[:, None] / frequency_hz - 1) < 5 * freq_tol
    members = close[np.argmax(close.sum(axis=1))]
    return complex(np.median(pole[members].real) + 1j * np.median(pole[members].imag))


def _per_hit(
    frf: AveragedFRF, pole: np.ndarray, max_damping: float, only=None
) -> tuple[np.ndarray, np.ndarray]:
    """(hits, modes) frequency [Hz] and damping ratio [-] (window-corrected) of every mode
    (or of those at the indices ``only``) fitted on each hit's FRF with the neighbourhood
    it had on H1 (:func:`refined_per_record`; NaN: failed, or damped above
    ``max_damping``)."""
    out, damping = np.full((frf.n_hits, len(pole)), np.nan), np.full((frf.n_hits, len(pole)), np.nan)
    if frf.n_hits < 2:
        return out, damping
    fits = {}
    for i, (joint, fixed, lines) in enumerate(_neighbourhoods(frf, pole)):
        if (only is not None and i not in only) or len(lines) < 2 * (len(joint) + len(fixed)) + 4:
            continue
        key = (joint.tobytes(), fixed.tobytes())
        if key not in fits:  # seeds fitted together share their fit
            fits[key] = refined_per_record(
                frf.frequency_hz[lines], frf.per_hit[:, lines], pole[joint], pole[fixed]
            )
        p, ok = fits[key]
        p = p[:, int(np.flatnonzero(joint == i)[0])]
        f, zeta = correct_for_window(p, frf.decay_rate)
        with np.errstate(invalid="ignore"):
            good = (
                ok
                & (np.abs(p.imag - pole[i].imag) < FIT_HALF_WIDTHS * abs(pole[i].real))
                & (zeta > 0)
                & (zeta < max_damping)
            )
        out[good, i], damping[good, i] = f[good], zeta[good]
    return out, damping


def broadening(
    frf: AveragedFRF, per_hit_hz: np.ndarray, frequency_hz: np.ndarray, damping_ratio: np.ndarray
) -> np.ndarray:
    """How much wider than each hit's the H1 peak is [damping ratio]: averaging hits
    whose peaks scatter in frequency, s_f^2 / (zeta f^2), s_f^2 the H1-weighted variance of
    the (hits, modes) per-hit frequencies (NaN with fewer than two)."""
    line = frf.line(frequency_hz)
    out = np.full(len(frequency_hz), np.nan)
    for j in range(len(frequency_hz)):
        have = np.isfinite(per_hit_hz[:, j])
        if have.sum() >= 2:
            w = frf.weights[have, line[j]] / frf.weights[have, line[j]].sum()
            spread = (w @ (per_hit_hz[have, j] - w @ per_hit_hz[have, j]) ** 2) / (1 - np.sum(w**2))
            out[j] = spread / (damping_ratio[j] * frequency_hz[j] ** 2)
    return out


def damping_std(
    frf: AveragedFRF, per_hit_damping: np.ndarray, frequency_hz: np.ndarray, broadened: np.ndarray
) -> np.ndarray:
    """damping_std [-] of the damping ratio corrected for ``broadening``: the standard error
    of the per-hit damping ratios (each hit's exponential window corrected; the formula of
    std_hz, module docstring) and the uncertainty of the broadening, a sample variance of
    n hits (relative std sqrt(2 / (n - 1))), added in quadrature."""
    standard_error, n = _std(frf, per_hit_damping, frequency_hz)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.hypot(standard_error, broadened * np.sqrt(2 / (n - 1)))


def _std(frf: AveragedFRF, per_hit: np.ndarray, frequency_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """std_hz (module docstring) from the (hits, modes) per-hit frequencies (or the
    standard error of another per-hit estimate), and the number of hit estimates per
    mode; the weights are H1's at ``frequency_hz``."""
    line = frf.line(frequency_hz)
    n = np.sum(np.isfinite(per_hit), axis=0)
    std = np.full(len(frequency_hz), np.nan)
    for j in np.flatnonzero(n >= 2):
        have = np.isfinite(per_hit[:, j])
        w = frf.weights[have, line[j]] / frf.weights[have, line[j]].sum()
        std[j] = np.std(per_hit[have, j], ddof=1) / _c4(n[j]) * np.sqrt(np.sum(w**2))
    return std, n


def _table(frf, lines, found: _Poles, picked, notes, policy: PeakPolicy) -> pd.DataFrame:
    order = np.argsort(found.pole.imag)
    pole, snr, guided = found.pole[order], found.snr[order], found.guided[order]
    f, zeta = correct_for_window(pole, frf.decay_rate)
    per_hit_f, per_hit_zeta = _per_hit(frf, pole, policy.max_damping)
    std, n = _std(frf, per_hit_f, pole.imag / (2 * np.pi))
    broadened = broadening(frf, per_hit_f, f, zeta)
    zeta = np.where(np.isfinite(broadened) & (broadened < 0.5 * zeta), zeta - broadened, zeta)
    zeta_std = damping_std(frf, per_hit_zeta, f, np.nan_to_num(broadened))
    half_bw = np.abs(pole.real) / (2 * np.pi)
    pooled = np.isnan(std) & np.isfinite(std).any()
    if pooled.any():
        std[pooled] = np.nanmedian(std / f) * f[pooled]
        zeta_std[pooled] = np.nanmedian(zeta_std / zeta) * zeta[pooled]
    line = frf.line(pole.imag / (2 * np.pi))
    peak_hz = np.full(len(f), np.nan)
    used = set()
    for j in range(len(f)):
        near = np.abs(picked["frequency_hz"].to_numpy() - pole[j].imag / (2 * np.pi)) <= half_bw[j]
        if near.any():
            i = int(np.flatnonzero(near)[np.argmin(np.abs(picked["frequency_hz"].to_numpy()[near] - f[j]))])
            peak_hz[j] = picked["frequency_hz"].iloc[i]
            used.add(i)
    prominence = _prominences_at(frf, lines, pole.imag / (2 * np.pi), half_bw)
    sep = np.diff(f)
    close = np.zeros(len(f), dtype=bool)
    close[:-1] |= sep < 4 * half_bw[:-1]
    close[1:] |= sep < 4 * half_bw[1:]
    flags = {
        "response_only": np.full(len(f), not frf.has_force),
        "suspension": f < frf_module.SUSPENSION_HZ,
        "low_coherence": frf.coherence[line] < policy.coherence_min,
        "weak": (prominence < policy.weak_db) | (snr < policy.weak_snr * policy.snr_min),
        "close": close,
        "single_hit": n < 2,
        "guided": guided,
        "std_pooled": pooled,
        "unpicked": np.isnan(peak_hz),
    }
    names = [[k for k in FLAG_ORDER if flags[k][j]] for j in range(len(f))]
    left = (
        picked.drop(index=list(used))
        .nlargest(policy.noted_peaks, "prominence_db")
        .sort_values("frequency_hz")
    )
    if len(left):
        listed = ", ".join(
            f"{x:.1f} Hz ({p:.1f} dB)"
            for x, p in zip(left["frequency_hz"], left["prominence_db"], strict=True)
        )
        more = len(picked) - len(used) - len(left)
        notes.append(
            f"peaks picked on |H1| without a stable pole (spurious: suspension, anti-resonance, cable, "
            f"noise?) left out: {listed}" + (f" and {more} smaller ones" if more else "")
        )
    return pd.DataFrame(
        {
            "frequency_hz": f,
            "std_hz": std,
            "damping_ratio": zeta,
            "damping_std": zeta_std,
            "coherence": frf.coherence[line],
            "prominence_db": prominence,
            "snr": snr,
            "hits": n,
            "peak_hz": peak_hz,
            "quality": [k[0] if k else "good" for k in names],
            "flags": [",".join(k) for k in names],
        }
    )
