"""Physical effects beyond the baseline Kirchhoff free-plate model, and their registry.

An effect is a parameterised change of the model.  Switched on from a spec's
``[[effects]]`` table its parameters are fixed; switched on free (``--effect KIND`` or
by the diagnosis) it brings parameters that are estimated with the layer properties.
Every built-in effect has exact sensitivities (modal energies, or the attachment
formulas in ``fem.solver.attachments``).

Registering a new kind (see the README, "Adding an effect"): subclass ``Effect``, give
it a ``kind`` and implement ``fixed`` and ``free``, then call ``register(MyEffect())``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .errors import NotApplicableError, SpecError
from .laminates.layerwise import soft_layers, stretching_layers
from .model import SpecimenModel
from .solver.attachments import PointMass, Suspension
from .specimen import Parameter
from .validation import check_keys, number


@dataclass(frozen=True)
class SwitchedOn:
    """A model with an effect switched on: the model to solve, the free parameters the
    effect brings (empty when fixed) and a note for the report."""

    kind: str
    model: SpecimenModel
    free: tuple[Parameter, ...] = ()
    note: str = ""


class Effect:
    """Base class of effects.  ``keys`` lists the spec table keys ``fixed`` accepts.

    An effect also declares how a diagnosis treats it (``identify.diagnosis``): the
    physics it ``covers`` (an effect that is others together, e.g. the Mindlin plate),
    the effects it ``refines`` (tried only where one of those pays), whether it
    ``frees_shear`` moduli (G13, G23: restarts, continuation and the held-moduli rule
    apply), whether it ``restarts_from_spec`` when the thin-plate fit it would start from
    is degenerate, the ``sign`` an implausible estimate of it is reported as, and the
    selected effects it ``completes`` at the selection's end (in their place when it
    ``replaces`` them: a fuller theory of the same physics; else beside them), and whether
    its refit runs from ``independent_starts`` that the residual scan ``hinted``, and the
    parameters that measure its ``amount``."""

    kind = ""
    description = ""
    keys: tuple[str, ...] = ()
    covers: frozenset[str] = frozenset()
    refines: tuple[str, ...] = ()
    frees_shear = False
    restarts_from_spec = False
    sign = "read it as a sign of what is missing"
    completes: tuple[str, ...] = ()
    replaces = False
    #: Its refit is several independent ones from starts over the plate, side by side
    #: where worker processes are open, the lowest misfit kept (a sensor's positions).
    independent_starts = False
    #: What it may explain is bounded by the residual scan's hints (each start's share of
    #: the misfit) as well as by the linearised step, which at a wrong position explains
    #: little.
    hinted = False
    #: The kinds of its parameters that say how much of it there is, zero where it is
    #: absent (a sensor's mass, the springs' stiffness): where the refit determines none of
    #: them (std at least the value), the data show a misfit it removes, not the effect.
    amount: tuple[str, ...] = ()
    #: Its ``other_starts`` are the fit it is added to but for an amount of the effect that
    #: moves no frequency by more than about 1e-8 (springs all but gone): the fit's own modes
    #: span theirs, and its pre-check evaluates them on the fit's Rayleigh-Ritz models
    #: (``Sensitivities.on_state_modes``), not by solving every configuration again.
    other_starts_spanned = False

    @property
    def physics(self) -> frozenset[str]:
        """The effects this one is the same physics as (``covers``), or itself."""
        return self.covers or frozenset({self.kind})

    def adds_nothing(self, model: SpecimenModel) -> bool:
        """True where switching this effect on gives ``model`` the same model as an
        effect it completes (then it is not tried as a completion)."""
        return False

    def fixed(self, model: SpecimenModel, table: dict) -> SwitchedOn:
        """The model with the effect on, its parameters fixed by the spec's table."""
        raise NotImplementedError

    def free(self, model: SpecimenModel, hint: dict | None = None) -> list[SwitchedOn]:
        """Variants with free parameters (e.g. one per candidate layer); ``hint`` may carry
        start values from the residual patterns."""
        raise NotImplementedError

    def hint_at(self, values: dict[Parameter, float]) -> dict:
        """The ``hint`` that makes ``free`` start at ``values`` of its parameters [SI] (a
        finished refit's end), for an effect refitted from ``independent_starts``."""
        raise NotImplementedError

    def free_all(self, model: SpecimenModel) -> SwitchedOn:
        """All variants at once (e.g. every candidate layer's angle), for ``--effect``."""
        variants = self.free(model)
        if not variants:
            raise NotApplicableError(f"effect '{self.kind}' has nothing to act on in this spec")
        if len(variants) == 1:
            return variants[0]
        starts = {p: v.model.value(p) for v in variants for p in v.free}
        return SwitchedOn(
            self.kind,
            replace(variants[0].model, specimen=model.specimen.with_values(starts)),
            tuple(starts),
            "; ".join(v.note for v in variants if v.note),
        )

    def other_starts(self, switched: SwitchedOn, shapes: bool = False) -> list[SpecimenModel]:
        """Other start models of the free parameters of ``switched`` worth one linearised
        step each (the refit starts from the best); none by default.  ``shapes``: the data
        include measured mode shapes (they tell a plate from its mirror image)."""
        return []

    @property
    def _where(self) -> str:
        return f"[[effects]] kind = '{self.kind}'"

    def _check(self, table: dict) -> None:
        check_keys(table, self.keys + ("kind",), self._where)

    def _layer(self, model: SpecimenModel, table: dict) -> str:
        """The specimen layer label a table names, checked."""
        labels = [l.label for l in model.specimen.layers]
        layer = str(table.get("layer", ""))
        if layer not in labels:
            raise SpecError(f"{self._where}: layer = {layer!r}; use one of {', '.join(labels)}")
        return layer

    def _number(self, table: dict, key: str, default=None) -> float:
        return number(table, key, self._where, required=default is None, default=default)


