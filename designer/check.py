"""``check``: is the spec's own set of configurations a feasible test (paper section 4.6)?"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

from fem.io import html_pre
from fem.limits import CLOSE_MODES_WARNING, Limits
from fem.model import SpecimenModel
from fem.solver.sensitivity import Verdict

from .problem import Problem, Solved, solve_points, unmeasurable
from .progress import Progress
from .scores.damping import DampingScores, damping_scores
from .scores.design import Design
from .scores.poisson import PoissonPlate, poisson_plate
from .sheet import TestSheet, test_sheet


@dataclass(frozen=True)
class CheckResult:
    """The scored spec design, the Poisson-plate rule, warnings (close modes, modes
    outside the band, too few frequencies), violations of the lab's limits, the limits
    themselves and the test sheet (computed when first asked for: ``test_sheet``); the
    loss-factor scores when materials have ``identify_damping`` (``designer.scores.damping``)."""

    design: Design
    poisson: PoissonPlate
    warnings: tuple[str, ...]
    violations: tuple[str, ...]
    limits: Limits | None = None
    problem: Problem | None = field(default=None, repr=False, compare=False)
    prior: tuple = field(default=(), repr=False, compare=False)
    damping: DampingScores | None = None

    @property
    def feasible(self) -> bool:
        """Not singular, within every limit, and every parameter meets its target std."""
        return (
            self.design.scores.verdict != Verdict.SINGULAR
            and not self.violations
            and self.design.meets_targets
        )

    @cached_property
    def test_sheet(self) -> TestSheet | None:
        """Supports, sensor and tap points, frequencies to expect, close pairs and the
        sensor's shift for every configuration (``designer.sheet``)."""
        if self.problem is None:
            return None
        return test_sheet(self.problem, list(self.design.solved), list(self.prior) or None)

    def _repr_html_(self) -> str:
        return html_pre(self.report())

    def to_dict(self) -> dict:
        sheet = self.test_sheet
        return {
            **self.design.to_dict(),
            "feasible": self.feasible,
            "warnings": list(self.warnings),
            "violations": list(self.violations),
            "poisson_plate": self.poisson.to_dict(),
            "limits": self.limits.to_dict() if self.limits is not None else None,
            "test_sheet": sheet.to_dict() if sheet is not None else None,
            "damping": self.damping.to_dict() if self.damping is not None else None,
        }

    def report(self) -> str:
        lines = [self.design.report(), "", self.poisson.report()]
        if self.damping is not None:
            lines += ["", self.damping.report()]
        if self.limits is not None:
            lines += ["", self.limits.describe()]
        if self.warnings:
            lines += ["", "warnings:"] + [f"  - {w}" for w in self.warnings]
        if self.violations:
            lines += ["", "limits broken:"] + [f"  - {v}" for v in self.violations]
        if self.test_sheet is not None:
            lines += ["", self.test_sheet.report()]
        reasons = []
        if self.design.scores.verdict == Verdict.SINGULAR:
            reasons.append("singular: the layers cannot be told apart")
        if self.violations:
            reasons.append("a limit is broken")
        if not self.design.meets_targets:
            misses = self.design.target_misses()
            reasons.append(
                f"{len(misses)} parameter(s) miss their target std: "
                + ", ".join(p.name for p, _, _ in misses[:4])
                + (" ..." if len(misses) > 4 else "")
            )
        lines += ["", "feasible: " + ("yes" if self.feasible else "NO (" + "; ".join(reasons) + ")")]
        return "\n".join(lines)


