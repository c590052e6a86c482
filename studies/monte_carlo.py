"""Does the reported std mean what it says?  Many virtual experiments with 0.05 % Gaussian
scatter on the paper's three configurations: the observed scatter of the identified
properties is compared with the std the fit reports.

    python -m studies.monte_carlo [--out DIR] [--draws N]
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from identify.fitting.driver import fit
from identify.measurements import Measurements
from identify.recordings.synthetic import synthetic_measurements

from .common import report_folder, true_model, write_text

NOISE = 5e-4


@dataclass(frozen=True)
class MonteCarlo:
    names: list[str]
    observed_std: np.ndarray  # scatter of the identified values over the draws
    reported_std: np.ndarray  # mean std reported by the fits
    draws: int

    @property
    def ratio(self) -> np.ndarray:
        return self.reported_std / self.observed_std


def run(out=None, draws: int = 200, seed: int = 7) -> MonteCarlo:
    """Each draw adds fresh noise to the same true frequencies and fits from the truth
    (the start does not matter once the fit converges; it keeps the study fast)."""
    truth = true_model()
    base = synthetic_measurements(truth, modes=5, noise_rel=NOISE, seed=0, labels="close")
    exact = np.concatenate(
        [truth.with_options(modes=5).solve(c).frequencies_hz[:5] for c in base.configurations]
    )
    rng = np.random.default_rng(seed)
    values, stds = [], []
    for _ in range(draws):
        noisy = exact * (1 + NOISE * rng.standard_normal(exact.size))
        result = fit(truth, Measurements(base.table.assign(frequency_hz=noisy), "<monte carlo>"))
        if result.converged:
            values.append(result.values)
            stds.append(result.uncertainty.std)
    values, stds = np.array(values), np.array(stds)
    names = [p.name for p in truth.specimen.material_parameters()]
    outcome = MonteCarlo(names, values.std(axis=0, ddof=1), stds.mean(axis=0), len(values))
    folder = report_folder("monte_carlo", out)
    lines = [
        f"Monte Carlo: {outcome.draws} converged draws of {draws}, {100 * NOISE:.2g} % frequency scatter",
        "",
        f"  {'parameter':24s} {'observed std':>14s} {'reported std':>14s} {'ratio':>7s}",
    ]
    lines += [
        f"  {n:24s} {o:14.4g} {r:14.4g} {q:7.3f}"
        for n, o, r, q in zip(names, outcome.observed_std, outcome.reported_std, outcome.ratio)
    ]
    write_text(folder / "summary.txt", "\n".join(lines) + "\n")
    return outcome


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m studies.monte_carlo", description=__doc__)
    parser.add_argument("--out")
    parser.add_argument("--draws", type=int, default=200)
    args = parser.parse_args()
    run(args.out, args.draws)
    print("report written to reports/monte_carlo (or --out)")
