"""Diagnosis benchmarks: ``diagnose`` against one baseline ``fit`` of the same data, in
the same run, with every registered effect a candidate (target: at most 10x the fit), with
worker processes as the command line uses them.  Cases: the bundled example (nothing
missing: the baseline is at the noise level), a hidden 3 g sensor on the paper's plate,
and the thick laminate of the 3-D reference (178 s before the forward
selection).  Solutions are cached by content, so the cache is cleared before each timed
call."""

import time

from fem.model import solve_laminate
from fem.solver.attachments import PointMass
from fem.spec import load_spec
from identify.diagnosis.diagnose import diagnose
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
from identify.fitting.driver import fit
from identify.measurements import load_measurements
from identify.recordings.synthetic import synthetic_measurements
from studies import hidden_effect
from studies.common import start_model, true_model


def timed(function) -> tuple[float, object]:
    solve_laminate.cache_clear()
    t0 = time.perf_counter()
    result = function()
    return time.perf_counter() - t0, result


def compare_times(name: str, model, data) -> None:
    fitted, _ = timed(lambda: fit(model, data))
    seconds, d = timed(lambda: diagnose(model, data, workers=None))
    chosen = " + ".join(c.kind for c in d.selected) or (
        "nothing (at the noise level)" if d.at_noise_level else "nothing"
    )
    print(
        f"{name}: fit {fitted:.2f} s, diagnose {seconds:.2f} s = {seconds / fitted:.1f}x the fit (target <= "
        "10x); "
        f"selected {chosen}"
    )


def main() -> None:
    print("== diagnosis: forward selection over every registered effect, against one baseline fit ==")
    model = load_spec(COATED_PLATE)
    compare_times("bundled example", model, load_measurements(COATED_PLATE_MEASURED, model))
    truth = true_model().with_attachments([PointMass(3e-3, 0.125, 0.110)]).with_options(modes=8)
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=8, labels="close")
    compare_times("hidden 3 g sensor, paper plate, 3 x 8 modes", start_model().with_options(modes=8), data)
    compare_times(
        "thick laminate, 3-D reference, 3 x 10 modes",
        hidden_effect.reference_start(),
        hidden_effect.reference_measurements(),
    )


if __name__ == "__main__":
    main()
