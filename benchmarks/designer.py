"""Test-planner benchmarks.

Targets on the 2-core reference machine: 36 candidates (3 materials x 6 thicknesses x 2
placements) and all 630 sets of two additions < 10 s; 1000 candidates through the
convex relaxation < 60 s; the 630 sets scored over 16 prior samples (robust) < 30 s; the
test sheet adds < 1 s to `check`.  Times are from a cold cache (every configuration
solved).  The spaces keep every candidate of the planner's acceptance space: a mass limit of 10 kg stands in
for the default one (3 x the specimen's mass), which would leave the thick plates out.
"""

import itertools
import math
import os
import time
import tomllib
from dataclasses import replace

import numpy as np

from designer import problem as problem_module
from designer.candidates import candidates
from designer.check import check
from designer.parallel import executor
from designer.problem import Problem
from designer.search.ranking import ORIGINAL, recommend, stacked_rows
from designer.search.relaxation import information_loss
from fem.design_space import parse_design
from fem.model import solve_laminate

from .common import PAPER_TABLE1, paper_spec

PAPER_DESIGN = tomllib.loads(PAPER_TABLE1.read_text())["design"]
THICKNESSES_36 = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
MATERIALS_1000 = ("brass", "aluminium", "steel_stock", "copper", "titanium")


def paper_problem(materials, thicknesses_mm, size: int = 3, **more) -> Problem:
    """The paper's plate (Table 1 values, 5 modes) with a design space."""
    model = paper_spec()
    design = {
        **PAPER_DESIGN,
        "materials": list(materials),
        "thicknesses_mm": list(thicknesses_mm),
        "configurations": size,
        "max_added_mass_g": 1e4,
        **more,
    }
    return Problem(
        model, parse_design(design, model.defined_materials, len(model.specimen.identified_materials))
    )


def cold() -> None:
    """Forget every solved configuration (this process's caches)."""
    problem_module._CACHE.clear()
    solve_laminate.cache_clear()


def timed(function):
    start = time.perf_counter()
    out = function()
    return out, time.perf_counter() - start


def serial_and_parallel(problem: Problem):
    """(the serial result, its time, the time with a 2-process pool) of an exhaustive
    recommendation from a cold cache; both must rank the same designs."""
    cold()
    serial, t_serial = timed(lambda: recommend(problem, method="exhaustive"))
    cold()

    def with_pool():
        with executor(2) as pool:
            return recommend(problem, method="exhaustive", pool=pool)

    parallel, t_parallel = timed(with_pool)
    assert [d.names for d in parallel.designs] == [d.names for d in serial.designs]
    return serial, t_serial, t_parallel


def small_space() -> None:
    problem = paper_problem(("brass", "aluminium", "steel_stock"), THICKNESSES_36)
    print(f"-- 36 candidates, all {math.comb(36, 2)} sets of two additions (target < 10 s) --")
    serial, t_serial, t_parallel = serial_and_parallel(problem)
    print(
        f"serial: {t_serial:.2f} s ({t_serial / 10:.2f} of the target); 2 processes (start-up included): "
        f"{t_parallel:.2f} s ({t_parallel / 10:.2f} of the target); serial / parallel "
        f"{t_serial / t_parallel:.2f}"
    )
    scored = recommend(problem, method="exhaustive")  # warm: the set scoring alone
    print(
        f"scoring the {scored.sets} sets alone (batched SVD, warm cache): {scored.seconds * 1e3:.0f} ms; "
        f"best {', '.join(scored.best.names[1:])}: condition number {scored.best.scores.condition_number:.4g}"
    )
    relaxed = recommend(problem, method="relaxation")
    for criterion in ("d", "e"):
        exact = recommend(
            replace(problem, space=replace(problem.space, criterion=criterion)), top=1, method="exhaustive"
        ).best
        bound = recommend(
            replace(problem, space=replace(problem.space, criterion=criterion)), top=1, method="relaxation"
        ).bound
        print(
            f"relaxation ({criterion}): bound {bound.relaxed:.6g}, chosen {bound.chosen:.6g}, exhaustive "
            "optimum "
            f"{exact.scores.value(criterion):.6g}"
        )
    print(
        f"relaxation (condition number, via e): chosen {relaxed.best.scores.condition_number:.4g}, "
        "exhaustive "
        f"optimum {serial.best.scores.condition_number:.4g}"
    )


