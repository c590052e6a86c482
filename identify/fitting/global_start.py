"""A global stage before the local fit of the layer properties.

From handbook start values 30 % off (or a fabric's E1 = E2 guessed for a unidirectional
ply) the local Gauss-Newton fit of a thick plate can stop in a local minimum several per
cent off, where every effect's refit then starts (the 3-D carbon/glass laminate: 11.8 %
RMS with a glass G12 collapsed towards zero).  When the local fit leaves more than
``GLOBAL_FROM`` relative RMS error (20x a typical 0.05 % scatter: more than missing
effects leave on the plates of the blind study, except soft-core sandwiches, which pay
the stage anyway), ``STARTS`` further starts are screened, each with
``SCREEN_ITERATIONS`` iterations: a Latin hypercube (seeded, so the result repeats) of
every free property's factor on its start value, log-uniform within 1 / ``SPREAD`` to
``SPREAD`` (Poisson ratios within their bounds).  The lowest misfit among the local fit
and the screened starts is taken to convergence.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.stats import qmc

from fem.errors import LayerIdError
from fem.model import SpecimenModel

from ..measurements import Measurements
from ..engine.result import FitResult
from ..engine.updating import FitOptions

GLOBAL_FROM = 0.01
STARTS = 8
SCREEN_ITERATIONS = 6
SPREAD = 3.0
SEED = 0


def starts(model: SpecimenModel, parameters, n: int = STARTS, seed: int = SEED) -> list[dict]:
    """``n`` start values of ``parameters`` around the model's (Latin hypercube, log-uniform
    factors within 1/SPREAD..SPREAD, clipped to each property's bounds)."""
    unit = qmc.LatinHypercube(d=len(parameters), seed=seed).random(n)
    out = []
    for row in unit:
        values = {}
        for p, u in zip(parameters, row, strict=True):
            value = model.value(p) * math.exp((2 * u - 1) * math.log(SPREAD))
            low, high = model.specimen.materials[p.target].bound(p.kind)
            values[p] = float(np.clip(value, low + 1e-3 * (high - low) if p.kind == "nu12" else low,
                                      high - 1e-3 * (high - low) if p.kind == "nu12" else high))
        out.append(values)
    return out


def global_fit(model: SpecimenModel, measurements: Measurements, local: FitResult) -> tuple[FitResult, str]:
    """``local`` (the fit from the model's start), or the best of the screened starts taken
    to convergence when that misfits less; with a note (empty when the stage did not run
    or did not help)."""
    from .driver import fit_layers  # noqa: PLC0415 - fitting imports this module's users

    if not local.rms_rel_error > GLOBAL_FROM:
        return local, ""
    parameters = [p for p in local.parameters if p.target in model.specimen.materials]
    best = local
    for values in starts(model, parameters):
        try:
            trial = fit_layers(model.with_values(values), measurements, parameters,
                               FitOptions(max_iterations=SCREEN_ITERATIONS), explain=False, settle=False)
        except LayerIdError:
            continue
        if trial.statistics.sum_squares < best.statistics.sum_squares:
            best = trial
    if best is local:
        return local, ""
    final = fit_layers(best.model, measurements, list(best.parameters), explain=False)
    if not final.statistics.sum_squares < local.statistics.sum_squares:
        return local, ""
    note = (f"global stage: the fit from the given start stopped at {100 * local.rms_rel_error:.3g} % RMS; of "
            f"{STARTS} screened starts the best reached {100 * final.rms_rel_error:.3g} %")
    return final, note


__all__ = ["global_fit", "starts", "GLOBAL_FROM"]
