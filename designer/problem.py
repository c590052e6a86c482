"""A planning problem: the model at its nominal properties and the design space;
configurations solved once each, cached by content, possibly in parallel."""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from fem.design_space import DesignSpace, parse_design
from fem.errors import DesignError
from fem.model import THEORY_OPTIONS, ModelOptions, SpecimenModel, one_blas_thread, solve_laminate
from fem.solver.mesh import PlateMesh
from fem.solver.sensitivity import normalised
from fem.specimen import Configuration, Parameter, Specimen

from .parallel import chunked, run_chunks
from .progress import Progress
from .scores.prior import Prior

#: Solved configurations kept in this process (a few kB each: no mode shapes).
CACHE_SIZE = 8192
_CACHE: OrderedDict = OrderedDict()
#: Work split into at most this many tasks per pool (load balance against task overhead).
MAX_TASKS = 64


@dataclass(frozen=True)
class Solved:
    """One configuration at one parameter point (the nominal one unless scored over a
    prior): the elastic frequencies [Hz] of the modes solved, their labels (empty at a
    prior sample: nothing reads them there, and they cost a sixth of a solve), and the
    relative sensitivities (p/f) df/dp (modes x parameters, paper eq. 13)."""

    configuration: Configuration
    frequencies_hz: np.ndarray
    labels: tuple[str, ...]
    sensitivities: np.ndarray


def content_key(specimen: Specimen, configuration: Configuration) -> tuple:
    """What the physics of a configuration depends on (layer labels do not matter)."""
    return tuple((l.material, l.thickness, l.angle) for l in specimen.laminate(configuration).layers)


def _solution(
    specimen: Specimen,
    options: ModelOptions,
    mesh: PlateMesh,
    n_modes: int,
    configuration: Configuration,
    attachments: tuple = (),
):
    """The model ``SpecimenModel`` solves (effects, attachments, plate theory), cached by
    content."""
    theory = {key: getattr(options, key) for key in THEORY_OPTIONS if hasattr(options, key)}
    return solve_laminate(
        specimen.laminate(configuration),
        mesh,
        n_modes,
        transverse_shear=options.transverse_shear,
        rotary_inertia=options.rotary_inertia,
        attachments=specimen.attachments + tuple(attachments),
        **theory,
    )


@one_blas_thread
def solve_pairs(
    options: ModelOptions,
    mesh: PlateMesh,
    n_modes: int,
    parameters: tuple[Parameter, ...],
    pairs: list[tuple[Specimen, Configuration, bool]],
) -> list[tuple]:
    """(frequencies, labels, relative sensitivities) of each (specimen, configuration,
    with labels): the task run by workers (a module-level function, so it pickles to
    processes and Dask workers); the specimens may differ in their material values
    (prior samples); labels are None where not asked for.  Parallelism comes from
    processes: each solve, its assembly and its sensitivities run BLAS on one thread (on
    busy cores a second BLAS thread made them 3x slower)."""
    out = []
    for specimen, configuration, labelled in pairs:
        values = np.array([specimen.value(p) for p in parameters])
        solution = _solution(specimen, options, mesh, n_modes, configuration)
        f = solution.frequencies_hz
        out.append(
            (
                f,
                solution.labels if labelled else None,
                normalised(f, solution.derivatives(list(parameters)), values),
            )
        )
    return out