class TransverseShear(Effect):
    kind = "transverse_shear"
    description = (
        "first-order shear deformation; free: G13, G23 of the identified materials (G12 where not given, "
        "stated)"
    )
    options = {"transverse_shear": True}
    frees_shear = True
    #: Refitted from the spec's values too when the thin-plate fit is degenerate
    #: (``identify.fitting.driver.spec_start``): the whole of the thin plate's misfit is
    #: the shear's to explain, and its moduli are what the thin plate did to them (blind
    #: cross-ply and hybrid plates with a/h of 15-20: 15-17 % misfit left with a ply's E2
    #: and nu12 at their bounds, from where the shear refit stopped at 1.3 % or 8.6 %
    #: against a floor of 0.07 % or 0.37 %).
    restarts_from_spec = True

    @staticmethod
    def shear_parameters(model) -> list[Parameter]:
        """G13 and G23 of every identified material that does not identify them already."""
        return [
            Parameter(kind, m.name)
            for m in model.specimen.identified_materials
            for kind in ("G13", "G23")
            if kind not in m.identify
        ]

    def _on(self, model, free=()):
        freed = {p.target for p in free}
        by_defaults: dict[str, list[str]] = {}
        for m in model.specimen.materials.values():
            if m.defaulted_shear_moduli and m.name not in freed:
                by_defaults.setdefault(" = ".join(m.defaulted_shear_moduli), []).append(m.name)
        notes = [
            f"{names} = G12 assumed for {', '.join(materials)} (exact for isotropic layers)"
            for names, materials in by_defaults.items()
        ]
        if free:
            materials = model.specimen.materials
            started = sorted({p.target for p in free if p.kind in materials[p.target].defaulted_shear_moduli})
            notes.insert(
                0,
                f"free: {', '.join(p.name for p in free)}"
                + (f" (starting at G12 for {', '.join(started)})" if started else ""),
            )
        return SwitchedOn(self.kind, model.with_options(**self.options), tuple(free), "; ".join(notes))

    def fixed(self, model, table):
        self._check(table)
        return self._on(model)

    def free(self, model, hint=None):
        return [self._on(model, self.shear_parameters(model))]


class ThickPlate(TransverseShear):
    kind = "thick_plate"
    description = (
        "Mindlin plate: transverse shear and rotary inertia together; free: G13, G23 of the identified "
        "materials"
    )
    options = {"transverse_shear": True, "rotary_inertia": True}
    covers = frozenset({"transverse_shear", "rotary_inertia"})


