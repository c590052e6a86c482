"""A planning problem: the model at its nominal properties and the design space;
configurations solved once each, cached by content, possibly in parallel."""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from fem.design_space import DesignSpace, parse_design
from fem.errors import DesignError
from fem.mesh import PlateMesh
from fem.model import ModelOptions, SpecimenModel, solve_laminate
from fem.sensitivity import normalised
from fem.specimen import Configuration, Parameter, Specimen

from .parallel import chunked, run_chunks
from .progress import Progress

#: Solved configurations kept in this process (a few kB each: no mode shapes).
CACHE_SIZE = 8192
_CACHE: OrderedDict = OrderedDict()
#: Work split into at most this many tasks per pool (load balance against task overhead).
MAX_TASKS = 64


@dataclass(frozen=True)
class Solved:
    """One configuration at the nominal properties: the elastic frequencies [Hz] of the
    modes solved, their labels, and the relative sensitivities (p/f) df/dp
    (modes x parameters, paper eq. 13)."""

    configuration: Configuration
    frequencies_hz: np.ndarray
    labels: tuple[str, ...]
    sensitivities: np.ndarray


def content_key(specimen: Specimen, configuration: Configuration) -> tuple:
    """What the physics of a configuration depends on (layer labels do not matter)."""
    return tuple((l.material, l.thickness, l.angle) for l in specimen.laminate(configuration).layers)


def solve_chunk(specimen: Specimen, options: ModelOptions, mesh: PlateMesh, n_modes: int,
                parameters: tuple[Parameter, ...], configurations: list[Configuration]) -> list[tuple]:
    """(frequencies, labels, relative sensitivities) of each configuration: the task run
    by workers (a module-level function, so it pickles to processes and Dask workers).
    Parallelism comes from processes: each solve runs BLAS on one thread (``fem.model``)."""
    values = np.array([specimen.value(p) for p in parameters])
    out = []
    for configuration in configurations:
        solution = solve_laminate(  # the model SpecimenModel solves (effects, attachments)
            specimen.laminate(configuration), mesh, n_modes, transverse_shear=options.transverse_shear,
            rotary_inertia=options.rotary_inertia, attachments=specimen.attachments)
        f = solution.frequencies_hz
        out.append((f, solution.labels, normalised(f, solution.derivatives(list(parameters)), values)))
    return out


@dataclass(frozen=True)
class Problem:
    """What test sets are scored against: the ``model`` at its nominal (start)
    properties (its options: modes measured per plate, mesh, effects) and the design
    ``space``."""

    model: SpecimenModel
    space: DesignSpace

    def __post_init__(self):
        if not self.specimen.identified_materials:
            raise DesignError("spec: no material has identify = true, so there is nothing to identify and no "
                              "test to plan; set identify = true on the layer materials to find")

    @classmethod
    def of(cls, model: "SpecimenModel | Problem", modes: int | None = None, criterion: str | None = None) -> "Problem":
        """The planning problem of a model (its ``[design]`` table, or the defaults);
        ``modes`` overrides ``[model] modes``, ``criterion`` the design's criterion."""
        if isinstance(model, Problem):
            problem = model
        else:
            space = model.design or parse_design({}, model.defined_materials, len(model.specimen.identified_materials))
            problem = cls(model, space)
        if modes is not None:
            problem = problem.with_options(modes=modes)
        if criterion is not None:
            problem = replace(problem, space=replace(problem.space, criterion=criterion))
        return problem

    @property
    def specimen(self) -> Specimen:
        return self.model.specimen

    @property
    def options(self) -> ModelOptions:
        return self.model.options

    def with_options(self, **changes) -> "Problem":
        return replace(self, model=self.model.with_options(**changes))

    @cached_property
    def parameters(self) -> tuple[Parameter, ...]:
        """E1, E2, G12, nu12 of every identified material, material by material."""
        return tuple(self.specimen.material_parameters())

    @cached_property
    def values(self) -> np.ndarray:
        """Nominal values of the parameters (SI)."""
        return np.array([self.specimen.value(p) for p in self.parameters])

    @cached_property
    def mesh(self) -> PlateMesh:
        return self.options.mesh(self.specimen)

    @property
    def modes(self) -> int:
        """Modes measured per plate."""
        return self.options.modes

    @property
    def area(self) -> float:
        return self.specimen.length * self.specimen.width

    def solve(self, configurations, pool=None, progress: Progress | None = None,
              label: str = "solving configurations") -> list[Solved]:
        """Each configuration solved once (cached by content in this process); the rest
        on ``pool`` (a ``concurrent.futures`` executor) when given."""
        n_solve = self.modes + self.space.limits.extra_modes()
        model = (self.mesh, replace(self.options, modes=n_solve), self.specimen.attachments, self.parameters)
        keys = [(content_key(self.specimen, c),) + model for c in configurations]
        found = {key: _CACHE[key] for key in keys if key in _CACHE}
        todo = {}
        for key, configuration in zip(keys, configurations):
            if key not in found:
                todo.setdefault(key, configuration)
        if todo:
            pieces = 1 if pool is None else min(len(todo), MAX_TASKS)
            results = run_chunks(solve_chunk, chunked(list(todo.values()), pieces), self.specimen, self.options,
                                 self.mesh, n_solve, self.parameters, pool=pool, progress=progress, label=label)
            found.update(zip(todo, results))
        for key, result in found.items():
            _CACHE[key] = result
            _CACHE.move_to_end(key)
        while len(_CACHE) > CACHE_SIZE:
            _CACHE.popitem(last=False)
        return [Solved(c, found[k][0], tuple(found[k][1]), found[k][2]) for k, c in zip(keys, configurations)]

    def measured(self, solved: Solved) -> np.ndarray:
        """Which of the first ``modes`` modes the lab measures (band, separation)."""
        return self.space.limits.measured(solved.frequencies_hz, self.modes)

    def rows(self, solved: Solved) -> np.ndarray:
        """The measured rows of a configuration's relative sensitivity matrix."""
        return solved.sensitivities[: self.modes][self.measured(solved)]


def unmeasurable(problem: Problem, solved: Solved) -> DesignError:
    """The error for a configuration of which no mode would be measured."""
    f = solved.frequencies_hz[: problem.modes]
    limits = problem.space.limits
    where = f"configuration '{solved.configuration.name}' (its {f.size} modes lie at {f.min():.4g}..{f.max():.4g} Hz)"
    if limits.band is not None and not np.any((f >= limits.band[0]) & (f <= limits.band[1])):
        return DesignError(f"[design].band_hz = [{limits.band[0]:g}, {limits.band[1]:g}] excludes every mode of "
                           f"{where}; widen the band or change [model] modes")
    return DesignError(f"[design].min_separation_rel = {limits.min_separation:g} (with band_hz) leaves no mode of "
                       f"{where} to measure; lower min_separation_rel or widen the band")
