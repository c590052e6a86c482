"""Solving configurations: frequencies, modes and exact sensitivities, cached by content."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from .design_space import DesignSpace
from .elements import HermitePlate, ShearDifferencePlate
from .errors import ModelError, OptionsError
from .inputs import InputStd
from .laminates.laminate import Laminate
from .laminates.layerwise import GROUPINGS, LayerwiseLaminate, layout
from .laminates.layerwise import unit_matrices as layerwise_units
from .laminates.material import Material
from .solver.assembly import UNIT_CACHE, UnitMatrices, unit_matrices
from .solver.attachments import ATTACHMENT_PARAMETERS, PointMass, Suspension, add_attachment_data, base_square
from .solver.attachments import eigenvalue_derivative as attachment_derivative
from .solver.mesh import PlateMesh, edge_size
from .solver.modal import Modes, _first_bending_estimate, solve_modes
from .solver.mode_shapes import beam_coefficients, in_plane, label_of, nodal_line_counts
from .solver.sensitivity import (
    ModalEnergies,
    eigenvalue_derivatives,
    eigenvector_derivatives,
    frequency_derivatives,
    normalised,
)
from .solver.solve_cache import SOLVE_CACHE_BYTES, bytes_bounded_cache
from .solver.threads import one_blas_thread
from .specimen import Parameter, Specimen
from .validation import whole

#: Elements along the longer side per sqrt(modes x aspect ratio).  The element converges
#: at O(h^4); with this density the highest requested mode of the paper's plate is within
#: about 0.01 % of the converged value (benchmarks/core.py, ``accuracy_against_time``:
#: 5 modes -> 11 divisions, 0.006 %; 15 modes -> 18 divisions, 0.010 %).
DIVISIONS_PER_ROOT_MODE = 4.5
MIN_DIVISIONS = 8
#: Inertia terms (I0, I1, I2) kept by the classical (Kirchhoff) baseline: translational
#: inertia only, as in the paper's eqs. 6-8; the rotary_inertia effect adds I1 and I2.
KIRCHHOFF_INERTIA = (1.0, 0.0, 0.0)
#: Inertia terms with the rotary_inertia effect: all three (I1 couples in-plane and
#: rotational inertia in unsymmetric stacks, I2 is the rotary inertia proper).
ROTARY_INERTIA = (1.0, 1.0, 1.0)
#: Most elastic modes a model solves per configuration (a free-plate test rarely uses 20).
MAX_MODES = 60
#: Most modes a model may solve at all: the user's MAX_MODES and the few extra modes the
#: fit follows beyond the highest measured one.
MAX_SOLVED_MODES = MAX_MODES + 10
#: Mesh divisions a model accepts: one element cannot bend (frequencies are then off by
#: about 15 %), and beyond 64 a solve takes minutes for no accuracy a test can see.
DIVISIONS_RANGE = (2, 64)
#: Plate theories: "single_layer" (Kirchhoff, or FSDT with ``transverse_shear``) or
#: "layerwise" (one shear strain per group of layers, ``fem.laminates.layerwise``).
THEORIES = ("single_layer", "layerwise")
#: Model options that choose the plate theory, passed on to the solve.
THEORY_OPTIONS = ("theory", "layer_groups", "core_stretch")
#: The shear-deformable theories' accuracy against 3-D elasticity, a relative std of each
#: frequency: the RMS error of the layerwise theory at the true values (properties,
#: angles, sensor) against the CalculiX references of the blind study's development
#: halves, over all their modes (``tests/data/solid3d/theory_accuracy.json``, made by
#: ``theory_accuracy.py`` there; the references' own mesh error is 0.003-0.015 % RMS, far
#: below it).  A first-order shear model is no more accurate than the layerwise one.  It
#: enters the identified properties' std (the uncertainty budget), never a decision.
SHEAR_THEORY_STD_REL = 4.9e-4


@dataclass(frozen=True)
class ModelOptions:
    """How configurations are modelled: elastic modes kept, mesh density and the
    physical effects of the plate theory (both off = the paper's Kirchhoff model)."""

    modes: int = 5
    divisions: int | None = None  # elements along the longer side; None = the default rule
    transverse_shear: bool = False  # first-order shear deformation (ShearDifferencePlate)
    rotary_inertia: bool = False  # keep the inertia terms I1, I2
    # "layerwise": zig-zag shear per layer group (LayerwisePlate), always with transverse
    # shear and the full inertia of its displacement field (the two flags above are implied).
    theory: str = "single_layer"
    layer_groups: str = "auto"  # shear groups of the layerwise theory: "auto", "blocks" or "layers"
    core_stretch: bool = True  # layerwise: a soft core's transverse normal strain (E3 = E2 unless given)
    # Size [m] of the edge elements of a shear-deformable theory's graded mesh; None: from
    # the specimen (``edge_size_for``).  A SpecimenModel pins it when it is made, so the
    # mesh stays put while a fit or a derivative moves the layer thicknesses.
    edge_size: float | None = None
    # The layerwise theory's shear groups, stretching layers and soft groups of each stack,
    # as (layout, groups, stretch, soft) (``fem.laminates.layerwise``: "Pinned structure").  A
    # SpecimenModel pins them when it is made, by the rules above at its values then, so a
    # fit moving a modulus across a rule's threshold keeps one theory.
    layerwise_structure: tuple = ()

    def __post_init__(self):
        whole(self.modes, "ModelOptions.modes", 1, MAX_SOLVED_MODES, "of elastic modes ", OptionsError)
        if self.divisions is not None:
            whole(
                self.divisions,
                "ModelOptions.divisions",
                *DIVISIONS_RANGE,
                "of elements along the longer side (or None for the default rule) ",
                OptionsError,
            )
        if self.theory not in THEORIES:
            raise ModelError(f"theory = {self.theory!r} is unknown; use one of {', '.join(THEORIES)}")
        if self.layer_groups not in GROUPINGS:
            raise ModelError(
                f"layer_groups = {self.layer_groups!r} is unknown; use one of {', '.join(GROUPINGS)}"
            )

    @property
    def shear_deformable(self) -> bool:
        """Whether the plate theory has transverse shear strains (FSDT or layerwise)."""
        return self.transverse_shear or self.theory == "layerwise"

    @property
    def theory_std_rel(self) -> float:
        """The theory's own error against 3-D elasticity, a relative std of each frequency:
        ``SHEAR_THEORY_STD_REL`` for a shear-deformable theory; 0 for the thin plate, whose
        missing shear is what the diagnosis tests, below the scatter where it finds none."""
        return SHEAR_THEORY_STD_REL if self.shear_deformable else 0.0

    def layerwise_stack(self, laminate: Laminate) -> LayerwiseLaminate:
        """The layerwise stack of ``laminate``: its pinned structure, or the rules'."""
        pinned = {entry[0]: entry[1:] for entry in self.layerwise_structure}.get(layout(laminate))
        return LayerwiseLaminate.of(laminate, self.layer_groups, self.core_stretch, pinned)

    def pinned(self, specimen: Specimen) -> ModelOptions:
        """These options with the layerwise structure of every configuration's stack pinned
        (those pinned already kept, stacks no configuration has any more dropped)."""
        if self.theory != "layerwise":
            return self if not self.layerwise_structure else replace(self, layerwise_structure=())
        entries = []
        for configuration in specimen.configurations:
            laminate = specimen.laminate(configuration)
            stack = self.layerwise_stack(laminate)
            entry = (layout(laminate), *stack.structure)
            if entry not in entries:
                entries.append(entry)
        structure = tuple(entries)
        return self if structure == self.layerwise_structure else replace(self, layerwise_structure=structure)

    def divisions_for(self, specimen: Specimen) -> int:
        """Elements along the longer side: ``divisions``, or the default rule."""
        if self.divisions is not None:
            return self.divisions
        aspect = max(specimen.length, specimen.width) / min(specimen.length, specimen.width)
        return max(MIN_DIVISIONS, math.ceil(DIVISIONS_PER_ROOT_MODE * math.sqrt(self.modes * aspect)))

    def mesh(self, specimen: Specimen) -> PlateMesh:
        """The mesh of every configuration: ``divisions_for`` equal elements, graded
        towards the free edges for a shear-deformable theory (``edge_size``) and divided
        finely over a sensor's base (``PointMass.base``; the lines follow the sensor)."""
        edge = (self.edge_size or edge_size_for(specimen)) if self.shear_deformable else None
        bases = []
        for a in specimen.attachments:
            if isinstance(a, PointMass) and a.base > 0:
                x0, y0 = base_square(a, specimen.length, specimen.width)
                bases.append((x0, x0 + a.base, y0, y0 + a.base))
        return PlateMesh.with_element_size(
            specimen.length, specimen.width, self.divisions_for(specimen), edge, tuple(bases)
        )


def edge_size_for(specimen: Specimen) -> float:
    """Edge element size [m] of a graded mesh for the thinnest configuration
    (``fem.solver.mesh.edge_size``)."""
    return edge_size(min(specimen.laminate(c).thickness for c in specimen.configurations))


@dataclass(frozen=True)
class LaminateSolution:
    """Elastic modes of one laminate on one mesh, with modal energies for sensitivities.

    inertia_terms: which of I0, I1, I2 the model keeps (1) or drops (0);
    transverse_shear: the stiffness also has the three shear coefficients (A44, A55, A45).
    """

    laminate: Laminate
    units: UnitMatrices
    modes: Modes
    inertia_terms: tuple[float, float, float] = KIRCHHOFF_INERTIA
    transverse_shear: bool = False
    attachments: tuple = ()
    layerwise: LayerwiseLaminate | None = None  # the layerwise theory's stack and groups, when solved with it

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.modes.frequencies_hz

    @cached_property
    def energies(self) -> ModalEnergies:
        return one_blas_thread(ModalEnergies.of)(self.units, self.modes)

    @cached_property
    def shape_coefficients(self) -> np.ndarray:
        """Each mode's deflection on products of free-free beam functions (modes, i, j)."""
        return beam_coefficients(self.units, self.modes.shapes)

    @cached_property
    def moves_in_plane(self) -> np.ndarray:
        """Per mode, whether it moves mostly in the plate's plane (bool, (modes,)): a test
        that measures the deflection does not see such a mode; its label is 'in-plane'."""
        return np.array([in_plane(self.units, s) for s in self.modes.shapes.T], dtype=bool)

    @cached_property
    def labels(self) -> tuple[str, ...]:
        """Nodal-pattern labels, e.g. '(1,2)' or '(0,2)+(2,0)' (``fem.solver.mode_shapes``);
        computed when first asked for, not on every solve."""
        return tuple(
            "in-plane" if moving else label_of(c)
            for moving, c in zip(self.moves_in_plane, self.shape_coefficients)
        )

    @cached_property
    def nodal_lines(self) -> np.ndarray:
        """The nodal lines each mode crosses along x and along y, as a lab counts them on
        the plate (``fem.solver.mode_shapes.nodal_line_counts``): (modes, 2), -1 for an
        in-plane mode."""
        counts = nodal_line_counts(self.units, self.modes.shapes)
        return np.where(self.moves_in_plane[:, None], -1, counts)

    def coefficient_derivatives(self, kinds) -> tuple[np.ndarray, np.ndarray]:
        """dX/dp and dI/dp of the laminate parameters ``kinds`` ((kind, target) pairs): the
        derivatives of the weights of the unit stiffness and mass matrices as this theory
        weighs them, (parameters, coefficients) and (parameters, inertia terms)."""
        if self.layerwise is not None:
            return self.layerwise.derivatives(kinds)
        dx, di = (np.array(d) for d in zip(*(self.laminate.derivative(*kind) for kind in kinds)))
        if self.transverse_shear:
            dx = np.hstack([dx, self.laminate.shear_derivatives(kinds)])
        return dx, di * self.inertia_terms

    def shape_derivatives(self, parameters: list[Parameter], indices) -> np.ndarray:
        """d phi_i / dp of the modes ``indices`` [per SI unit of p]: (n_dofs, modes,
        parameters), exact, for laminate parameters of a single-layer theory."""
        return _shape_derivatives(self, parameters, indices)

    @one_blas_thread
    def derivatives(self, parameters: list[Parameter]) -> np.ndarray:
        """df_i/dp_j [Hz per SI unit of p]: (modes, parameters)."""
        if not parameters:
            return np.zeros((len(self.modes.eigenvalues), 0))
        d_lambda = np.zeros((len(self.modes.eigenvalues), len(parameters)))
        laminate = [j for j, p in enumerate(parameters) if p.kind not in ATTACHMENT_PARAMETERS]
        if laminate:
            dx, di = self.coefficient_derivatives(
                [(parameters[j].kind, parameters[j].target) for j in laminate]
            )
            d_lambda[:, laminate] = eigenvalue_derivatives(self.energies, self.modes.eigenvalues, dx, di)
        by_label = {a.label: a for a in self.attachments}
        for j, p in enumerate(parameters):
            if p.kind in ATTACHMENT_PARAMETERS and p.target in by_label:
                d_lambda[:, j] = attachment_derivative(
                    self.units, by_label[p.target], p.kind, self.modes.shapes, self.modes.eigenvalues
                )
        return frequency_derivatives(self.modes.eigenvalues, d_lambda)


def _shape_derivatives(solution: LaminateSolution, parameters: list[Parameter], indices) -> np.ndarray:
    """d phi / dp [per SI unit of p] of the modes ``indices``: (n_dofs, modes, parameters),
    exact (``eigenvector_derivatives``), for the laminate parameters of a single-layer
    theory (attachments kept in K and M)."""
    if solution.layerwise is not None:
        raise ModelError(
            "mode shape sensitivities are not available for the layerwise theory; use the "
            "single-layer plate (Kirchhoff or first-order shear)"
        )
    if any(p.kind in ATTACHMENT_PARAMETERS for p in parameters):
        raise ModelError(
            "mode shape sensitivities to an attachment's parameters are not available; hold its mass "
            "and position, or fit frequencies alone"
        )
    units = solution.units
    coefficients, inertia = system_coefficients(
        solution.laminate, solution.transverse_shear, solution.inertia_terms
    )
    stiffness, mass = system_data(units, coefficients, inertia, solution.attachments)
    dx, di = solution.coefficient_derivatives([(p.kind, p.target) for p in parameters])
    d_stiffness, d_mass = [], []
    for x, i in zip(dx, di):
        dk, dm = system_data(units, x, i)
        d_stiffness.append(units.matrix(dk))
        d_mass.append(units.matrix(dm))
    k_matrix, m_matrix = units.matrix(stiffness), units.matrix(mass)
    out = np.empty((units.n_dofs, len(indices), len(parameters)))
    for n, i in enumerate(indices):
        out[:, n, :] = eigenvector_derivatives(
            k_matrix,
            m_matrix,
            float(solution.modes.eigenvalues[i]),
            solution.modes.shapes[:, i],
            d_stiffness,
            d_mass,
        )[0]
    return out


def system_coefficients(
    laminate: Laminate, transverse_shear: bool, inertia_terms: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """The weights of the unit stiffness and mass matrices of a single-layer theory: the
    18 CLT coefficients (and the 3 shear stiffnesses with ``transverse_shear``) [SI], and
    the inertia terms I0, I1, I2 the theory keeps."""
    coefficients = laminate.stiffness
    if transverse_shear:
        coefficients = np.concatenate([coefficients, laminate.shear_stiffness])
    return coefficients, laminate.inertia * np.array(inertia_terms)


def system_data(
    units: UnitMatrices, coefficients: np.ndarray, inertia: np.ndarray, attachments: tuple = ()
) -> tuple[np.ndarray, np.ndarray]:
    """CSR data of K = sum_c coefficients_c K_c and M = sum_j inertia_j M_j on ``units``
    (weights from ``system_coefficients`` or a layerwise stack; complex ones for damping),
    the attachments' point masses and springs added.  The thin plate's few unit data
    arrays are kept assembled; the shear and layerwise elements' (21 to ~180 of them) are
    weighted element by element before one aggregation: memory for one data array."""
    if units.element_type is HermitePlate:
        stiffness, mass = coefficients @ units.stiffness_data, inertia @ units.mass_data
    else:
        stiffness = units.combined_data(coefficients, units.element_stiffness)
        mass = units.combined_data(inertia, units.element_mass)
    add_attachment_data(units, attachments, stiffness, mass)  # both arrays are new here
    return stiffness, mass


def _solution_bytes(solution: LaminateSolution) -> int:
    """What a cached solve holds [bytes]: its mode shapes and frequencies (the unit
    matrices are shared by every solve on the mesh and cached apart; the modal energies
    computed later are (coefficients x modes), kilobytes), plus a small allowance."""
    modes = solution.modes
    return int(modes.shapes.nbytes + modes.eigenvalues.nbytes) + SOLUTION_OVERHEAD_BYTES


#: Bytes a cached solve holds beside its shapes (energies, labels, the objects themselves).
SOLUTION_OVERHEAD_BYTES = 1 << 16


@bytes_bounded_cache(SOLVE_CACHE_BYTES, _solution_bytes)
@one_blas_thread
def solve_laminate(
    laminate: Laminate,
    mesh: PlateMesh,
    n_modes: int,
    *,
    transverse_shear: bool = False,
    rotary_inertia: bool = False,
    attachments: tuple = (),
    theory: str = "single_layer",
    layer_groups: str = "auto",
    core_stretch: bool = True,
    structure: tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]] | None = None,
) -> LaminateSolution:
    """Solve (and cache by content, within ``SOLVE_CACHE_BYTES``) the free-free modes of a
    laminate on a mesh.

    transverse_shear: first-order shear deformation theory (``ShearDifferencePlate``, the
    laminate's shear stiffness with its shear correction) instead of Kirchhoff;
    rotary_inertia: keep I1 and I2 in the kinetic energy;
    attachments: point masses and suspension springs (``fem.solver.attachments``);
    theory "layerwise": the layerwise element (``fem.laminates.layerwise``, shear groups by
    ``layer_groups``, soft cores stretching unless ``core_stretch`` is off, or the pinned
    ``structure``: (groups, stretching layers, soft groups)) with its full inertia; the two flags are
    then implied.
    """
    stack = None
    if theory == "layerwise":
        stack = LayerwiseLaminate.of(laminate, layer_groups, core_stretch, structure)
    transverse_shear, rotary_inertia = (
        (True, True) if stack is not None else (transverse_shear, rotary_inertia)
    )
    terms = ROTARY_INERTIA if rotary_inertia else KIRCHHOFF_INERTIA
    coefficients, inertia = system_coefficients(laminate, transverse_shear, terms)
    shift = _first_bending_estimate(laminate.stiffness, inertia[0], max(mesh.length, mesh.width))
    if stack is not None:
        units = layerwise_units(mesh, stack.n_groups, 2 * len(stack.stretch), stack.soft)
        coefficients, inertia = stack.stiffness, stack.inertia
    else:
        units = unit_matrices(mesh, ShearDifferencePlate if transverse_shear else HermitePlate)
    stiffness, mass = system_data(units, coefficients, inertia, attachments)
    suspended = any(isinstance(a, Suspension) and a.stiffness > 0 for a in attachments)
    modes = solve_modes(units, stiffness, mass, n_modes, shift, suspended=suspended)
    return LaminateSolution(laminate, units, modes, terms, transverse_shear, attachments, stack)