class Layerwise(Effect):
    kind = "layerwise"
    description = (
        "layerwise (zig-zag) shear: each soft layer (foam or honeycomb core, bond line) shears on its "
        "own; free: G13, G23 of the identified materials and of the soft specimen layers"
    )
    #: Shear and the full inertia of its displacement field besides its soft layers' own
    #: shear; it frees the same shear moduli.
    covers = frozenset({"layerwise", "transverse_shear", "rotary_inertia"})
    #: It refines transverse shear where a layer is much softer in shear than its
    #: neighbours (elsewhere it does not apply), and one of its solves costs 6-18 of the
    #: single-layer model's: tried in a round only where one of these paid (or is selected).
    refines = ("transverse_shear", "thick_plate")
    frees_shear = True
    #: Judged in the round where the shear first enters, with other effects still missing,
    #: its ply shear moduli can run out and it loses to the single shear layer; refitted
    #: in its place from the selection's end it can win (``identify.diagnosis``).
    completes = refines
    replaces = True

    def _soft(self, model):
        """(soft specimen layers' materials, soft added layers' materials), by name."""
        specimen = model.specimen
        found = {}
        for configuration in specimen.configurations:
            laminate = specimen.laminate(configuration)
            for layer, soft in zip(laminate.layers, soft_layers(laminate)):
                if soft:
                    found.setdefault(layer.material.name, layer in specimen.layers)
        return [n for n, own in found.items() if own], [n for n, own in found.items() if not own]

    def single_shear_layer(self, model: SpecimenModel) -> bool:
        """Every configuration's stack is one shear group with no stretching layer (a
        single homogeneous layer, say): the layerwise theory is then the first-order
        shear plate with rotary inertia, ``thick_plate``, to round-off
        (``tests/fem/test_layerwise.py``), and switching to it adds nothing."""
        options, specimen = model.options, model.specimen
        stacks = [options.layerwise_stack(specimen.laminate(c)) for c in specimen.configurations]
        return all(stack.n_groups == 1 and not stack.stretch for stack in stacks)

    def adds_nothing(self, model: SpecimenModel) -> bool:
        return self.single_shear_layer(model)

    @staticmethod
    def held_normal_moduli(model: SpecimenModel) -> list:
        """The materials of the layers that stretch through their thickness in the layerwise
        theory (``stretching_layers``) whose E3 would follow an identified E2, each with its
        E3 set to that E2 as it stands [Pa]: held from then on, while E2 is fitted.  Tied,
        the in-plane E2 of a thin soft layer, which the frequencies hardly see in plane,
        becomes its through-thickness stiffness, which they see strongly: blind99's 1 mm
        polymer coating (E = 0.82 GPa) on aluminium, its 9.5 g sensor not yet in the model,
        took E2 = 3.5 MPa, the coating's mass bouncing on it imitating the sensor, at 0.83 %
        std and 28,000 std from the truth."""
        specimen = model.specimen
        if not model.options.core_stretch:
            return []
        stretching = set()
        for configuration in specimen.configurations:
            laminate = specimen.laminate(configuration)
            stretching |= {laminate.layers[k].material.name for k in stretching_layers(laminate)}
        return [
            replace(m, E3=m.E2)
            for m in specimen.materials.values()
            if m.name in stretching and m.E3 is None and "E2" in m.identify
        ]

    def _on(self, model, free=()):
        own, added = self._soft(model)
        notes = [
            f"soft layers shear on their own: {', '.join(own + added)}"
            if own or added
            else "no soft layer: the same as transverse_shear with rotary inertia"
        ]
        held = self.held_normal_moduli(model)
        if held:
            model = model.with_specimen(model.specimen.with_materials(held))
            notes.append(
                "through-thickness modulus held at the E2 it starts from (E3 not in the spec): "
                + ", ".join(f"{m.name} E3 = {m.E3 / 1e9:.4g} GPa" for m in held)
                + " (E2 is fitted in plane apart from it)"
            )
        defaulted = [
            f"{' = '.join(m.defaulted_shear_moduli)} = G12 for {m.name}"
            for m in model.specimen.materials.values()
            if m.defaulted_shear_moduli
        ]
        if defaulted:
            notes.append(f"assumed {', '.join(defaulted)} (exact for isotropic layers)")
        if free:
            notes.append(f"free: {', '.join(p.name for p in free)}")
        return SwitchedOn(self.kind, model.with_options(theory="layerwise"), tuple(free), "; ".join(notes))

    def fixed(self, model, table):
        self._check(table)
        return self._on(model)

    def free(self, model, hint=None):
        own, added = self._soft(model)
        if not own and not added:
            return []  # a single shear group: transverse_shear already is this model
        materials = model.specimen.materials
        free = TransverseShear.shear_parameters(model)
        free += [
            p
            for p in (
                Parameter(kind, name)
                for name in own
                for kind in ("G13", "G23")
                if kind not in materials[name].identify
            )
            if p not in free
        ]
        return [self._on(model, free)]