@dataclass(frozen=True)
class Problem:
    """What test sets are scored against: the ``model`` at its nominal (start)
    properties (its options: modes measured per plate, mesh, effects) and the design
    ``space``.  ``store``: where solved configurations are kept on disk too (a
    ``store.SolveStore``; None: only in this process's memory), so an interrupted sweep
    or search resumes and a repeated one is fast; every problem derived from this one
    (other values, prior samples) shares it."""

    model: SpecimenModel
    space: DesignSpace
    store: object = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        if not self.specimen.identified_materials:
            raise DesignError(
                "spec: no material has identify = true, so there is nothing to identify and no "
                "test to plan; set identify = true on the layer materials to find"
            )
        # the mass and thickness limits [design] leaves open: the defaults relative to the specimen
        limits = self.space.limits.with_defaults(self.specimen_mass, self.specimen_thickness)
        if limits != self.space.limits:
            object.__setattr__(self, "space", replace(self.space, limits=limits))

    @property
    def specimen_mass(self) -> float:
        """Mass [kg] of the original plate."""
        return self.area * sum(layer.material.density * layer.thickness for layer in self.specimen.layers)

    @property
    def specimen_thickness(self) -> float:
        """Thickness [m] of the original plate."""
        return sum(layer.thickness for layer in self.specimen.layers)

    @classmethod
    def of(
        cls,
        model: SpecimenModel | Problem,
        modes: int | None = None,
        criterion: str | None = None,
        prior_range: float | None = None,
        store=None,
    ) -> Problem:
        """The planning problem of a model (its ``[design]`` table, or the defaults);
        ``modes`` overrides ``[model] modes``, ``criterion`` the design's criterion,
        ``prior_range`` its ``prior_range_rel``, ``store`` the disk store of solves."""
        if isinstance(model, Problem):
            problem = model if store is None else replace(model, store=store)
        else:
            space = model.design or parse_design(
                {}, model.defined_materials, len(model.specimen.identified_materials)
            )
            problem = cls(model, space, store)
        if modes is not None:
            problem = problem.with_options(modes=modes)
        if criterion is not None:
            problem = replace(problem, space=replace(problem.space, criterion=criterion))
        if prior_range is not None:
            if (
                isinstance(prior_range, bool)
                or not isinstance(prior_range, (int, float))
                or not 0.0 <= prior_range <= 0.9
            ):
                raise DesignError(
                    f"--prior-range {prior_range!r}: need 0..0.9, relative (e.g. 0.3 for +-30 % of the "
                    "identified properties; 0 for the nominal values only)"
                )
            problem = replace(problem, space=replace(problem.space, prior_range=float(prior_range)))
        return problem

    @property
    def specimen(self) -> Specimen:
        return self.model.specimen

    @property
    def options(self) -> ModelOptions:
        return self.model.options

    def with_options(self, **changes) -> Problem:
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

    def solve(
        self,
        configurations,
        pool=None,
        progress: Progress | None = None,
        label: str = "solving configurations",
    ) -> list[Solved]:
        """Each configuration solved once (cached by content in this process); the rest
        on ``pool`` (a ``concurrent.futures`` executor) when given."""
        return solve_points([self], configurations, pool, progress, label)[0]

    @property
    def solved_modes(self) -> int:
        """Modes solved per configuration: the measured ones and, with a separation limit,
        one more (to judge the last measured mode's neighbour)."""
        return self.modes + self.space.limits.extra_modes()

    def solution(self, configuration: Configuration, attachments: tuple = ()):
        """The full solution (mode shapes included) of a configuration at the nominal
        values: the very solve ``solve`` ran (``fem.model.solve_laminate`` keeps it in
        this process), so it costs nothing after ``solve`` here.  ``attachments``: more
        point masses or springs than the spec's (e.g. a sensor), a new solve."""
        return _solution(
            self.specimen,
            self.options,
            self.mesh,
            self.solved_modes,
            configuration_at(self, configuration),
            attachments,
        )

    def at(self, values: dict[Parameter, float]) -> Problem:
        """The same problem with the identified parameters at other values (SI)."""
        return replace(self, model=self.model.with_values(values))

    @cached_property
    def prior(self):
        """The prior parameter points robust scores use (``prior.Prior``), or
        None when ``[design] prior_range_rel`` is 0 (scores at the nominal values only)."""
        return Prior.of(self) if self.space.prior_range > 0 else None

    def points(self) -> list[Problem]:
        """The problems a design is scored at: the nominal one, then each prior sample."""
        return [self] if self.prior is None else list(self.prior.problems)

    def measured(self, solved: Solved) -> np.ndarray:
        """Which of the first ``modes`` modes the lab measures (band, separation)."""
        return self.space.limits.measured(solved.frequencies_hz, self.modes)

    def rows(self, solved: Solved) -> np.ndarray:
        """The measured rows of a configuration's relative sensitivity matrix."""
        return solved.sensitivities[: self.modes][self.measured(solved)]


