"""Refinement of the added plates' thicknesses, snapped to stock.

A lab buys plates in the stock thicknesses of the design space (``thicknesses_mm``).
Starting from a chosen set, BOBYQA (nlopt, derivative-free) first moves each added
plate's thickness continuously within the stock range (and below the mass and thickness
limits) to improve the criterion at the nominal values: where the optimum lies.  Then
every combination of the stock thicknesses next to it (the one below, the one above,
and the plate's own) is scored as sets are ranked (over the prior when the design has a
prior range), within the limits, and the best replaces the chosen set only if it
improves the criterion.  The continuous optimum is reported beside it: what plates
ground to size would gain.  After an exhaustive search every stock combination has been
scored already, so the refinement can only confirm the chosen set; after the convex
relaxation it may improve it.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import nlopt
import numpy as np

from fem.limits import added_mass, added_thickness
from fem.specimen import Configuration

from ..candidates import outer_face, with_plate_thickness
from ..problem import Problem
from ..scores.design import Design, score_design

#: Relative thickness change [-] at which the continuous search stops (1 %: a plate is
#: ground to about 0.01 mm, and the result is snapped to stock anyway), and evaluations
#: allowed per refined plate (each solves that many configurations, ~20 ms apiece).
XTOL_REL = 1e-2
EVALUATIONS_PER_PLATE = 25
#: Loss of a set with no measurable mode in some configuration (worse than any real one).
INFEASIBLE = 1e3
#: A refinement must lower the criterion's loss by more than this (relative) to count.
IMPROVEMENT = 1e-9


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
    """The set before and after refinement, the refined (stock) thicknesses [m] with
    their bounds, and the evaluations the continuous search took.

    improved: a stock combination scored better than the chosen set (else ``design`` is
    the chosen set); continuous: the continuous optimum's thicknesses [m] and
    continuous_design its set at the nominal values; stock: per plate, the stock
    thicknesses [m] tried."""

    start: Design
    design: Design
    thicknesses: tuple[float, ...]
    bounds: tuple[tuple[float, float], ...]
    evaluations: int
    criterion: str = "condition"
    improved: bool = False
    continuous: tuple[float, ...] = ()
    continuous_design: Design | None = None
    stock: tuple[tuple[float, ...], ...] = ()

    def to_dict(self) -> dict:
        out = {
            "thicknesses_mm": [round(t * 1e3, 4) for t in self.thicknesses],
            "bounds_mm": [[lo * 1e3, hi * 1e3] for lo, hi in self.bounds],
            "evaluations": self.evaluations,
            "design": self.design.to_dict(),
            "improved": self.improved,
            "criterion": self.criterion,
            "stock_tried_mm": [[round(t * 1e3, 4) for t in ts] for ts in self.stock],
            "continuous_thicknesses_mm": [round(t * 1e3, 4) for t in self.continuous],
        }
        if self.continuous_design is not None:
            sc = self.continuous_design.scores
            out["continuous"] = {
                "condition_number": sc.condition_number,
                "logdet_fisher": sc.logdet_fisher,
                "min_eigenvalue_fisher": sc.min_eigenvalue_fisher,
            }
        return out

    def _scores(self, d: Design) -> str:
        text = f"condition number {d.scores.condition_number:.4g}, log det F {d.scores.logdet_fisher:.5g}"
        if d.robust is not None:
            text += f", worst over the prior {d.robust.worst(self.criterion):.5g}"
        return text

    def report(self) -> str:
        plates = ", ".join(f"{s.configuration.name}" for s in self.design.solved[1:])
        if self.improved:
            head = (
                f"refined to stock thicknesses: {plates}; {self._scores(self.start)} -> "
                f"{self._scores(self.design)}"
            )
        else:
            head = (
                "refinement: no combination of the stock thicknesses next to the continuous optimum "
                f"improves the {self.criterion} criterion within the limits; the chosen set stands"
            )
        lines = [head]
        if self.continuous_design is not None:
            c, s = self.continuous_design.scores, self.start.scores
            ground = ", ".join(f"{t * 1e3:.3g} mm" for t in self.continuous)
            lines.append(
                f"  (plates ground to size, continuous optimum by nlopt BOBYQA in {self.evaluations} "
                f"evaluations at the nominal values: {ground}; condition number {s.condition_number:.4g} -> "
                f"{c.condition_number:.4g}, log det F {s.logdet_fisher:.5g} -> {c.logdet_fisher:.5g})"
            )
        return "\n".join(lines)


def _thickness(configuration: Configuration) -> float:
    return getattr(configuration, outer_face(configuration))[-1].thickness


def stock_near(
    problem: Problem, configuration: Configuration, x: float, bounds: tuple[float, float]
) -> tuple:
    """The stock thicknesses [m] next to ``x`` (below and above) and the plate's own,
    within ``bounds`` and the limits."""
    stock = sorted(
        t for t in problem.space.thicknesses if bounds[0] * (1 - 1e-9) <= t <= bounds[1] * (1 + 1e-9)
    )
    below = [t for t in stock if t <= x]
    above = [t for t in stock if t >= x]
    near = {_thickness(configuration)} | set(below[-1:]) | set(above[:1])
    limits = problem.space.limits
    return tuple(
        sorted(t for t in near if not limits.violations(with_plate_thickness(configuration, t), problem.area))
    )


def refine(problem: Problem, design: Design) -> Refinement:
    """Refine the thickness of every added plate of ``design`` (original first) to the
    stock thicknesses; see the module's description."""
    base = [s.configuration for s in design.solved]
    added = base[1:]
    bounds = [thickness_range(problem, c) for c in added]
    criterion = problem.space.criterion

    def configurations(x_m) -> list[Configuration]:
        return base[:1] + [with_plate_thickness(c, t, rename=True) for c, t in zip(added, x_m)]

    best = {"loss": np.inf, "x": None}

    def objective(x_mm, grad) -> float:
        solved = problem.solve(configurations(np.asarray(x_mm) * 1e-3))
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
    start = [_thickness(c) * 1e3 for c in added]
    try:
        opt.optimize(np.clip(start, opt.get_lower_bounds(), opt.get_upper_bounds()))
    except nlopt.RoundoffLimited:  # the best point so far stands
        pass
    x = np.asarray(start if best["x"] is None else best["x"]) * 1e-3
    continuous = Design.of(problem, problem.solve(configurations(x)))

    stock = [stock_near(problem, c, xi, b) for c, xi, b in zip(added, x, bounds)]
    chosen, chosen_loss, chosen_x = design, design.loss(criterion), tuple(_thickness(c) for c in added)
    for combination in itertools.product(*stock):
        if np.allclose(combination, chosen_x, rtol=1e-12, atol=0) and chosen is design:
            continue
        candidate_configurations = configurations(combination)
        solved = problem.solve(candidate_configurations)
        if not all(problem.measured(s).any() for s in solved):
            continue
        candidate = score_design(problem, candidate_configurations)
        if candidate.loss(criterion) < chosen_loss - IMPROVEMENT * abs(chosen_loss):
            chosen, chosen_loss, chosen_x = candidate, candidate.loss(criterion), tuple(combination)
    return Refinement(
        design,
        chosen,
        tuple(float(t) for t in chosen_x),
        tuple(bounds),
        opt.get_numevals(),
        criterion,
        chosen is not design,
        tuple(float(t) for t in x),
        continuous,
        tuple(tuple(float(t) for t in ts) for ts in stock),
    )