class RotaryInertia(Effect):
    kind = "rotary_inertia"
    description = "rotary inertia of the plate (I1, I2 terms)"
    #: Every real plate has it beside its transverse shear; a Mindlin candidate judged
    #: early, with a sensor still missing, can be implausible and never selected, and
    #: shear alone then lets the moduli absorb the rotary inertia.
    completes = ("transverse_shear",)

    def fixed(self, model, table):
        self._check(table)
        return SwitchedOn(self.kind, model.with_options(rotary_inertia=True))

    def free(self, model, hint=None):
        return [self.fixed(model, {})]


def _plate_mass(specimen) -> float:
    """The original plate's mass [kg]."""
    return specimen.laminate(specimen.configurations[0].name).inertia[0] * specimen.length * specimen.width


class PointMassEffect(Effect):
    kind = "point_mass"
    description = (
        "a mass at a point (an accelerometer, a glue blob): mass and position; base_mm, the side of the "
        "sensor's square footprint, spreads it over that"
    )
    sign = (
        "the misfit grows with the mode number like shear, or a sensor heavier than plausible: transverse "
        "shear, or a mass measured and given in the spec?"
    )
    keys = ("mass_g", "x_mm", "y_mm", "label", "base_mm")
    independent_starts = True
    hinted = True
    amount = ("mass",)

    def fixed(self, model, table):
        self._check(table)
        mass = PointMass(
            self._number(table, "mass_g") * 1e-3,
            self._number(table, "x_mm") * 1e-3,
            self._number(table, "y_mm") * 1e-3,
            str(table.get("label", self.kind)),
            self._number(table, "base_mm", 0.0) * 1e-3,
        )
        plate = _plate_mass(model.specimen)
        if mass.mass > plate:
            raise SpecError(
                f"{self._where}.mass_g = {1e3 * mass.mass:g} g is more than the plate itself "
                f"({1e3 * plate:.4g} g): a point mass is a sensor or a glue blob; the mass is in grams"
            )
        return SwitchedOn(self.kind, model.with_attachments(model.specimen.attachments + (mass,)))

    def hint_at(self, values):
        by_kind = {p.kind: v for p, v in values.items()}
        return {"xy": (by_kind["x"], by_kind["y"]), "mass_kg": by_kind["mass"], "ended": True}

    def free(self, model, hint=None):
        specimen = model.specimen
        hint = hint or {}
        plate_mass = _plate_mass(specimen)
        mass = hint.get("mass_kg") or 0.01 * plate_mass
        x, y = hint.get("xy", (0.8 * specimen.length, 0.7 * specimen.width))
        # Start inside the plate, so that the first step may go either way.
        x, y = (
            np.clip(x, 0.02 * specimen.length, 0.98 * specimen.length),
            np.clip(y, 0.02 * specimen.width, 0.98 * specimen.width),
        )
        on = PointMass(max(mass, 1e-3 * plate_mass), x, y, self.kind)
        free = tuple(Parameter(k, self.kind) for k in ("mass", "x", "y"))
        note = (
            "start where a refit ended"
            if hint.get("ended")
            else "start from the residual pattern"
            if "xy" in hint
            else "start at a guessed position"
        )
        if all(abs(math.sin(2 * layer.angle)) < 1e-12 for layer in specimen.all_layers()):
            note += "; mirrored positions (L - x, W - y) give the same frequencies"
        return [SwitchedOn(self.kind, model.with_attachments(specimen.attachments + (on,)), free, note)]


