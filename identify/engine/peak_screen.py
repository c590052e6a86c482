"""Screening a peak list's pairing before any refit: which layer moduli lay the model's
spectrum over the most peaks.

A handbook start can be 10-20 % off in each modulus of an orthotropic plate; the modes
that E1 governs then move against those E2 or G12 govern, and no single scale factor
(``matching.align``) lays the spectrum over the peaks: on a long spruce plate the scaled
start paired 11 of 30 peaks wrongly and the fit stopped there.  The screen searches the
moduli instead, on a Rayleigh-Ritz model of each configuration
(``fem.solver.reduced_basis.Reanalysis``: the start's modes, 1.5 x as many as the fit
solves; 0.01-0.04 % from the full solve over that range, a millisecond an evaluation):

1. ``SAMPLES`` points of a Sobol sequence in a box around the start (moduli x 1/2..2,
   Poisson's ratios +- 0.2, inside their bounds), plus the start itself; each scored by
   the matching cost of every configuration's peaks at ``SCREEN_TOLERANCE``
   (``matching.match``: a peak left out costs GATE^2);
2. the ``POLISHED`` best, and the scaled start, are polished: least squares on the
   matched peaks, matched again, at the tolerances ``POLISH_TOLERANCES``;
3. the best polished point (the polished scaled start among them, so the screen's start
   is never worse than it on the screen's criterion) is solved in full and matched there:
   the fit starts from it with that matching.  Polishing matters as much as the search:
   from a scaled start that already paired every peak rightly, the fit's narrowing
   re-matches (1 %, then 0.3 %) dropped true peaks while the model was still 1-2 % off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import qmc

from fem.errors import SpecError
from fem.model import MAX_SOLVED_MODES, SpecimenModel
from fem.solver.reduced_basis import Reanalysis
from fem.specimen import Parameter

from ..measurements import Measurements
from . import ties
from .matching import START_TOLERANCE, Match, match, matched_count
from .parameters import ParameterSpace

#: Basis modes per model mode of the screen's reduced model (Ritz error 0.01-0.04 % at
#: 1.5 on a long spruce plate over the search box; 0.07 % at 1.0).
BASIS_PER_MODE = 1.5
#: Tolerance of the screen's matching (relative): well above the Ritz error and the
#: scatter, below a long plate's mode spacing (3 % at 30 peaks in band).
SCREEN_TOLERANCE = 0.01
#: The box searched: moduli from 1/MODULUS_RANGE to MODULUS_RANGE x the start, Poisson's
#: ratios within NU_RANGE of it (a handbook start is rarely off by more).
MODULUS_RANGE = 2.0
NU_RANGE = 0.2
#: Sobol points scored (a power of two), and the best ones polished.
SAMPLES = 1024
POLISHED = 6
#: Matching tolerances of the polishing rounds: the alignment's (a start off in the
#: spectrum's shape by a few %), then the screen's.
POLISH_TOLERANCES = (START_TOLERANCE, SCREEN_TOLERANCE, SCREEN_TOLERANCE)
#: Most screened parameters: ``SAMPLES`` points space a d-dimensional box at about
#: SAMPLES^(-1/d) of its side, a fifth at d = 4 and a third at 6; beyond that the samples
#: say little and the scaled start is kept (a laminate's 12 moduli, e.g.).
MAX_DIMENSIONS = 6
#: Parameter kinds the screen moves: those that set the laminate's stiffness alone.
SCREENED_KINDS = ("E1", "E2", "G12", "G13", "G23", "nu12")


@dataclass(frozen=True)
class Screened:
    """The screen's best start: the parameter values [SI] and each configuration's
    matching there (full solve, ``SCREEN_TOLERANCE``), its total cost, that of the scaled
    start polished the same way, and how many points were scored."""

    values: dict[Parameter, float]
    matches: dict[str, Match]
    cost: float
    scaled_cost: float
    scored: int


def ritz_basis(solver: SpecimenModel) -> SpecimenModel:
    """``solver`` solving ``BASIS_PER_MODE`` times its modes (at most the solver's cap): the
    model whose modes are a screen's Rayleigh-Ritz basis."""
    return solver.with_options(modes=min(math.ceil(BASIS_PER_MODE * solver.options.modes), MAX_SOLVED_MODES))


class _Search:
    """The reduced models of every configuration and the matching cost of a point z of
    the screened parameters (the others held at the start)."""

    def __init__(self, solver: SpecimenModel, peaks: Measurements, parameters: list[Parameter]):
        self.solver, self.peaks = solver, peaks
        self.space = ParameterSpace.of(parameters, solver.specimen)
        self.start = np.array([solver.value(p) for p in parameters], dtype=float)
        self.moved = np.array([p.kind in SCREENED_KINDS for p in parameters])
        self.z_start = self.space.to_z(self.start)[self.moved]
        basis = ritz_basis(solver)
        # Single-layer theories only (a layerwise peak list keeps the scaled start).
        self.reduced = (
            {name: Reanalysis.of(basis, name) for name in peaks.configurations}
            if basis.options.theory != "layerwise"
            else None
        )
        self.n_modes = solver.options.modes
        self.rows = {name: peaks.of(name) for name in peaks.configurations}

    @property
    def usable(self) -> bool:
        return self.reduced is not None

    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds in z of the screened parameters: the search box within the space's bounds."""
        log = self.space.is_log[self.moved]
        half = np.where(log, np.log(MODULUS_RANGE), NU_RANGE)
        low, high = (b[self.moved] for b in self.space.z_bounds())
        return np.maximum(self.z_start - half, low), np.minimum(self.z_start + half, high)

    def values(self, z: np.ndarray) -> np.ndarray:
        full = self.space.to_z(self.start)
        full[self.moved] = z
        return self.space.to_values(full)

    def spectra(self, z: np.ndarray) -> dict[str, np.ndarray] | None:
        """The Ritz frequencies of every configuration at z; None where z is inadmissible."""
        try:
            specimen = ties.apply(self.solver.specimen, self.space.parameters, self.values(z))
        except SpecError:
            return None
        return {name: red.frequencies_hz(specimen)[: self.n_modes] for name, red in self.reduced.items()}

    def matches(
        self, spectra: dict[str, np.ndarray], tolerance: float = SCREEN_TOLERANCE
    ) -> dict[str, Match]:
        out = {}
        for name, rows in self.rows.items():
            std = rows["std_hz"].to_numpy() if self.peaks.has_std else None
            out[name] = match(rows["frequency_hz"].to_numpy(), std, spectra[name], tolerance)
        return out

    def cost(self, z: np.ndarray) -> float:
        spectra = self.spectra(z)
        return np.inf if spectra is None else sum(m.cost for m in self.matches(spectra).values())

    def polish(self, z: np.ndarray) -> np.ndarray:
        """Least squares of the matched peaks' log frequency errors (in units of
        ``SCREEN_TOLERANCE``) on the reduced model, matched again before each round, with
        the start as a weak prior (the search box's half-width as its std): the
        directions the peaks determine move freely, those they do not (a weak layer of
        a laminate) stay at the start instead of wandering."""
        low, high = self.box()
        half = (high - low) / 2
        for tolerance in POLISH_TOLERANCES:
            spectra = self.spectra(z)
            if spectra is None:
                return z
            pairs = self.matches(spectra, tolerance)
            if matched_count(pairs) <= len(z):
                return z

            def residuals(trial, pairs=pairs):
                spectra = self.spectra(trial)
                if spectra is None:
                    return np.full(len(trial) + matched_count(pairs), 1e3)
                # the start as a prior: a direction no peak sets stays there
                out = [(trial - self.z_start) / half]
                for name, m in pairs.items():
                    f = self.rows[name]["frequency_hz"].to_numpy()[m.matched]
                    out.append(np.log(spectra[name][m.modes[m.matched]] / f) / SCREEN_TOLERANCE)
                return np.concatenate(out)

            z = least_squares(
                residuals,
                np.clip(z, low, high),
                bounds=(low, high),
                diff_step=1e-4,
                max_nfev=20 * (len(z) + 1),
            ).x
        return z


def screen(
    solver: SpecimenModel, peaks: Measurements, parameters: list[Parameter], scaled: SpecimenModel
) -> Screened | None:
    """The start of a peak-list fit by the screen (module docstring), from the ``solver``
    model (the fit's mesh and modes) with the ``scaled`` start polished as one more
    candidate; None where the screen does not run (no stiffness parameter, more than
    ``MAX_DIMENSIONS`` of them, a layerwise model, peaks with labels or measured shapes:
    they already pin the pairing)."""
    if peaks.pinned.any():
        return None
    screened = sum(p.kind in SCREENED_KINDS for p in parameters)
    if not 0 < screened <= MAX_DIMENSIONS:
        return None
    search = _Search(solver, peaks, parameters)
    if not search.usable:
        return None
    low, high = search.box()
    sobol = qmc.Sobol(len(low), scramble=True, seed=0).random(SAMPLES)
    points = [search.z_start] + list(qmc.scale(sobol, low, high))
    costs = np.array([search.cost(z) for z in points])
    best = [search.polish(points[i]) for i in np.argsort(costs)[:POLISHED] if np.isfinite(costs[i])]
    z_scaled = search.space.to_z(np.array([scaled.value(p) for p in parameters]))[search.moved]
    reference = search.polish(np.clip(z_scaled, low, high))
    final = min(best + [reference], key=search.cost)
    values = dict(zip(parameters, search.values(final)))
    model = solver.with_values(values)
    matches = search.matches({name: model.solve(name).frequencies_hz for name in peaks.configurations})
    return Screened(
        values, matches, sum(m.cost for m in matches.values()), search.cost(reference), len(points)
    )


__all__ = ["BASIS_PER_MODE", "SCREEN_TOLERANCE", "Screened", "ritz_basis", "screen"]
