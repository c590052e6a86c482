"""A scored test set: the configurations to measure (the original plate first), the
frequencies to expect and how well they identify every parameter."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fem.limits import added_mass
from fem.numbers import finite_or_none
from fem.solver.sensitivity import GOOD_BELOW, SINGULAR_ABOVE
from fem.specimen import Configuration, Parameter

from ..problem import Problem, Solved, solve_points
from .robust import RobustScores
from .scoring import WEAK_STD_REL, Scores, score

GPA = 1e9
#: Correlations of estimates beyond this are listed in reports.
STRONG_CORRELATION = 0.9


def display(parameter: Parameter, value: float) -> tuple[str, float]:
    """(key with unit, value in that unit): moduli in GPa, Poisson ratios plain."""
    if parameter.kind == "nu12":
        return "nu12", value
    return f"{parameter.kind}_GPa", value / GPA


def describe(configuration: Configuration) -> str:
    """e.g. 'top: adhesive 0.05 mm, brass 1 mm' (from the specimen outward); '-' for none."""
    parts = []
    for face in ("bottom", "top"):
        layers = getattr(configuration, face)
        if layers:
            parts.append(
                f"{face}: " + ", ".join(f"{l.material.name} {l.thickness * 1e3:g} mm" for l in layers)
            )
    return "; ".join(parts) or "-"


@dataclass(frozen=True)
class Design:
    """A test set, scored at the nominal properties and, with a prior range, over it.

    solved: each configuration's frequencies and relative sensitivities (original first);
    measured: per configuration, which of its first ``modes`` modes are measured;
    parameters, values: the identified parameters and their nominal values (SI);
    scores: condition number, Fisher information and predicted std of the stacked
    measured rows; frequency_std_rel: the scatter the std assumes; added_mass [kg];
    robust: the scores at the nominal point and every prior sample (None without a prior
    range); targets: each parameter's target relative std (None = none);
    targets_default: the targets are the defaults, not the spec's.
    """

    solved: tuple[Solved, ...]
    measured: tuple[np.ndarray, ...]
    parameters: tuple[Parameter, ...]
    values: np.ndarray
    scores: Scores
    frequency_std_rel: float
    added_mass: tuple[float, ...]
    robust: RobustScores | None = None
    targets: tuple[float | None, ...] = ()
    targets_default: bool = True

    @classmethod
    def of(cls, problem: Problem, solved: list[Solved], prior: list[list[Solved]] | None = None) -> Design:
        """The set ``solved`` at the nominal values; ``prior``: the same configurations
        solved at each prior sample (``problem.prior``), for the robust scores."""
        measured = tuple(problem.measured(s) for s in solved)
        sigma = problem.space.frequency_std_rel

        def scored(points: list[Solved]) -> Scores:
            return score(np.vstack([problem.rows(s) for s in points]), sigma)

        nominal = scored(solved)
        robust = None
        if prior:
            robust = RobustScores(problem.space.prior_range, (nominal,) + tuple(scored(p) for p in prior))
        targets = tuple(problem.space.target(p.kind) for p in problem.parameters)
        return cls(
            tuple(solved),
            measured,
            problem.parameters,
            problem.values,
            nominal,
            sigma,
            tuple(added_mass(s.configuration, problem.area) for s in solved),
            robust,
            targets,
            not problem.space.targets_given,
        )

    def loss(self, criterion: str) -> float:
        """What sets are ranked by: the criterion's worst case over the prior when the
        design has robust scores, else its nominal value (as a number to minimise)."""
        return self.robust.worst_loss(criterion) if self.robust is not None else self.scores.loss(criterion)

    @property
    def judged_std_rel(self) -> np.ndarray:
        """The relative std the targets are judged on: the worst over the prior when
        scored over it, else the nominal."""
        return self.robust.worst_std_rel if self.robust is not None else self.scores.std_rel

    def target_misses(self) -> list[tuple[Parameter, float, float]]:
        """(parameter, predicted relative std, target) of every parameter over its target."""
        return [
            (p, float(s), t)
            for p, s, t in zip(self.parameters, self.judged_std_rel, self.targets)
            if t is not None and not s <= t
        ]

    @property
    def meets_targets(self) -> bool:
        return not self.target_misses()

    def targets_dict(self) -> dict:
        kinds = {}
        for p, t in zip(self.parameters, self.targets):
            kinds.setdefault(p.kind, t)
        return {
            "std_rel": kinds,
            "default": self.targets_default,
            "basis": "worst over the prior" if self.robust is not None else "nominal",
            "met": self.meets_targets,
            "missed": [
                {"parameter": p.name, "predicted_std_rel": finite_or_none(s), "target_std_rel": t}
                for p, s, t in self.target_misses()
            ],
        }

    def targets_report(self) -> str:
        """One line: the targets and which parameters miss them."""
        kinds = {}
        for p, t in zip(self.parameters, self.targets):
            if t is not None:
                kinds.setdefault(p.kind, t)
        if "E1" in kinds and kinds.get("E2") == kinds["E1"]:  # one modulus target: "E"
            kinds = {("E" if k == "E1" else k): t for k, t in kinds.items() if k != "E2"}
        stated = ", ".join(f"{k} {100 * t:g} %" for k, t in kinds.items())
        where = "default; set [design] target_std_rel" if self.targets_default else "[design] target_std_rel"
        basis = " (worst over the prior)" if self.robust is not None else ""
        misses = self.target_misses()
        if not misses:
            return f"target std ({stated}; {where}): met by all {len(self.parameters)} parameters{basis}"
        listed = ", ".join(f"{p.name} {100 * s:.3g} %" for p, s, _ in misses[:6]) + (
            " ..." if len(misses) > 6 else ""
        )
        return (
            f"target std ({stated}; {where}): MISSED by {len(misses)} of {len(self.parameters)} "
            f"parameters{basis}: {listed}"
        )

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.configuration.name for s in self.solved)

    @property
    def n_measured(self) -> int:
        return int(sum(m.sum() for m in self.measured))

    @property
    def std(self) -> np.ndarray:
        """Predicted std of each parameter (SI)."""
        return self.scores.std_rel * np.abs(self.values)

    def predicted_std(self, relative: bool = False) -> dict[str, dict[str, float | None]]:
        """Material -> {E1_GPa, E2_GPa, G12_GPa, nu12} predicted std (or relative std)."""
        out: dict[str, dict] = {}
        for p, std, rel in zip(self.parameters, self.std, self.scores.std_rel):
            key, value = display(p, std)
            out.setdefault(p.target, {})[p.kind if relative else key] = finite_or_none(
                rel if relative else value
            )
        return out

    def configurations_dict(self) -> list[dict]:
        rows = []
        for s, measured, mass in zip(self.solved, self.measured, self.added_mass):
            c = s.configuration
            rows.append(
                {
                    "name": c.name,
                    "added": [
                        {
                            "face": face,
                            "material": l.material.name,
                            "thickness_mm": round(l.thickness * 1e3, 6),
                        }
                        for face in ("bottom", "top")
                        for l in getattr(c, face)
                    ],
                    "added_mass_g": round(mass * 1e3, 3),
                    "frequencies_hz": s.frequencies_hz[: measured.size].round(4),
                    "labels": list(s.labels[: measured.size]),
                    "measured": measured,
                }
            )
        return rows

    def to_dict(self) -> dict:
        sc = self.scores
        return {
            "configurations": self.configurations_dict(),
            "condition_number": finite_or_none(sc.condition_number),
            "verdict": sc.verdict,
            "logdet_fisher": finite_or_none(sc.logdet_fisher),
            "min_eigenvalue_fisher": sc.min_eigenvalue_fisher,
            "frequency_std_rel": self.frequency_std_rel,
            "predicted_std": self.predicted_std(),
            "predicted_std_rel": self.predicted_std(relative=True),
            "targets": self.targets_dict(),
            "robust": self.robust.to_dict(self.parameters) if self.robust is not None else None,
        }

    def summary(self) -> str:
        """One line: configurations and condition number."""
        scores = self.scores
        return f"{' + '.join(self.names)}: condition number {scores.condition_number:.4g} ({scores.verdict})"

    def report(self) -> str:
        """Fixed sections: statistics, configurations with the frequencies to expect,
        parameters with predicted std and flags, strong correlations."""
        sc = self.scores
        p = len(self.parameters)
        lines = [
            f"test set: {' + '.join(self.names)} ({len(self.solved)} configurations, "
            f"{self.n_measured} measured frequencies, {p} parameters)",
            f"condition number {sc.condition_number:.4g}: {sc.verdict} (good below {power(GOOD_BELOW)}, "
            f"ill-conditioned up to {power(SINGULAR_ABOVE)}, singular above; paper section 4.6)",
            self.targets_report(),
            f"Fisher information for {100 * self.frequency_std_rel:.3g} % frequency scatter: "
            f"log det {sc.logdet_fisher:.5g}, smallest eigenvalue {sc.min_eigenvalue_fisher:.4g}",
        ]
        if self.robust is not None:
            r = self.robust
            lines.append(
                f"over the prior range (identified properties x 1/{1 + r.range_rel:g}..{1 + r.range_rel:g}, "
                f"{len(r.scores) - 1} samples + nominal): condition number worst {r.worst('condition'):.4g}, "
                f"mean {r.mean('condition'):.4g}; log det F worst {r.worst('d'):.5g}, mean {r.mean('d'):.5g}"
            )
        lines += ["", "configurations: added layers, added mass, frequencies to expect [Hz] ([not measured])"]
        width = max(len(n) for n in self.names)
        added = [describe(s.configuration) for s in self.solved]
        added_width = max(len(a) for a in added)
        for s, measured, mass, what in zip(self.solved, self.measured, self.added_mass, added):
            freqs = " ".join(f"{f:.1f}" if m else f"[{f:.1f}]" for f, m in zip(s.frequencies_hz, measured))
            lines.append(
                f"  {s.configuration.name:<{width}s}  {what:<{added_width}s}  {mass * 1e3:6.1f} g  {freqs}"
            )
        width = max(len(par.name) for par in self.parameters)
        worst = self.robust.worst_std_rel if self.robust is not None else None
        lines += [
            "",
            f"  {'parameter':<{width}s}  {'nominal':>13s}  {'predicted std':>13s}  {'relative':>9s}"
            + (f"  {'worst':>9s}" if worst is not None else "")
            + f"  {'target':>7s}",
        ]
        for j, (par, value, std, rel) in enumerate(zip(self.parameters, self.values, self.std, sc.std_rel)):
            key, v = display(par, value)
            _, s_ = display(par, std)
            unit = " GPa" if key.endswith("GPa") else "    "
            target = self.targets[j] if self.targets else None
            judged = self.judged_std_rel[j]
            flag = (
                "  singular"
                if not np.isfinite(rel)
                else ("  weakly identifiable" if rel > WEAK_STD_REL else "")
            )
            if target is not None and not judged <= target:
                flag += "  misses target"
            lines.append(
                f"  {par.name:<{width}s}  {v:>9.4g}{unit}  {s_:>9.3g}{unit}  {100 * rel:>7.3g} %"
                + (f"  {100 * worst[j]:>7.3g} %" if worst is not None else "")
                + (f"  {100 * target:>5.3g} %" if target is not None else f"  {'-':>7s}")
                + flag
            )
        if np.all(np.isfinite(sc.correlation)):
            i, j = np.triu_indices(p, 1)
            strong = sorted(
                (
                    (abs(sc.correlation[a, b]), a, b)
                    for a, b in zip(i, j)
                    if abs(sc.correlation[a, b]) > STRONG_CORRELATION
                ),
                reverse=True,
            )
            if strong:
                lines += ["", f"strong correlations of the estimates (|r| > {STRONG_CORRELATION}):"]
                lines += [
                    f"  {self.parameters[a].name} ~ {self.parameters[b].name}: {sc.correlation[a, b]:+.3f}"
                    for _, a, b in strong[:8]
                ]
        return "\n".join(lines)


def power(x: float) -> str:
    """1000.0 -> '1e3'."""
    return f"1e{round(math.log10(x))}"


def score_design(problem: Problem, configurations, pool=None, progress=None) -> Design:
    """The configurations solved at the nominal values and, with a prior range, at every
    prior sample (one batch), scored as a ``Design``."""
    points = problem.points()
    solved = solve_points(points, configurations, pool, progress)
    return Design.of(problem, solved[0], solved[1:] or None)