class SuspensionEffect(Effect):
    kind = "suspension"
    description = "out-of-plane springs where the plate is suspended: stiffness"
    sign = "the lowest modes are off: the suspension, or a missing shear effect?"
    keys = ("stiffness_N_m", "points_mm")
    amount = ("stiffness",)
    other_starts_spanned = True
    #: Default support points when none are given: near the four corners (10 % in).
    DEFAULT_INSET = 0.1
    #: The vanishing start's stiffness, a share of the default start's: the default moves
    #: the first elastic mode by about 0.1 %, this by about 1e-8, far below any scatter.
    VANISHING = 1e-5

    def _points(self, specimen, table):
        if "points_mm" not in table:
            a, b, t = specimen.length, specimen.width, self.DEFAULT_INSET
            return ((t * a, t * b), ((1 - t) * a, t * b), ((1 - t) * a, (1 - t) * b), (t * a, (1 - t) * b))
        points = table["points_mm"]
        if not isinstance(points, list) or not all(isinstance(p, list) and len(p) == 2 for p in points):
            raise SpecError("[[effects]] kind = 'suspension': points_mm must be a list of [x, y] pairs in mm")
        return tuple((1e-3 * float(x), 1e-3 * float(y)) for x, y in points)

    def fixed(self, model, table):
        self._check(table)
        springs = Suspension(
            self._number(table, "stiffness_N_m"), self._points(model.specimen, table), self.kind
        )
        return SwitchedOn(self.kind, model.with_attachments(model.specimen.attachments + (springs,)))

    def free(self, model, hint=None):
        specimen = model.specimen
        # Start where the suspension modes sit at ~5 % of the first elastic frequency.
        laminate = specimen.laminate(specimen.configurations[0].name)
        plate_mass = laminate.inertia[0] * specimen.length * specimen.width
        d = max(laminate.stiffness[12], laminate.stiffness[14])
        omega1 = (22.0 / max(specimen.length, specimen.width) ** 2) * math.sqrt(d / laminate.inertia[0])
        points = self._points(specimen, {})
        k = (0.05 * omega1) ** 2 * plate_mass / len(points)
        springs = Suspension(k, points, self.kind)
        note = "springs near the four corners (give points_mm in the spec to fix them)"
        return [
            SwitchedOn(
                self.kind,
                model.with_attachments(specimen.attachments + (springs,)),
                (Parameter("stiffness", self.kind),),
                note,
            )
        ]

    def other_starts(self, switched, shapes=False):
        """The springs all but gone (``VANISHING``): the fit the effect is added to, from
        where a refit can only descend (from the default start one stopped above it, its
        stiffness creeping towards zero in log space while the layers lagged)."""
        p = Parameter("stiffness", self.kind)
        return [switched.model.with_values({p: self.VANISHING * switched.model.value(p)})]


class Orientation(Effect):
    kind = "orientation"
    description = "material axes of a layer turned from the plate edges: angle"
    sign = "the twisting modes are off: a turned layer, or shear coupling?"
    keys = ("layer", "angle_deg")
    #: Frequencies are even in the angle, so the search starts off zero.
    START_DEG = 3.0

    def fixed(self, model, table):
        self._check(table)
        layer = self._layer(model, table)
        angle = math.radians(self._number(table, "angle_deg"))
        return SwitchedOn(self.kind, model.with_values({Parameter("angle", layer): angle}))

    def free(self, model, hint=None):
        """The angle of every identified layer with axes: where the spec states a lay-up
        tolerance (``angle_deg_std``) for some layers, only those; a layer given none (a
        foam core) has no axes to turn.  blind06 (held-out, a glass-skinned sandwich): the
        core, its G13 and G23 free, turned -37 deg, which made the candidate implausible
        and left the skins' 2-5 deg unfitted."""
        stated = {s.target for s in model.input_std if s.kind == "angle"}
        out = []
        for layer in model.specimen.layers:
            if layer.material.identify and (not stated or layer.label in stated):
                p = Parameter("angle", layer.label)
                moved = model.with_values({p: layer.angle + math.radians(self.START_DEG)})
                out.append(
                    SwitchedOn(self.kind, moved, (p,), f"angle of {layer.label} ({layer.material.name})")
                )
        return out

    def other_starts(self, switched, shapes=False):
        """Every free angle at -``START_DEG`` instead: the frequencies are even in the
        angles of all layers together only while the plate is mirror-symmetric; a sensor
        off the mirror line breaks that, and the side matters (blind19: from +3 deg the
        linearised step promised nothing, the solution lies near -4.5 deg).

        Where the plate is its own mirror image about y = W/2 but for the free angles
        (``Specimen.maps_onto_itself``) and no mode shape is measured, every angle at -3
        deg is the +3 deg start mirrored, the same frequencies: the other starts are then
        each free ply turned the other way alone (for three plies, every way they can turn
        against each other).  At a 0/90 lay-up the first
        derivatives in the angles vanish, and a step reaches only the turns of its own
        start's pattern: blind35 (a cross-ply, its outer plies turned +1.5 and -1.6 deg),
        from the layerwise fit, promised 72 from every ply at +3 deg and 393 from (+3, +3,
        -3) deg; the refit explained 442 of 459, but at 72 it was not refitted, and a
        spurious sensor was added instead."""
        free = list(switched.free)
        turn = math.radians(self.START_DEG)
        if shapes or not switched.model.specimen.maps_onto_itself(
            flip_x=False, flip_y=True, negate=True, free=set(free)
        ):
            return [switched.model.with_values({p: switched.model.value(p) - 2 * turn for p in free})]
        flips = free if len(free) > 2 else free[1:]  # two plies: either one turned back is one pattern
        return [switched.model.with_values({p: switched.model.value(p) - 2 * turn}) for p in flips]