def mode_warnings(problem: Problem, solved: Solved) -> list[str]:
    """Close pairs among the measured modes, and modes the band leaves out."""
    limits = problem.space.limits
    f = solved.frequencies_hz
    name = solved.configuration.name
    out = []
    threshold = max(CLOSE_MODES_WARNING, limits.min_separation)
    n = problem.modes
    for i in range(min(n, f.size - 1)):
        gap = (f[i + 1] - f[i]) / f[i]
        if gap < threshold:
            action = (
                "both are dropped (min_separation_rel)"
                if gap < limits.min_separation
                else "pair them by mode shape (measure where they differ) or set [design] min_separation_rel"
            )
            which = f"modes {i + 1} and {i + 2}" if i + 1 < n else f"mode {n} and the unmeasured mode {n + 1}"
            out.append(
                f"{which} of '{name}' are {100 * gap:.3g} % apart ({f[i]:.2f}, {f[i + 1]:.2f} Hz, "
                f"shapes {solved.labels[i]}, {solved.labels[i + 1]}): {action}"
            )
    if limits.band is not None:
        outside = [i for i in range(min(n, f.size)) if not limits.band[0] <= f[i] <= limits.band[1]]
        if outside:
            listed = ", ".join(f"{i + 1} ({f[i]:.1f} Hz)" for i in outside)
            out.append(
                f"'{name}': modes {listed} lie outside the band {limits.band[0]:g}..{limits.band[1]:g} Hz "
                "and are not measured"
            )
    return out


def check(
    problem: Problem | SpecimenModel, configurations=None, pool=None, progress: Progress | None = None
) -> CheckResult:
    """Score the spec's configurations (or the given ones) as one test set.

    The set is scored by the conditioning of its sensitivity matrix at the spec's values
    (over the prior range too when ``[design] prior_range_rel`` is set), and checked
    against the lab's limits; the result's ``test_sheet`` tells how to carry out the test.

    Parameters
    ----------
    problem : Problem or SpecimenModel
        A planning problem, or a model (its ``[design]`` table makes the problem).
    configurations : sequence of Configuration, optional
        The test set; default (None): the spec's configurations.
    pool : concurrent.futures.Executor, optional
        Where to solve the configurations not cached (None: in this process).
    progress : Progress, optional
        Where a progress bar goes for long runs (None: nowhere).

    Returns
    -------
    CheckResult
        The scored design, the Poisson-plate rule, warnings (close modes, modes outside the
        band, too few frequencies), violations of the lab's limits and the test sheet.

    Raises
    ------
    DesignError
        A configuration has no mode that would be measured (all outside ``band_hz``, or
        none separable).

    Examples
    --------
    >>> import designer
    >>> from identify.examples import COATED_PLATE
    >>> from fem import load_spec
    >>> result = designer.check(load_spec(COATED_PLATE))
    >>> result.feasible, round(result.design.scores.condition_number, 1)
    (True, 25.6)
    """
    problem = Problem.of(problem)
    configurations = tuple(configurations or problem.specimen.configurations)
    at_points = solve_points(problem.points(), configurations, pool=pool, progress=progress)
    solved, prior = at_points[0], at_points[1:]
    warnings, violations = [], []
    for s in solved:
        if not problem.measured(s).any():
            raise unmeasurable(problem, s)
        warnings += mode_warnings(problem, s)
        violations += [
            f"'{s.configuration.name}' {v}"
            for v in problem.space.limits.violations(s.configuration, problem.area)
        ]
    design = Design.of(problem, solved, prior or None)
    if design.n_measured < len(design.parameters):
        warnings.append(
            f"{design.n_measured} measured frequencies for {len(design.parameters)} parameters: "
            "singular whatever the plates; measure more modes ([model] modes) or add configurations"
        )
    damping = damping_scores(problem.model, configurations, problem.space.damping_std_rel)
    if damping is not None and damping.useless:
        warnings.append(
            f"the design does not determine the loss factors {', '.join(damping.useless)} (predicted std "
            "above the value): add configurations that change the layers' share of the strain energy"
        )
    return CheckResult(
        design,
        poisson_plate(problem.specimen),
        tuple(warnings),
        tuple(violations),
        problem.space.limits,
        problem,
        tuple(prior),
        damping,
    )