# A unit set the unit cache lets go goes with the solves that hold it, so the two budgets
# bound what the process keeps.
UNIT_CACHE.on_drop.append(
    lambda units: solve_laminate.cache_discard(lambda solution: solution.units is units)
)


@dataclass(frozen=True)
class SpecimenModel:
    """A specimen and how it is modelled: what a spec file describes, ready to solve.
    Every command and API function takes one (``fem.load_spec`` makes it).

    specimen: the plate, its test configurations and attachments, with the spec's fixed
    ``[[effects]]`` already applied; options: modes, mesh and plate theory; design: the
    validated ``[design]`` table (None when the model was built in code without one);
    effects: the effect kinds the spec switched on; notes: what they assumed (for
    reports); materials: every material the spec defines or names from stock, used or
    not (a test design may bond one); source: the spec file.

    Everything inside is SI (Pa, m, kg); reports print in the spec's units (GPa, mm, g).
    """

    specimen: Specimen
    options: ModelOptions = ModelOptions()
    design: DesignSpace | None = None
    effects: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    materials: tuple[Material, ...] = ()
    source: str = "<spec>"
    input_std: tuple[InputStd, ...] = ()  # known inputs' standard uncertainties, for the budget

    def __post_init__(self):
        if self.options.edge_size is None:
            object.__setattr__(self, "options", replace(self.options, edge_size=edge_size_for(self.specimen)))
        object.__setattr__(self, "options", self.options.pinned(self.specimen))

    @cached_property
    def mesh(self) -> PlateMesh:
        return self.options.mesh(self.specimen)

    @property
    def name(self) -> str:
        return self.specimen.name

    @property
    def defined_materials(self) -> dict[str, Material]:
        """Every material by name: those the spec defines, then any other its layers use."""
        return {**{m.name: m for m in self.materials}, **self.specimen.materials}

    def value(self, parameter: Parameter) -> float:
        """A parameter's current value (SI)."""
        return self.specimen.value(parameter)

    def with_specimen(self, specimen: Specimen) -> SpecimenModel:
        return replace(self, specimen=specimen)

    def with_values(self, values: dict[Parameter, float]) -> SpecimenModel:
        """The same model with parameter values replaced (SI; materials validated again)."""
        return replace(self, specimen=self.specimen.with_values(values))

    def with_options(self, **changes) -> SpecimenModel:
        """The same specimen with model options changed, e.g. ``with_options(modes=8)``.
        A change of theory, grouping or core stretch pins the layerwise structure afresh."""
        if any(key in changes and changes[key] != getattr(self.options, key) for key in THEORY_OPTIONS):
            changes.setdefault("layerwise_structure", ())
        return replace(self, options=replace(self.options, **changes))

    def with_configurations(self, configurations) -> SpecimenModel:
        return replace(self, specimen=self.specimen.with_configurations(configurations))

    def with_attachments(self, attachments) -> SpecimenModel:
        return replace(self, specimen=self.specimen.with_attachments(attachments))

    def solve(self, configuration: str) -> LaminateSolution:
        laminate = self.specimen.laminate(configuration)
        structure = None
        if self.options.theory == "layerwise":
            stack = self.options.layerwise_stack(laminate)
            structure = stack.structure
        return solve_laminate(
            laminate,
            self.mesh,
            self.options.modes,
            transverse_shear=self.options.transverse_shear,
            rotary_inertia=self.options.rotary_inertia,
            attachments=self.specimen.attachments,
            theory=self.options.theory,
            layer_groups=self.options.layer_groups,
            core_stretch=self.options.core_stretch,
            structure=structure,
        )

    def frequencies(self) -> dict[str, np.ndarray]:
        """Elastic frequencies [Hz] of every configuration."""
        return {c.name: self.solve(c.name).frequencies_hz for c in self.specimen.configurations}

    def sensitivity_matrix(self, parameters: list[Parameter], relative: bool = True) -> np.ndarray:
        """Stacked sensitivities of all configurations (paper eq. 14), rows configuration
        by configuration, mode by mode.  Relative: (p/f) df/dp."""
        values = np.array([self.specimen.value(p) for p in parameters])
        blocks = []
        for c in self.specimen.configurations:
            solution = self.solve(c.name)
            d = solution.derivatives(parameters)
            blocks.append(normalised(solution.frequencies_hz, d, values) if relative else d)
        return np.vstack(blocks)