def large_space() -> None:
    thicknesses = tuple(np.round(np.linspace(0.3, 3.0, 100), 4))
    problem = paper_problem(MATERIALS_1000, thicknesses)
    space = candidates(problem.space, problem.specimen)
    workers = os.cpu_count() or 1
    print(f"-- {len(space)} candidates through the convex relaxation (target < 60 s) --")
    cold()

    def solve():
        with executor(workers) as pool:
            return problem.solve((ORIGINAL,) + space.configurations, pool=pool)

    solved, t_solve = timed(solve)
    result, t_search = timed(lambda: recommend(problem, method="relaxation"))  # warm: relaxation and swaps
    total = t_solve + t_search
    print(
        f"solving {len(solved)} configurations on {workers} processes: {t_solve:.1f} s; relaxation, rounding "
        "and "
        f"swaps: {t_search:.1f} s; total {total:.1f} s ({total / 60:.2f} of the target)"
    )
    print(result.bound.report())
    d = replace(problem, space=replace(problem.space, criterion="d"))
    by_d, t_d = timed(lambda: recommend(d, top=1, method="relaxation"))
    print(f"log det relaxation instead: {t_d:.1f} s; {by_d.bound.report()}")
    rows0 = problem.rows(solved[0])
    blocks = stacked_rows(problem, solved[1:])
    info0, infos = rows0.T @ rows0, np.einsum("mrp,mrq->mpq", blocks, blocks)
    best, t_exhaustive = timed(lambda: exhaustive_condition(info0, infos))
    print(
        f"chosen {', '.join(result.best.names[1:])}: condition number "
        f"{result.best.scores.condition_number:.4g}; "
        f"all {math.comb(len(infos), 2)} sets checked ({t_exhaustive:.1f} s): best {best:.4g}, "
        f"chosen / best {result.best.scores.condition_number / best:.4f}"
    )


def exhaustive_condition(info0: np.ndarray, infos: np.ndarray) -> float:
    """The smallest condition number over every pair (from information matrices)."""
    best = np.inf
    pairs = itertools.combinations(range(len(infos)), 2)
    while chunk := list(itertools.islice(pairs, 20000)):
        index = np.array(chunk)
        best = min(best, information_loss(info0 + infos[index[:, 0]] + infos[index[:, 1]], "condition").min())
    return math.exp(best)


def robust_space() -> None:
    """The 36 candidates scored at the nominal point and 16 prior samples (+-30 %): 37 x 17
    = 629 solves, then all 630 sets scored at the 17 points (batched SVD)."""
    problem = paper_problem(
        ("brass", "aluminium", "steel_stock"), THICKNESSES_36, prior_range_rel=0.3, prior_samples=16
    )
    print("-- 36 candidates, all 630 sets, scored over 16 prior samples of +-30 % (target < 30 s) --")
    serial, t_serial, t_parallel = serial_and_parallel(problem)
    warm = recommend(problem, method="exhaustive")
    solves = (serial.candidates + 1) * (serial.prior_samples + 1)
    print(
        f"serial: {t_serial:.1f} s ({t_serial / 30:.2f} of the target; {solves} solves, "
        f"{1e3 * (t_serial - warm.seconds) / solves:.0f} ms each); 2 processes (start-up included): "
        f"{t_parallel:.1f} s ({t_parallel / 30:.2f} of the target); scoring 630 sets x 17 points alone "
        "(warm): "
        f"{warm.seconds * 1e3:.0f} ms"
    )
    nominal = recommend(replace(problem, space=replace(problem.space, prior_range=0.0)), top=1).best
    print(
        f"robust best: {', '.join(serial.best.names[1:])}, condition number worst "
        f"{serial.best.robust.worst('condition'):.4g} (nominal {serial.best.scores.condition_number:.4g}); "
        f"nominal best: {', '.join(nominal.names[1:])} (nominal {nominal.scores.condition_number:.4g})"
    )


def sheet_cost() -> None:
    """What the test sheet adds to `check` of the paper's three configurations (cold
    cache): the sheet itself (text and JSON), and the figures apart."""
    problem = paper_problem(("brass",), (1.0,))
    print("-- the test sheet in check (target: adds < 1 s) --")
    cold()
    result, t_check = timed(lambda: check(problem))
    sheet, t_sheet = timed(lambda: result.test_sheet)
    _, t_json = timed(lambda: result.to_dict())
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        _, t_figures = timed(lambda: sheet.write(folder))
    print(
        f"check (3 solves): {t_check:.2f} s; the test sheet adds {t_sheet:.3f} s ({t_sheet:.2f} of the "
        "target), "
        f"its JSON {t_json * 1e3:.0f} ms; the 3 figures (check --out, matplotlib included) {t_figures:.1f} s"
    )


def main() -> None:
    print("== test planner ==")
    small_space()
    robust_space()
    sheet_cost()
    large_space()


if __name__ == "__main__":
    main()
