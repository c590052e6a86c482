"""Continuous refinement of the added plates' thicknesses (nlopt, derivative-free).

Stock comes in a few thicknesses; a plate can also be ground or ordered to size.  Starting
from a chosen set, BOBYQA moves each added plate's thickness within the stock range
(and below the mass and thickness limits) to improve the criterion; every evaluation
solves the changed configurations (cached by content).
"""
from __future__ import annotations

from dataclasses import dataclass

import nlopt
import numpy as np

from fem.limits import added_mass, added_thickness
from fem.specimen import Configuration

from .candidates import outer_face, with_plate_thickness
from .design import Design
from .problem import Problem

#: Relative thickness change [-] at which the refinement stops, and evaluations allowed
#: per refined plate (each solves that many configurations, ~20 ms apiece).
XTOL_REL = 1e-3
EVALUATIONS_PER_PLATE = 40
#: Loss of a set with no measurable mode in some configuration (worse than any real one).
INFEASIBLE = 1e3


def thickness_range(problem: Problem, configuration: Configuration) -> tuple[float, float]:
    """Stock range [m] of the outer plate, capped by the mass and thickness limits."""
    low, high = min(problem.space.thicknesses), max(problem.space.thicknesses)
    limits = problem.space.limits
    plate = getattr(configuration, outer_face(configuration))[-1]
    thin = with_plate_thickness(configuration, low)
    if limits.max_added_mass is not None:
        spare = limits.max_added_mass - added_mass(thin, problem.area)
        high = min(high, low + spare / (plate.material.density * problem.area))
    if limits.max_added_thickness is not None:
        high = min(high, low + limits.max_added_thickness - added_thickness(thin))
    return low, max(low, high)


@dataclass(frozen=True)
class Refinement:
    """The set before and after refinement, the refined thicknesses [m] with their
    bounds, and the evaluations it took."""

    start: Design
    design: Design
    thicknesses: tuple[float, ...]
    bounds: tuple[tuple[float, float], ...]
    evaluations: int

    def to_dict(self) -> dict:
        return {"thicknesses_mm": [round(t * 1e3, 4) for t in self.thicknesses],
                "bounds_mm": [[lo * 1e3, hi * 1e3] for lo, hi in self.bounds],
                "evaluations": self.evaluations, "design": self.design.to_dict()}

    def report(self) -> str:
        plates = ", ".join(f"{s.configuration.name} {t * 1e3:.3g} mm" for s, t in
                           zip(self.design.solved[1:], self.thicknesses))
        return (f"refined thicknesses (nlopt BOBYQA, {self.evaluations} evaluations, within stock bounds): {plates}; "
                f"condition number {self.start.scores.condition_number:.4g} -> "
                f"{self.design.scores.condition_number:.4g}, log det F {self.start.scores.logdet_fisher:.5g} -> "
                f"{self.design.scores.logdet_fisher:.5g}")


def refine(problem: Problem, design: Design) -> Refinement:
    """Refine the thickness of every added plate of ``design`` (original first)."""
    base = [s.configuration for s in design.solved]
    added = base[1:]
    bounds = [thickness_range(problem, c) for c in added]
    criterion = problem.space.criterion

    def configurations(x_mm) -> list[Configuration]:
        return base[:1] + [with_plate_thickness(c, t * 1e-3, rename=True) for c, t in zip(added, x_mm)]

    best = {"loss": np.inf, "x": None}

    def objective(x_mm, grad) -> float:
        solved = problem.solve(configurations(x_mm))
        value = INFEASIBLE
        if all(problem.measured(s).any() for s in solved):
            value = min(Design.of(problem, solved).scores.loss(criterion), INFEASIBLE)
        if value < best["loss"]:
            best.update(loss=value, x=np.array(x_mm))
        return value

    opt = nlopt.opt(nlopt.LN_BOBYQA, len(added))
    opt.set_lower_bounds([lo * 1e3 for lo, _ in bounds])
    opt.set_upper_bounds([hi * 1e3 for _, hi in bounds])
    opt.set_min_objective(objective)
    opt.set_xtol_rel(XTOL_REL)
    opt.set_maxeval(EVALUATIONS_PER_PLATE * len(added))
    start = [getattr(c, outer_face(c))[-1].thickness * 1e3 for c in added]
    try:
        opt.optimize(np.clip(start, opt.get_lower_bounds(), opt.get_upper_bounds()))
    except nlopt.RoundoffLimited:  # the best point so far stands
        pass
    x = start if best["x"] is None else best["x"]
    refined = Design.of(problem, problem.solve(configurations(x)))
    if refined.scores.loss(criterion) > design.scores.loss(criterion):  # never report a worse set
        refined, x = design, start
    return Refinement(design, refined, tuple(float(t) * 1e-3 for t in x), tuple(bounds), opt.get_numevals())
