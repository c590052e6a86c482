"""Virtual experiments: measurements computed by the model itself (paper section 2.2)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from fem.model import SpecimenModel
from fem.solver.complex_modes import complex_loss_factors
from fem.solver.damping import ratio_from_loss

from ..measurements import Measurements, parse_measurements


def synthetic_measurements(
    truth: SpecimenModel,
    modes: int = 5,
    noise_rel: float = 0.0,
    seed: int = 0,
    labels: str = "none",
    configurations: list[str] | None = None,
    damping_std_rel: float | None = None,
) -> Measurements:
    """The first ``modes`` elastic frequencies of every configuration of ``truth`` (the
    model that generates the data: its specimen, mesh and effects).

    noise_rel: relative std of Gaussian noise added (also written as ``std_hz`` when > 0).
    labels: "none", "close" (nodal-line labels of modes within 1 % of a neighbour, as a lab
    would identify close modes by their shapes) or "all".
    damping_std_rel: when given, each mode's damping ratio from the complex eigenproblem of
    the materials' loss factors (``fem.solver.complex_modes``), with Gaussian noise of this
    relative std (also written as ``damping_std`` when > 0).
    """
    solver = truth.with_options(modes=max(modes, truth.options.modes))
    specimen = truth.specimen
    rng = np.random.default_rng(seed)
    rows = []
    for c in specimen.configurations:
        if configurations is not None and c.name not in configurations:
            continue
        solution = solver.solve(c.name)
        f = solution.frequencies_hz[:modes]
        close = np.zeros(modes, dtype=bool)
        gaps = np.diff(f) / f[:-1] < 0.01
        close[:-1] |= gaps
        close[1:] |= gaps
        noisy = f * (1 + noise_rel * rng.standard_normal(modes))
        for i in range(modes):
            row = {"configuration": c.name, "mode": i + 1, "frequency_hz": noisy[i]}
            if noise_rel > 0:
                row["std_hz"] = noise_rel * f[i]
            if labels == "all" or (labels == "close" and close[i]):
                row["label"] = solution.labels[i]
            rows.append(row)
        if damping_std_rel is not None:
            zeta = ratio_from_loss(complex_loss_factors(solver, c.name)[:modes])
            noisy_zeta = zeta * (1 + damping_std_rel * rng.standard_normal(modes))
            for row, z, z_noisy in zip(rows[-modes:], zeta, noisy_zeta):
                row["damping_ratio"] = z_noisy
                if damping_std_rel > 0:
                    row["damping_std"] = damping_std_rel * z
    frame = pd.DataFrame(rows)
    if labels != "none" and "label" not in frame:
        frame["label"] = ""
    # Noise can reorder two close modes; ranks follow the measured order.
    frame = frame.sort_values(["configuration", "frequency_hz"], kind="stable")
    frame["mode"] = frame.groupby("configuration").cumcount() + 1
    return parse_measurements(frame, truth, "<synthetic>")
