"""Physics-core benchmarks: solve time, sensitivity cost, accuracy vs mesh.

Targets on the 2-core reference machine: one solve of the paper's plate with 10 modes
within 0.05 % of converged <= 30 ms; all 12 sensitivities <= 1.3x one solve (the
paper's finite-difference route costs 13x).
"""

import json
from functools import partial
from pathlib import Path

import numpy as np

from fem.model import ModelOptions, SpecimenModel, solve_laminate
from fem.solver.assembly import unit_matrices
from fem.solver.mesh import PlateMesh
from fem.solver.sensitivity import ModalEnergies

from .common import best_time, paper_spec

CONVERGED = np.array(
    json.loads((Path(__file__).parent.parent / "tests" / "data" / "free_plates.json").read_text())[
        "paper_plate_clt_converged"
    ]["first15_elastic_hz"]
)
solve_uncached = solve_laminate.__wrapped__


def accuracy_against_time() -> list[dict]:
    """Worst error of the first 5/10/15 modes and solve time per mesh (original plate)."""
    laminate = paper_spec().specimen.laminate("original")
    rows = []
    for n in (6, 8, 10, 11, 12, 14, 16, 18, 20):
        mesh = PlateMesh(0.15, 0.15, n, n)
        units = unit_matrices(mesh)
        _ = units.stiffness_data  # assembled (and cached) once per mesh: not timed
        error = np.abs(solve_uncached(laminate, mesh, 15).frequencies_hz / CONVERGED - 1)
        rows.append(
            {
                "divisions": n,
                "dofs": units.n_dofs,
                "err5_pct": 100 * error[:5].max(),
                "err10_pct": 100 * error[:10].max(),
                "err15_pct": 100 * error.max(),
                "ms_10_modes": 1e3 * best_time(partial(solve_uncached, laminate, mesh, 10)),
            }
        )
    return rows


def sensitivity_overhead(divisions: int) -> dict:
    """Time of one 10-mode solve, and of the full 12-parameter sensitivity matrix."""
    spec = paper_spec()
    model = SpecimenModel(spec.specimen, ModelOptions(modes=10, divisions=divisions))
    parameters = spec.specimen.material_parameters()
    laminate = spec.specimen.laminate("brass_top")
    solve = best_time(lambda: solve_uncached(laminate, model.mesh, 10))

    def solve_and_sensitivities():
        solution = solve_uncached(laminate, model.mesh, 10)
        solution.derivatives(parameters)

    both = best_time(solve_and_sensitivities)
    solution = solve_uncached(laminate, model.mesh, 10)

    def sensitivities_alone():
        ModalEnergies.of(solution.units, solution.modes)
        solution.derivatives(parameters)

    alone = best_time(sensitivities_alone)
    return {
        "parameters": len(parameters),
        "solve_ms": 1e3 * solve,
        "with_sensitivities_ms": 1e3 * both,
        "sensitivities_ms": 1e3 * alone,
        "ratio": (solve + alone) / solve,
    }


def main() -> None:
    print("== physics core: accuracy against time (paper plate, original configuration) ==")
    print(
        f"{'div':>4s} {'dofs':>6s} {'err 1-5 %':>10s} {'err 1-10 %':>11s} {'err 1-15 %':>11s} "
        f"{'10 modes ms':>12s}"
    )
    rows = accuracy_against_time()
    for r in rows:
        print(
            f"{r['divisions']:>4d} {r['dofs']:>6d} {r['err5_pct']:>10.4f} {r['err10_pct']:>11.4f} "
            f"{r['err15_pct']:>11.4f} {r['ms_10_modes']:>12.1f}"
        )
    fit = next(r for r in rows if r["err10_pct"] <= 0.05)
    print(
        f"one solve, 10 modes within 0.05 %: {fit['divisions']} x {fit['divisions']} mesh, "
        f"{fit['ms_10_modes']:.1f} ms (target <= 30 ms)"
    )
    s = sensitivity_overhead(fit["divisions"])
    print(
        f"{s['parameters']}-parameter sensitivity matrix (bonded configuration): solve {s['solve_ms']:.1f} "
        "ms, "
        f"sensitivities alone {s['sensitivities_ms']:.2f} ms, ratio {s['ratio']:.2f}x "
        "(target <= 1.3x; finite differences: 13x)"
    )


if __name__ == "__main__":
    main()
