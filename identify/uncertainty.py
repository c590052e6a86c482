"""Parameter uncertainty of an identification, and how far it can be trusted.

The covariance is the linearised one, sigma^2 (J^T J)^-1 with J the Jacobian of the
weighted residuals.  The scatter comes from the measurements' ``std_hz`` when given
(inflated, with a warning, when the misfit is clearly larger than that scatter) or is
estimated from the residual.  A singular design gives no error bars at all: they would
be numbers without meaning.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.sensitivity import GOOD_BELOW, SINGULAR_ABOVE, condition_verdict

#: A reduced chi-square above this says the misfit exceeds the stated scatter.
CHI2_WARNING = 4.0
#: Relative std above which a parameter is flagged weakly identifiable.
WEAK_REL_STD = 0.1


def condition_number(matrix: np.ndarray) -> float:
    s = np.linalg.svd(matrix, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def describe_combination(vector: np.ndarray, names: list[str], threshold: float = 0.2) -> str:
    """A singular vector as a readable combination, e.g. '+0.71 steel.E1 -0.70 top.E1'."""
    order = np.argsort(-np.abs(vector))
    terms = [f"{vector[i]:+.2f} {names[i]}" for i in order if abs(vector[i]) >= threshold]
    return " ".join(terms)


@dataclass(frozen=True)
class Uncertainty:
    """std and covariance in SI units of the parameters; correlation; conditioning."""

    std: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    condition_number: float
    singular_values: np.ndarray
    weak_combinations: tuple[str, ...]
    flags: tuple[tuple[str, ...], ...]
    noise_source: str
    reduced_chi2: float
    warnings: tuple[str, ...]

    @property
    def verdict(self) -> str:
        return condition_verdict(self.condition_number)

    @classmethod
    def at(cls, updater, evaluation, residual: np.ndarray) -> "Uncertainty":
        from .updating import relative_sensitivity

        space = updater.space
        names = [p.name for p in space.parameters]
        values = evaluation.values
        n, p = len(residual), len(values)
        J = updater.jacobian(evaluation)
        dof = n - p
        chi2 = float(residual @ residual / dof) if dof > 0 else float("nan")
        warnings = []
        if updater.measurements.has_std:
            scale, source = 1.0, "measured std_hz"
            if chi2 > CHI2_WARNING:
                scale, source = chi2, f"measured std_hz inflated by the misfit (reduced chi^2 {chi2:.1f})"
                warnings.append(f"the misfit is {np.sqrt(chi2):.1f}x the stated scatter: the model misses "
                                "something (run 'identify-layers diagnose'); std inflated accordingly")
        elif dof > 0:
            scale, source = chi2, f"estimated from the residual ({dof} degrees of freedom)"
        else:
            scale, source = float("nan"), "none: as many unknowns as frequencies and no std_hz"
            warnings.append("no redundancy to estimate the scatter: give std_hz or measure more modes")
        relative = relative_sensitivity(evaluation)
        cond = condition_number(relative)
        _, s_rel, vt_rel = np.linalg.svd(relative, full_matrices=False)
        weak = tuple(
            f"{describe_combination(vt_rel[k], names)} (singular value {s_rel[k] / s_rel[0]:.1e} of the largest)"
            for k in range(len(s_rel)) if s_rel[k] < s_rel[0] / GOOD_BELOW
        )
        _, s, vt = np.linalg.svd(J, full_matrices=False)
        dvdz = space.dvalue_dz(values)
        if cond > SINGULAR_ABOVE or s[-1] <= 1e-12 * s[0]:
            covariance = np.full((p, p), np.inf)
            std = np.full(p, np.inf)
            correlation = np.full((p, p), np.nan)
            warnings.append("singular design: no error bars are given, the parameters are not determined")
        else:
            cov_z = scale * (vt.T / s**2) @ vt
            covariance = dvdz[:, None] * cov_z * dvdz[None, :]
            std = np.sqrt(np.diag(covariance))
            correlation = covariance / np.outer(std, std)
        flags = []
        for parameter, value, sd in zip(space.parameters, values, std):
            f = []
            if parameter.kind == "nu12":
                material = evaluation.specimen.materials[parameter.target]
                if value**2 > 0.98 * material.E1 / material.E2:
                    f.append("at bound (nu12^2 -> E1/E2)")
                if sd > WEAK_REL_STD * 0.3:
                    f.append("weakly identifiable")
            elif np.isfinite(sd) and sd > WEAK_REL_STD * abs(value):
                f.append("weakly identifiable")
            if not np.isfinite(sd):
                f.append("not identifiable")
            flags.append(tuple(f))
        return cls(std, covariance, correlation, cond, s_rel / s_rel[0], weak, tuple(flags), source, chi2,
                   tuple(warnings))
