"""Damping benchmark: the layers' loss factors cost < 10 % of the stiffness fit they
follow (the study's case: the paper's plate, 3 configurations x 10 modes, seven loss
factors).  The damping step reuses the fit's solves at the identified stiffness (cached
by content), as ``fit`` runs it; the complex eigenproblem a large loss factor adds is
timed beside it."""

import time

from fem.model import solve_laminate
from fem.solver.complex_modes import complex_loss_factors
from identify.fitting.damping import identify_damping
from identify.fitting.driver import fit_layers
from studies import damping as study

from .common import best_time


def main() -> None:
    print("== damping: paper plate with damping coatings, 3 configurations x 10 modes, 7 loss factors ==")
    data = study.simulate(seed=3)
    solve_laminate.cache_clear()
    t0 = time.perf_counter()
    result = fit_layers(study.start(), data)
    stiffness = time.perf_counter() - t0
    damping = best_time(
        lambda: identify_damping(result.model, result.measurements, result.pairings), repeat=5
    )
    print(
        f"stiffness fit {stiffness:.2f} s; damping step {1e3 * damping:.1f} ms = "
        f"{100 * damping / stiffness:.2f} % "
        "of it (target < 10 %)"
    )
    complex_solve = best_time(lambda: complex_loss_factors(result.model, "brass_top"), repeat=3)
    print(
        f"complex eigenproblem of one configuration (10 modes): {complex_solve:.2f} s (run only when a "
        "mode's "
        "energy-weighted loss factor exceeds 0.05)"
    )


if __name__ == "__main__":
    main()
