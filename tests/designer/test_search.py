"""recommend: the planner's acceptance space, exhaustive search against the convex
relaxation, and the lab's limits."""

import itertools

import numpy as np
import pytest

from designer.candidates import candidates
from designer.check import check
from designer.problem import Problem
from designer.search.ranking import ORIGINAL, recommend, stacked_rows
from designer.search.relaxation import information_loss
from designer.sweep import sweep
from fem.errors import DesignError
from fem.model import SpecimenModel

from .conftest import paper_data, problem_of, with_criterion


@pytest.fixture(scope="module")
def exhaustive_result(acceptance_problem):
    return recommend(acceptance_problem, top=5, method="exhaustive")


def test_acceptance_space_beats_the_papers_design(exhaustive_result, paper_problem):
    """Brass / aluminium / steel x 0.5-3 mm x top / bottom: all 630 sets of two; the best
    is at least as well conditioned as the paper's brass design (which is one of them)."""
    r = exhaustive_result
    assert (r.method, r.candidates, r.sets) == ("exhaustive", 36, 630)
    paper = check(paper_problem).design.scores.condition_number
    assert r.best.scores.condition_number <= paper
    assert r.baseline.scores.condition_number == pytest.approx(paper, rel=1e-12)
    conds = [d.scores.condition_number for d in r.designs]
    assert conds == sorted(conds), "best first"


def test_best_design_scored_like_the_fem_matrix(exhaustive_result, acceptance_problem):
    """The winning set, rebuilt as a specimen with those configurations and scored by the
    physics core's global matrix and numpy: the same condition number."""
    best = exhaustive_result.best
    specimen = acceptance_problem.specimen.with_configurations([s.configuration for s in best.solved])
    matrix = SpecimenModel(specimen, acceptance_problem.options).sensitivity_matrix(
        list(acceptance_problem.parameters)
    )
    assert best.scores.condition_number == pytest.approx(np.linalg.cond(matrix), rel=1e-10)


def all_set_losses(problem: Problem, criterion: str) -> tuple[list, np.ndarray]:
    """Every pair of candidates and its loss, from information matrices (independent of
    the batched-SVD scoring that the exhaustive search uses)."""
    pool = candidates(problem.space, problem.specimen)
    solved = problem.solve((ORIGINAL,) + pool.configurations)
    rows0 = problem.rows(solved[0])
    blocks = stacked_rows(problem, solved[1:])
    info0, infos = rows0.T @ rows0, np.einsum("mrp,mrq->mpq", blocks, blocks)
    pairs = list(itertools.combinations(range(len(infos)), 2))
    idx = np.array(pairs)
    return [(pool.configurations[i].name, pool.configurations[j].name) for i, j in pairs], information_loss(
        info0 + infos[idx[:, 0]] + infos[idx[:, 1]], criterion
    )


@pytest.mark.parametrize("criterion", ["d", "e", "condition"])
def test_exhaustive_and_relaxation_agree(acceptance_problem, criterion):
    """On the 630 enumerable sets: the relaxation (rounded, swapped) picks the exhaustive
    optimum, and its bound is above every set's value (up to the solver's 1e-6)."""
    problem = with_criterion(acceptance_problem, criterion)
    exact = recommend(problem, top=1, method="exhaustive").best
    relaxed = recommend(problem, top=1, method="relaxation")
    assert relaxed.best.names == exact.names
    names, losses = all_set_losses(problem, criterion)
    assert set(names[int(np.argmin(losses))]) == set(exact.names[1:])
    b = relaxed.bound
    assert b.criterion == ("d" if criterion == "d" else "e")
    optimum = recommend(with_criterion(problem, b.criterion), top=1, method="exhaustive").best.scores.value(
        b.criterion
    )
    assert b.chosen == pytest.approx(relaxed.best.scores.value(b.criterion), rel=1e-8)
    assert b.chosen <= optimum * (1 + 1e-9)
    assert b.relaxed >= optimum * (1 - 1e-6)


