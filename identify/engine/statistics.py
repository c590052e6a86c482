"""Goodness of fit of an identification, computed in one place.

Residuals are weighted by the measurement scatter: r = (model - measured) / std_hz when
the measurements state it, else relative errors r = (model - measured) / measured, whose
scale is then unknown and estimated from the residual itself.  Every report, ``compare``
and ``diagnose`` read these numbers from a ``FitStatistics``; none recomputes them.

Whether a fit may be called converged is a chi^2 test: the misfit must be consistent
with the stated scatter (std_hz), or, without one, with ``ASSUMED_SCATTER_REL`` of every
measured frequency, at the level ``CHI2_TEST_LEVEL``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from fem.numbers import finite_or_none

from ..measurements import Measurements

#: A reduced chi-square above this says the misfit exceeds the stated scatter: the
#: covariance is then inflated by it (and a warning says so).
CHI2_WARNING = 4.0
#: Scatter assumed for measured frequencies without std_hz: 0.1 % (careful tap tests on
#: free plates repeat to 0.01-0.1 %; a model that misses physics is off by more).
ASSUMED_SCATTER_REL = 1e-3
#: The misfit is inconsistent with the scatter when a chi^2 this large or larger would
#: happen by chance less often than this (a 0.1 % test: false alarms are rare).
CHI2_TEST_LEVEL = 1e-3


@dataclass(frozen=True)
class FitStatistics:
    """n measured frequencies, k fitted parameters; ``sum_squares`` of the weighted
    residuals; ``rms_rel_error`` of the relative errors; ``scatter_known``: the weights
    are the measurements' std_hz (else relative errors, scale unknown)."""

    n: int
    k: int
    sum_squares: float
    rms_rel_error: float
    scatter_known: bool

    @classmethod
    def of(cls, model_hz: np.ndarray, measurements: Measurements, k: int) -> FitStatistics:
        """The statistics of model frequencies paired row by row with ``measurements``."""
        r = weighted_residuals(model_hz, measurements)
        rel = np.asarray(model_hz) / measurements.table["frequency_hz"].to_numpy() - 1
        return cls(len(r), k, float(r @ r), float(np.sqrt(np.mean(rel**2))), measurements.has_std)

    @property
    def dof(self) -> int:
        """Degrees of freedom n - k."""
        return self.n - self.k

    @property
    def chi2(self) -> float | None:
        """chi^2 in units of the stated scatter; None when no scatter is stated."""
        return self.sum_squares if self.scatter_known else None

    @property
    def reduced_chi2(self) -> float:
        """sum of squares / dof: chi^2 / dof with a stated scatter, else the relative
        residual variance; NaN without redundancy (dof <= 0)."""
        return self.sum_squares / self.dof if self.dof > 0 else float("nan")

    @property
    def chi2_against_scatter(self) -> float:
        """chi^2 against the stated scatter, or against ``ASSUMED_SCATTER_REL`` of every
        frequency when none is stated (then the sum of squared relative errors / 0.001^2)."""
        return self.sum_squares if self.scatter_known else self.sum_squares / ASSUMED_SCATTER_REL**2

    @property
    def p_value(self) -> float:
        """Chance of a chi^2 at least this large if the model were right and the scatter
        as stated (or assumed); 1 without redundancy (nothing to test)."""
        return float(stats.chi2.sf(self.chi2_against_scatter, self.dof)) if self.dof > 0 else 1.0

    @property
    def consistent(self) -> bool:
        """The misfit is consistent with the (stated or assumed) scatter at ``CHI2_TEST_LEVEL``."""
        return self.p_value >= CHI2_TEST_LEVEL

    @property
    def misfit_over_scatter(self) -> float:
        """RMS of the residuals in units of the (stated or assumed) scatter."""
        return math.sqrt(self.chi2_against_scatter / self.n)

    def describe(self) -> str:
        """One line: the misfit against the scatter, and whether they are consistent."""
        against = (
            "the stated std_hz"
            if self.scatter_known
            else f"an assumed {100 * ASSUMED_SCATTER_REL:g} % scatter (no std_hz given)"
        )
        verdict = "consistent" if self.consistent else f"not consistent (chi^2 test, p = {self.p_value:.2g})"
        return (
            f"misfit {self.misfit_over_scatter:.3g}x {against}, RMS {100 * self.rms_rel_error:.4g} %: "
            f"{verdict}"
        )

    @property
    def chi2_unit(self) -> float:
        """The size of one unit of chi^2 for comparing fits: 1 with a stated scatter, else
        the residual variance (a tiny positive floor without redundancy)."""
        if self.scatter_known:
            return 1.0
        return max(self.sum_squares / self.dof, 1e-30) if self.dof > 0 else 1e-30

    @property
    def inflated(self) -> bool:
        """The misfit exceeds the stated scatter (reduced chi^2 > ``CHI2_WARNING``)."""
        return self.scatter_known and self.dof > 0 and self.reduced_chi2 > CHI2_WARNING

    @property
    def noise_scale(self) -> float:
        """Variance factor of the linearised covariance: 1 for the stated scatter (or the
        reduced chi^2 when the misfit is clearly larger), else the residual variance;
        NaN when it cannot be estimated."""
        if self.scatter_known:
            return self.reduced_chi2 if self.inflated else 1.0
        return self.reduced_chi2

    @property
    def noise_source(self) -> str:
        if self.scatter_known:
            return (
                f"measured std_hz inflated by the misfit (reduced chi^2 {self.reduced_chi2:.1f})"
                if self.inflated
                else "measured std_hz"
            )
        if self.dof > 0:
            return f"estimated from the residual ({self.dof} degrees of freedom)"
        return "none: as many unknowns as frequencies and no std_hz"

    @property
    def bic(self) -> float:
        """Bayesian information criterion: chi^2 + k ln n, or n ln(RSS / n) + k ln n
        (RSS of the relative errors) without a stated scatter."""
        if self.scatter_known:
            fit = self.sum_squares
        else:
            fit = self.n * math.log(max(self.sum_squares / self.n, 1e-300))
        return fit + self.k * math.log(self.n)

    def to_dict(self) -> dict:
        return {
            "n": self.n,
            "k": self.k,
            "dof": self.dof,
            "chi2": finite_or_none(self.chi2),
            "reduced_chi2": finite_or_none(self.reduced_chi2) if self.scatter_known else None,
            "chi2_against_scatter": finite_or_none(self.chi2_against_scatter),
            "scatter_assumed_rel": None if self.scatter_known else ASSUMED_SCATTER_REL,
            "p_value": self.p_value,
            "consistent": self.consistent,
            "noise_scale": finite_or_none(self.noise_scale),
            "rms_rel_error": self.rms_rel_error,
            "bic": finite_or_none(self.bic),
            "scatter": self.noise_source,
        }


def weighted_residuals(model_hz: np.ndarray, measurements: Measurements) -> np.ndarray:
    """(model - measured) / std_hz, or relative errors when no std_hz is given."""
    table = measurements.table
    measured = table["frequency_hz"].to_numpy()
    sigma = table["std_hz"].to_numpy() if measurements.has_std else measured
    return (np.asarray(model_hz) - measured) / sigma


__all__ = ["FitStatistics", "weighted_residuals", "CHI2_WARNING", "ASSUMED_SCATTER_REL", "CHI2_TEST_LEVEL"]