#: Where ``with_bending_modes`` ended last, per kind of model (its options but the number
#: of modes, its configurations, the bending modes asked for): its next search solves there
#: first.  Only the work depends on it, never the count returned.
_LAST_MODE_COUNTS: dict[tuple, int] = {}
_MAX_REMEMBERED_COUNTS = 64


def with_bending_modes(model: SpecimenModel, configurations, bending: int) -> SpecimenModel:
    """``model`` solving at least ``bending`` bending modes of each of ``configurations``
    (names): one mode more for every mode among them that moves in the plate's plane (a
    test that measures the deflection does not see those), at most ``MAX_SOLVED_MODES``,
    never fewer than ``model`` solves, on the mesh ``model`` has for its own number of
    modes (more modes do not refine it).

    The count is the first of the sequence m <- min(bending + in-plane modes among the
    first m, ``MAX_SOLVED_MODES``), from the larger of ``bending`` and ``model``'s modes,
    that it does not raise.  Each step needs the in-plane modes among more modes than the
    last, so the search starts with one solve at the count it ended at for the same kind
    of model (the mass, the moduli and the sensor move the membrane modes little within a
    fit), reads every step that count covers from that solve and solves again only beyond
    it: where the count is the same, each configuration is solved once, not once a step
    (a thick cross-ply's candidate starts solved every configuration twice, about 150
    discarded layerwise solves in a 234 s diagnosis)."""
    divisions = model.options.divisions_for(model.specimen)
    first = max(bending, model.options.modes)
    kind = (replace(model.options, modes=1, divisions=divisions), tuple(configurations), first)

    def moving_in_plane(solved: int) -> list[np.ndarray]:
        solver = model.with_options(modes=solved, divisions=divisions)
        return [solver.solve(c).moves_in_plane for c in configurations]

    solved = _LAST_MODE_COUNTS.get(kind, first)
    flags = moving_in_plane(solved)
    modes = first
    while (needed := min(bending + max(int(f[:modes].sum()) for f in flags), MAX_SOLVED_MODES)) > modes:
        modes = needed
        if modes > solved:
            solved, flags = modes, moving_in_plane(modes)
    if len(_LAST_MODE_COUNTS) >= _MAX_REMEMBERED_COUNTS:
        _LAST_MODE_COUNTS.clear()
    _LAST_MODE_COUNTS[kind] = modes
    return model.with_options(modes=modes, divisions=divisions)


def plate_frequency_parameter(
    frequency_hz: np.ndarray, length: float, mass_per_area: float, D: float
) -> np.ndarray:
    """lambda = omega a^2 sqrt(rho h / D), the usual non-dimensional plate frequency."""
    return 2 * math.pi * np.asarray(frequency_hz) * length**2 * math.sqrt(mass_per_area / D)
