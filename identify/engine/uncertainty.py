"""Parameter uncertainty of an identification, and how far it can be trusted.

The covariance is the linearised one, sigma^2 (J^T J)^-1 with J the Jacobian of the
weighted residuals.  The scatter comes from the measurements' ``std_hz`` when given
(inflated, with a warning, when the misfit is clearly larger than that scatter) or is
estimated from the residual.  A singular design gives no error bars at all: they would
be numbers without meaning.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fem.solver.sensitivity import GOOD_BELOW, SINGULAR_ABOVE, Verdict, condition_verdict

from .parameters import display
from .statistics import FitStatistics
from .stopping import UNDETERMINED_Z

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
    """std and covariance in SI units of the parameters; correlation; conditioning of
    the relative sensitivity matrix (the paper's criterion); flags per parameter."""

    std: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    condition_number: float
    singular_values: np.ndarray
    weak_combinations: tuple[str, ...]
    flags: tuple[tuple[str, ...], ...]
    warnings: tuple[str, ...]
    # Per parameter: on a bound of its own or at nu12's positive-definiteness limit (the
    # code that decisions read; ``flags`` word it for the report).
    bounded: tuple[bool, ...]
    # Per parameter: the std of one unit of its fit variable z (the value itself for a
    # modulus, a thickness, a mass; 1 for nu12, 1 rad for an angle, a plate length for a
    # position), the scale ``undetermined`` reads the std against.
    z_scale: np.ndarray

    @property
    def verdict(self) -> Verdict:
        return condition_verdict(self.condition_number)

    @property
    def undetermined(self) -> tuple[bool, ...]:
        """Per parameter: not determined, its std (as it stands: with the known inputs'
        share once the budget is added) at least ``UNDETERMINED_Z`` of its own scale, or
        none at all."""
        std_z = np.asarray(self.std, dtype=float) / self.z_scale
        return tuple(bool(v) for v in ~np.isfinite(std_z) | (std_z >= UNDETERMINED_Z))

    def with_covariance(self, extra: np.ndarray) -> Uncertainty:
        """The uncertainty with a further independent covariance added (the known
        inputs' part of an uncertainty budget)."""
        if not np.all(np.isfinite(self.std)):
            return self
        covariance = self.covariance + extra
        std = np.sqrt(np.diag(covariance))
        return replace(self, std=std, covariance=covariance, correlation=covariance / np.outer(std, std))

    def with_twins(self, values: np.ndarray, twins, parameters) -> Uncertainty:
        """The uncertainty widened by twin solutions (other mode pairings that fit within
        the scatter): the pairing is then unknown, so the estimate is a mixture of the
        solutions weighted by exp(-delta chi^2 / 2) (the best weighs 1), whose spread about
        the reported one adds to the covariance.  ``twins``: (values, delta chi^2)."""
        if not twins or not np.all(np.isfinite(self.std)):
            return self
        weights = np.array([np.exp(-0.5 * chi2) for _, chi2 in twins])
        deviations = np.array([v - values for v, _ in twins])
        spread = np.einsum("k,ki,kj->ij", weights, deviations, deviations) / (1 + weights.sum())
        covariance = self.covariance + spread
        std = np.sqrt(np.diag(covariance))
        widened = np.sqrt(np.diag(spread)) > 0.5 * self.std
        flags = tuple(
            f + (("pairing ambiguity (twin solutions) included in std",) if w else ())
            for f, w in zip(self.flags, widened)
        )
        warnings = self.warnings + (
            (
                f"std of {', '.join(p.name for p, w in zip(parameters, widened) if w)} "
                "widened by twin solutions: label the close modes to narrow them",
            )
            if widened.any()
            else ()
        )
        return replace(
            self,
            std=std,
            covariance=covariance,
            correlation=covariance / np.outer(std, std),
            flags=flags,
            warnings=warnings,
        )

    def with_merged_peaks(self, objective, evaluation, lone) -> tuple[Uncertainty, list[str]]:
        """The uncertainty widened for measured peaks that may be two modes merged: each
        ``lone`` (``ambiguity.LoneMode``) is a peak paired with one model mode while the
        close neighbour beside it has no peak.  The peak then lies anywhere between the
        two (a blend weighted by their residues, or the one mode with the other at a node),
        so its frequency carries a further error uniform over their spacing, variance
        spacing^2 / 12, propagated through the linearised fit.  (At 20 dB SNR two
        pairs 0.2-0.35 % apart each gave one peak with the hit-to-hit std_hz of 0.04-0.1 Hz,
        5 std from either mode, and the fit put four moduli 3.3-4.4 std off.)  Returns
        (uncertainty, a note per peak)."""
        if not lone or not np.all(np.isfinite(self.std)):
            return self, []
        table = objective.measurements.table
        extra = np.zeros(len(table))
        notes = []
        for row, other, mine, mine_hz, other_hz in lone:
            name = table["configuration"].iloc[row]
            spacing = abs(other_hz - mine_hz)
            # In weighted-residual units; a peak with a free close mode on each side: the wider.
            extra[row] = max(extra[row], spacing**2 / 12 / objective.sigma[row] ** 2)
            notes.append(
                f"{name} {table['frequency_hz'].iloc[row]:.2f} Hz: one peak where model modes {mine + 1} and "
                f"{other + 1} lie {100 * spacing / mine_hz:.2g} % apart (two modes merged, or one at a "
                f"node): it may lie anywhere between them, a further scatter of {spacing / 12**0.5:.3g} Hz "
                "(spacing / sqrt 12) is in the parameters' std; a label or a second sensor position would "
                "tell"
            )
        spread = row_scatter_covariance(objective, evaluation, extra)
        covariance = self.covariance + spread
        std = np.sqrt(np.diag(covariance))
        widened = np.sqrt(np.diag(spread)) > 0.5 * self.std
        flags = tuple(
            f + (("merged peak (two close modes, one peak) included in std",) if w else ())
            for f, w in zip(self.flags, widened)
        )
        return replace(
            self, std=std, covariance=covariance, correlation=covariance / np.outer(std, std), flags=flags
        ), notes

    @classmethod
    def at(cls, objective, evaluation, statistics: FitStatistics) -> Uncertainty:
        """The linearised uncertainty of ``evaluation``'s parameters, with the scatter
        ``statistics`` gives (stated, inflated or estimated)."""
        from .objective import relative_sensitivity

        space = objective.space
        names = [p.name for p in space.parameters]
        values = evaluation.values
        p = len(values)
        warnings = []
        if statistics.inflated:
            warnings.append(
                f"the misfit is {np.sqrt(statistics.reduced_chi2):.1f}x the stated scatter: the model misses "
                "something (run 'identify-layers diagnose'); std inflated accordingly"
            )
        if not statistics.scatter_known and statistics.dof <= 0:
            warnings.append("no redundancy to estimate the scatter: give std_hz or measure more modes")
        scale = statistics.noise_scale
        relative = relative_sensitivity(evaluation, space)
        cond = condition_number(relative)
        _, s_rel, vt_rel = np.linalg.svd(relative, full_matrices=False)
        # Relative to the largest; all zero when no paired mode moves (frequencies in kHz).
        s_rel = s_rel / s_rel[0] if s_rel[0] > 0 else np.zeros_like(s_rel)
        weak = tuple(
            f"{describe_combination(vt_rel[k], names)} (singular value {s_rel[k]:.1e} of the largest)"
            for k in range(len(s_rel))
            if s_rel[k] < 1 / GOOD_BELOW
        )
        _, s, vt = np.linalg.svd(objective.jacobian(evaluation), full_matrices=False)
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
        on_bound = space.at_bound(values)
        specimen = evaluation.model.specimen
        flags = tuple(
            parameter_flags(
                parameter, value, sd, specimen, space.bound_of(i, values) if on_bound[i] else None
            )
            for i, (parameter, value, sd) in enumerate(zip(space.parameters, values, std))
        )
        bounded = tuple(
            bool(on_bound[i]) or at_limit(parameter, value, specimen)
            for i, (parameter, value) in enumerate(zip(space.parameters, values))
        )
        return cls(
            std, covariance, correlation, cond, s_rel, weak, flags, tuple(warnings), bounded, np.abs(dvdz)
        )


def row_scatter_covariance(objective, evaluation, extra: np.ndarray) -> np.ndarray:
    """The parameters' covariance [SI^2] from a further scatter of each measured row,
    independent between rows, ``extra`` its variance in weighted-residual units (of
    sigma^2), through the linearised fit at ``evaluation``."""
    u, s, vt = np.linalg.svd(objective.jacobian(evaluation), full_matrices=False)
    gain = (vt.T / s) @ u.T  # dz = -gain dr
    dvdz = objective.space.dvalue_dz(evaluation.values)
    return dvdz[:, None] * ((gain * extra) @ gain.T) * dvdz[None, :]


def at_limit(parameter, value: float, specimen) -> bool:
    """A Poisson's ratio at the positive-definiteness limit of its ply (nu12^2 within 2 %
    of E1/E2): bounded by the material, not by the data."""
    if parameter.kind != "nu12":
        return False
    material = specimen.materials[parameter.target]
    return value**2 > 0.98 * material.E1 / material.E2


def parameter_flags(
    parameter, value: float, std: float, specimen, bound: float | None = None
) -> tuple[str, ...]:
    """Flags of one estimate: on its bound (``bound``: the bound it sits on, limited by it
    rather than by the data), at the positive-definiteness limit, weakly identifiable (std
    above ``WEAK_REL_STD`` of the value; for nu12 of 0.3, its typical size), not
    identifiable."""
    flags = []
    if bound is not None:
        flags.append(
            f"at bound ({parameter.kind} = {display(parameter, bound):.4g}; set bounds in the spec to widen)"
        )
    if at_limit(parameter, value, specimen):
        flags.append("at bound (nu12^2 -> E1/E2)")
    if parameter.kind == "nu12":
        if std > WEAK_REL_STD * 0.3:
            flags.append("weakly identifiable")
    elif np.isfinite(std) and std > WEAK_REL_STD * abs(value):
        flags.append("weakly identifiable")
    if not np.isfinite(std):
        flags.append("not identifiable")
    return tuple(flags)