def configuration_at(problem: Problem, configuration: Configuration) -> Configuration:
    """``configuration`` with any added layer of an identified material at ``problem``'s
    values (added plates are known materials, so this rarely changes anything)."""
    materials = problem.specimen.materials

    def at(layers):
        return tuple(
            replace(l, material=materials[l.material.name])
            if l.material.identify and l.material.name in materials
            else l
            for l in layers
        )

    if not any(l.material.identify for l in configuration.bottom + configuration.top):
        return configuration
    return replace(configuration, bottom=at(configuration.bottom), top=at(configuration.top))


def solve_points(
    problems: list[Problem],
    configurations,
    pool=None,
    progress: Progress | None = None,
    label: str = "solving configurations",
) -> list[list[Solved]]:
    """The configurations solved at every problem's parameter values (problems that share
    the specimen's geometry, model options and design: the nominal one and its prior
    samples), in one batch: cached by content in this process, the rest on ``pool``.
    Returns one list of ``Solved`` per problem; only the first problem's have labels."""
    first = problems[0]
    n_solve = first.solved_modes
    model = (first.mesh, replace(first.options, modes=n_solve), first.specimen.attachments, first.parameters)
    configurations = list(configurations)
    at = [[configuration_at(p, c) for c in configurations] for p in problems]
    keys = [[(content_key(p.specimen, c),) + model for c in cs] for p, cs in zip(problems, at)]
    labelled = set(keys[0])
    found = {
        key: _CACHE[key]
        for row in keys
        for key in row
        if key in _CACHE and (_CACHE[key][1] is not None or key not in labelled)
    }
    store = first.store
    if store is not None:
        for row in keys:
            for key in row:
                if key not in found:
                    hit = store.get(key)
                    if hit is not None and (hit[1] is not None or key not in labelled):
                        found[key] = hit
    todo = {}
    for p, row, cs in zip(problems, keys, at):
        for key, configuration in zip(row, cs):
            if key not in found:
                todo.setdefault(key, (p.specimen, configuration, key in labelled))
    if todo:
        pieces = min(len(todo), MAX_TASKS) if pool is not None or store is not None else 1
        chunks = chunked(list(todo.items()), pieces)

        def keep(i, results):  # on disk as each chunk completes: an interruption loses only work in progress
            for (key, _), result in zip(chunks[i], results):
                store.put(key, result)

        results = run_chunks(
            solve_pairs,
            [[task for _, task in chunk] for chunk in chunks],
            first.options,
            first.mesh,
            n_solve,
            first.parameters,
            pool=pool,
            progress=progress,
            label=label,
            done=keep if store is not None else None,
        )
        found.update(zip(todo, results))
    for key, result in found.items():
        _CACHE[key] = result
        _CACHE.move_to_end(key)
    while len(_CACHE) > CACHE_SIZE:
        _CACHE.popitem(last=False)
    return [
        [Solved(c, found[k][0], tuple(found[k][1] or ()), found[k][2]) for k, c in zip(row, configurations)]
        for row in keys
    ]


def unmeasurable(problem: Problem, solved: Solved) -> DesignError:
    """The error for a configuration of which no mode would be measured."""
    f = solved.frequencies_hz[: problem.modes]
    limits = problem.space.limits
    modes_lie = f"its {f.size} modes lie at {f.min():.4g}..{f.max():.4g} Hz"
    where = f"configuration '{solved.configuration.name}' ({modes_lie})"
    if limits.band is not None and not np.any((f >= limits.band[0]) & (f <= limits.band[1])):
        return DesignError(
            f"[design].band_hz = [{limits.band[0]:g}, {limits.band[1]:g}] excludes every mode of "
            f"{where}; widen the band or change [model] modes"
        )
    return DesignError(
        f"[design].min_separation_rel = {limits.min_separation:g} (with band_hz) leaves no mode of "
        f"{where} to measure; lower min_separation_rel or widen the band"
    )
