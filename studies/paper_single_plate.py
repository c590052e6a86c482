"""Paper section 2.2 (Fig. 3, Table 5, Fig. 10a): one plate, 15 frequencies, 12 unknowns.
The frequencies can be fitted exactly, the layer properties cannot be found: the
sensitivity matrix is singular (condition number above 1e7; paper 6.76e9).

    python -m studies.paper_single_plate [--out DIR]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from identify.engine.result import FitResult
from identify.engine.updating import FitOptions
from identify.fitting.driver import fit
from identify.recordings.synthetic import synthetic_measurements
from identify.reporting.plots import plot_convergence
from identify.reporting.report import write_report

from .common import (
    dependency_plot,
    parse_args,
    report_folder,
    start_model,
    true_model,
    write_text,
)

ENTRIES = {"11": (0, 0), "22": (1, 1), "12": (0, 1), "66": (2, 2)}


@dataclass(frozen=True)
class SinglePlate:
    condition_number: float
    fit: FitResult
    max_parameter_error: float  # relative, identified vs Table 1
    stiffness_difference_pct: dict  # (true - identified) / true, paper Table 5
    dependency_residual: float  # Fig. 10a: 0 = column 1 is a combination of the others


def run(out=None, iterations: int = 15) -> SinglePlate:
    truth = true_model()
    one = truth.with_configurations(truth.specimen.configurations[:1])
    start = start_model()
    start = start.with_configurations(start.specimen.configurations[:1])
    data = synthetic_measurements(one, modes=15, labels="close")
    result = fit(start, data, options=FitOptions(max_iterations=iterations))
    parameters = list(result.parameters)
    S = one.with_options(modes=15).sensitivity_matrix(parameters)
    cond = float(np.linalg.cond(S))
    errors = [abs(v / truth.value(p) - 1) for p, v in zip(parameters, result.values)]
    m_true = one.specimen.laminate("original").matrices()
    m_fit = result.specimen.laminate("original").matrices()
    diff = {f"{x}{k}": 100 * (1 - m_fit[x][ij] / m_true[x][ij]) for x in "ABD" for k, ij in ENTRIES.items()}
    folder = report_folder("paper_single_plate", out)
    write_report(result, folder / "fit")
    plot_convergence(result, folder / "fig3_convergence.png")
    residual = dependency_plot(S, folder / "fig10a_dependency.png", "one plate, 15 modes (paper Fig. 10a)")
    lines = [
        "One plate, 15 frequencies, 12 unknown layer properties (paper section 2.2)",
        "",
        f"condition number of the normalised sensitivity matrix: {cond:.3g} (paper 6.76e9; singular > 1e7)",
        f"fit status: {result.message}",
        f"RMS frequency error after {result.iterations} iterations: {100 * result.rms_rel_error:.2e} %",
        f"largest layer-property error: {100 * max(errors):.1f} %",
        "",
        "stiffness differences (true - identified) / true [%] (paper Table 5: D within 0.4 %, "
        "A tens of percent, B hundreds)",
    ]
    lines += [f"  {k:4s} {v:10.3f}" for k, v in diff.items()]
    lines += [
        "",
        f"Fig. 10a: column 1 against the best combination of the other 11: relative misfit {residual:.2e}",
    ]
    write_text(folder / "summary.txt", "\n".join(lines) + "\n")
    return SinglePlate(cond, result, max(errors), diff, residual)


if __name__ == "__main__":
    run(parse_args("paper_single_plate", __doc__).out)
    print("report written to reports/paper_single_plate (or --out)")