def test_too_many_configurations_for_the_candidates():
    problem = problem_of(paper_data(), materials=["brass"], thicknesses_mm=[1.0], configurations=4)
    with pytest.raises(DesignError) as info:
        recommend(problem)
    message = str(info.value)
    assert "configurations = 4 needs 3 added plates" in message and "offers 2 candidate" in message
    assert "\n" not in message


def test_band_that_excludes_every_mode():
    """recommend, check and sweep all stop with the same one-line error."""
    problem = problem_of(paper_data(), band_hz=[5000.0, 6000.0])
    for run in (recommend, check, lambda p: sweep(p, [])):
        with pytest.raises(
            DesignError,
            match=r"band_hz = \[5000, 6000\] excludes every mode of configuration "
            r"'original' \(its 5 modes lie at 129.3\.\.337 Hz\)",
        ):
            run(problem)


def test_band_leaves_out_stiff_candidates():
    """A band ending at 195 Hz keeps the original plate's first two modes (129, 192 Hz).
    Added plates raise the first mode, the 0.5 mm brass least (to 189 Hz: its mass nearly
    cancels its stiffness), so every other candidate is left out, with the reason."""
    problem = problem_of(
        paper_data(), band_hz=[20.0, 195.0], materials=["aluminium", "brass"], thicknesses_mm=[0.5, 2.0]
    )
    solved = problem.solve(candidates(problem.space, problem.specimen).configurations)
    inside = {s.configuration.name for s in solved if s.frequencies_hz[0] <= 195.0}
    assert inside == {"brass_0.5mm_top", "brass_0.5mm_bottom"}
    r = recommend(problem, top=1)
    assert set(r.excluded) == {s.configuration.name for s in solved} - inside
    assert all(why == "no mode inside band_hz" for why in r.excluded.values())
    assert r.best.n_measured == 4 and r.best.scores.verdict == "singular"


def test_mass_and_thickness_limits():
    """Added mass = area x sum(density x thickness): brass 1 mm + 50 um adhesive on the
    150 x 150 mm plate is 0.0225 (8500e-3 + 1200 x 50e-6) = 192.6 g.  Limits at 150 g and
    1.6 mm total leave the 0.5 mm brass and the 1 mm aluminium (62.0 + 1.35 g)."""
    problem = problem_of(
        paper_data(),
        materials=["brass", "aluminium"],
        thicknesses_mm=[0.5, 1.0, 2.0],
        max_added_mass_g=150.0,
        max_added_thickness_mm=1.6,
    )
    pool = candidates(problem.space, problem.specimen)
    kept = {c.name for c in pool.configurations}
    assert kept == {
        f"{m}_{t}mm_{p}"
        for m, t in (("brass", 0.5), ("aluminium", 0.5), ("aluminium", 1))
        for p in ("top", "bottom")
    }
    assert "192.6 g > max_added_mass_g = 150" in pool.excluded["brass_1mm_top"]
    assert "2.05 mm > max_added_thickness_mm = 1.6" in pool.excluded["aluminium_2mm_bottom"]
    r = recommend(problem, top=3)
    assert all(m * 1e3 <= 150.0 for d in r.designs for m in d.added_mass)


def test_min_separation_drops_close_pairs(paper):
    """The original plate's modes 4 and 5 are 0.045 % apart (a near-degenerate pair of the
    square, near-isotropic plate): with min_separation_rel = 0.1 % both go, so 3 of 5
    modes are measured; with 0.01 % they stay."""
    problem = problem_of(paper_data(), min_separation_rel=0.001)
    solved = problem.solve([ORIGINAL])[0]
    assert len(solved.frequencies_hz) == 6, "one extra mode to judge the last measured one"
    assert problem.measured(solved).tolist() == [True, True, True, False, False]
    loose = problem_of(paper_data(), min_separation_rel=0.0001)
    assert loose.measured(loose.solve([ORIGINAL])[0]).all()
