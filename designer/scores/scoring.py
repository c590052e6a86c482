"""Scores of a test set from its stacked relative sensitivity matrix S (paper eq. 14).

With measured relative frequency errors of std ``sigma`` (independent), the linearised
estimate of the relative parameter changes dP = S^+ dR (eq. 15) has covariance
sigma^2 (S^T S)^-1 = F^-1, F = S^T S / sigma^2 the Fisher information.  From the
singular values s_k and right singular vectors V of S:

- condition number s_max / s_min (the paper's criterion, section 4.6);
- D-optimality log det F = sum 2 log(s_k / sigma);
- E-optimality lambda_min(F) = (s_min / sigma)^2;
- predicted std of parameter j, relative to its value: sigma sqrt(sum_k V_jk^2 / s_k^2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.solver.sensitivity import Verdict
from fem.solver.sensitivity import condition_verdict as verdict

#: Relative std above which a parameter is flagged weakly identifiable (10 %).
WEAK_STD_REL = 0.1


def singular_values(stacks: np.ndarray) -> np.ndarray:
    """Singular values, largest first, of every matrix in ``stacks`` (..., rows, p).

    A matrix with fewer rows than columns is padded with zero rows, so it has p singular
    values with zeros at the end: rank deficient, as it is."""
    rows, p = stacks.shape[-2:]
    if rows < p:
        stacks = np.concatenate([stacks, np.zeros(stacks.shape[:-2] + (p - rows, p))], axis=-2)
    return np.linalg.svd(stacks, compute_uv=False)


def condition_numbers(sv: np.ndarray) -> np.ndarray:
    """s_max / s_min per row of singular values (inf when rank deficient)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sv[..., -1] > 0, sv[..., 0] / np.where(sv[..., -1] > 0, sv[..., -1], 1.0), np.inf)


def logdet_fisher(sv: np.ndarray, sigma: float) -> np.ndarray:
    """log det of the Fisher information S^T S / sigma^2 (-inf when singular)."""
    with np.errstate(divide="ignore"):
        return 2 * np.sum(np.log(sv / sigma), axis=-1)


def min_eigenvalue_fisher(sv: np.ndarray, sigma: float) -> np.ndarray:
    return (sv[..., -1] / sigma) ** 2


def loss(sv: np.ndarray, sigma: float, criterion: str) -> np.ndarray:
    """The criterion as a number to minimise: log condition number, -log det F or
    -log lambda_min(F)."""
    with np.errstate(divide="ignore"):
        if criterion == "condition":
            return np.log(condition_numbers(sv))
        if criterion == "d":
            return -logdet_fisher(sv, sigma)
        if criterion == "e":
            return -np.log(min_eigenvalue_fisher(sv, sigma))
    raise ValueError(f"criterion {criterion!r}: allowed: 'condition', 'd', 'e'")


@dataclass(frozen=True)
class Scores:
    """How well a test set identifies the parameters, at the nominal properties.

    condition_number: of the stacked relative sensitivity matrix; logdet_fisher and
    min_eigenvalue_fisher: of F = S^T S / sigma^2 (relative parameters); std_rel: the
    predicted std of each parameter relative to its value; correlation: of the estimates.
    """

    condition_number: float
    logdet_fisher: float
    min_eigenvalue_fisher: float
    std_rel: np.ndarray
    correlation: np.ndarray

    @property
    def verdict(self) -> Verdict:
        return verdict(self.condition_number)

    def loss(self, criterion: str) -> float:
        """The criterion as a number to minimise (as ``loss`` of singular values)."""
        with np.errstate(divide="ignore"):
            return float(
                {
                    "condition": np.log(self.condition_number),
                    "d": -self.logdet_fisher,
                    "e": -np.log(self.min_eigenvalue_fisher),
                }[criterion]
            )

    def value(self, criterion: str) -> float:
        """The number the criterion ranks by, in its own units."""
        return {"condition": self.condition_number, "d": self.logdet_fisher, "e": self.min_eigenvalue_fisher}[
            criterion
        ]


def score(rows: np.ndarray, sigma: float) -> Scores:
    """Scores of a stacked relative sensitivity matrix (measured rows x parameters) for a
    relative frequency scatter ``sigma``."""
    n, p = rows.shape
    _, s, vt = np.linalg.svd(rows, full_matrices=False)
    sv = np.concatenate([s, np.zeros(p - s.size)])
    cond = float(condition_numbers(sv))
    if n < p or not s[-1] > 0:
        std, corr = np.full(p, np.inf), np.full((p, p), np.nan)
    else:
        covariance = sigma**2 * (vt.T / s**2) @ vt
        std = np.sqrt(np.diag(covariance))
        corr = covariance / np.outer(std, std)
    return Scores(cond, float(logdet_fisher(sv, sigma)), float(min_eigenvalue_fisher(sv, sigma)), std, corr)