class Adhesive(Effect):
    kind = "adhesive"
    description = "bond-line thickness of each bonded configuration off nominal"
    sign = "the bonded configurations are off: the bond line's shear (layerwise)?"
    keys = ("thickness_mm",)

    @staticmethod
    def bond_layers(specimen):
        """The added layer next to the specimen in each configuration that adds two or more."""
        for c in specimen.configurations:
            for added in (c.bottom, c.top):
                if len(added) >= 2:
                    yield added[0]

    def fixed(self, model, table):
        self._check(table)
        t = self._number(table, "thickness_mm") * 1e-3
        return SwitchedOn(
            self.kind,
            model.with_values({Parameter("thickness", l.label): t for l in self.bond_layers(model.specimen)}),
        )

    def free(self, model, hint=None):
        free = tuple(Parameter("thickness", l.label) for l in self.bond_layers(model.specimen))
        return [SwitchedOn(self.kind, model, free, "bond-line thicknesses free")] if free else []


class Thickness(Effect):
    kind = "thickness"
    description = "specimen layer thicknesses off nominal"
    sign = (
        "the misfit wants the neutral axis or the bending stiffness distribution to move: transverse shear "
        "or a layerwise effect?"
    )
    keys = ("layer", "thickness_mm")

    def fixed(self, model, table):
        self._check(table)
        layer = self._layer(model, table)
        return SwitchedOn(
            self.kind,
            model.with_values({Parameter("thickness", layer): self._number(table, "thickness_mm") * 1e-3}),
        )

    def free(self, model, hint=None):
        free = tuple(Parameter("thickness", l.label) for l in model.specimen.layers)
        return [SwitchedOn(self.kind, model, free, "specimen layer thicknesses free")]


REGISTRY: dict[str, Effect] = {}


def register(effect: Effect) -> Effect:
    """Make an effect kind available to specs, ``--effect`` and the diagnosis."""
    if not effect.kind:
        raise ValueError("an effect needs a 'kind' name")
    REGISTRY[effect.kind] = effect
    return effect


for _effect in (
    TransverseShear(),
    RotaryInertia(),
    ThickPlate(),
    PointMassEffect(),
    SuspensionEffect(),
    Orientation(),
    Adhesive(),
    Thickness(),
    Layerwise(),
):
    register(_effect)


def effect(kind: str) -> Effect:
    """The registered effect of this kind, or a one-line error listing the known kinds."""
    try:
        return REGISTRY[kind]
    except KeyError:
        raise SpecError(f"unknown effect kind {kind!r}; known: {', '.join(REGISTRY)}") from None


def apply_fixed(model: SpecimenModel, tables) -> SpecimenModel:
    """The model with the spec's ``[[effects]]`` tables switched on, their parameters
    fixed; their kinds and notes are kept on the model.  Only the spec loader calls this:
    a loaded model has its effects on already."""
    for table in tables:
        if "kind" not in table:
            raise SpecError("[[effects]]: every table needs a 'kind'")
        on = effect(str(table["kind"])).fixed(model, table)
        model = replace(
            on.model,
            effects=on.model.effects + (on.kind,),
            notes=on.model.notes + ((on.note,) if on.note else ()),
        )
    return model


__all__ = ["Effect", "SwitchedOn", "REGISTRY", "register", "effect"]
