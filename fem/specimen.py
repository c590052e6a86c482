"""Specimens, bonded test configurations and the parameters that describe them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .errors import SpecError
from .laminates.laminate import Laminate, Layer
from .laminates.material import MATERIAL_PARAMETERS, Material
from .solver.attachments import ATTACHMENT_PARAMETERS, PointMass, Suspension, check_attachment

LAYER_PARAMETERS = ("thickness", "angle")
KINDS = MATERIAL_PARAMETERS + LAYER_PARAMETERS + ATTACHMENT_PARAMETERS


@dataclass(frozen=True)
class Parameter:
    """A model parameter: a material property (target = material name), a layer
    property (``thickness`` [m] or ``angle`` [rad]; target = layer label) or an
    attachment's (``mass`` [kg], ``x``, ``y`` [m], ``stiffness`` [N/m]; target = its label)."""

    kind: str
    target: str

    def __post_init__(self):
        if self.kind not in KINDS:
            raise SpecError(f"parameter kind {self.kind!r} is unknown; allowed: {', '.join(KINDS)}")

    @property
    def name(self) -> str:
        return f"{self.target}.{self.kind}"


@dataclass(frozen=True)
class Configuration:
    """A test plate: the specimen with known plates bonded under and/or over it.

    bottom, top: added layers listed from the specimen outward.
    """

    name: str
    bottom: tuple[Layer, ...] = ()
    top: tuple[Layer, ...] = ()

    @property
    def is_original(self) -> bool:
        return not self.bottom and not self.top


@dataclass(frozen=True)
class Specimen:
    """A rectangular laminated plate [m] and its test configurations."""

    name: str
    length: float
    width: float
    layers: tuple[Layer, ...]
    configurations: tuple[Configuration, ...] = field(default=(Configuration("original"),))
    attachments: tuple[PointMass | Suspension, ...] = ()

    def __post_init__(self):
        labels = [a.label for a in self.attachments]
        if len(set(labels)) != len(labels):
            raise SpecError(f"attachments need distinct labels; got {', '.join(labels)}")
        for attachment in self.attachments:
            check_attachment(attachment, self.length, self.width)

    def attachment(self, label: str) -> PointMass | Suspension:
        for a in self.attachments:
            if a.label == label:
                return a
        raise SpecError(
            f"no attachment labelled {label!r}; known: "
            f"{', '.join(a.label for a in self.attachments) or 'none'}"
        )

    @property
    def materials(self) -> dict[str, Material]:
        """Every material used, by name (specimen layers and additions)."""
        out = {}
        for layer in self.all_layers():
            out.setdefault(layer.material.name, layer.material)
        return out

    @property
    def identified_materials(self) -> list[Material]:
        return [m for m in self.materials.values() if m.identify]

    def maps_onto_itself(self, flip_x: bool, flip_y: bool, negate: bool, free=frozenset()) -> bool:
        """Whether the image x -> L - x (``flip_x``), y -> W - y (``flip_y``), every ply angle
        negated (``negate``) maps the plate onto itself but for the ``free`` parameters
        (which may move to their images): every other ply at 0 or 90 deg where the angles
        are negated, every sensor coordinate that is not free on the mid-line it is
        mirrored about, the suspension points onto each other (to 1e-9 of the plate's
        size)."""
        tolerance = 1e-9 * max(self.length, self.width)
        if negate and any(
            abs(math.sin(2 * layer.angle)) > 1e-12
            for layer in self.all_layers()
            if Parameter("angle", layer.label) not in free
        ):
            return False
        for a in self.attachments:
            if isinstance(a, PointMass):
                for kind, flip, centre in (("x", flip_x, self.length / 2), ("y", flip_y, self.width / 2)):
                    off_centre = abs(getattr(a, kind) - centre) > tolerance
                    if flip and off_centre and Parameter(kind, a.label) not in free:
                        return False
            elif isinstance(a, Suspension):
                points = np.array(a.points)
                images = np.column_stack(
                    [
                        self.length - points[:, 0] if flip_x else points[:, 0],
                        self.width - points[:, 1] if flip_y else points[:, 1],
                    ]
                )
                distances = np.linalg.norm(points[:, None, :] - images[None, :, :], axis=2)
                if not np.all(distances.min(axis=1) <= tolerance):
                    return False
        return True

    def all_layers(self):
        yield from self.layers
        for c in self.configurations:
            yield from c.bottom
            yield from c.top

    def configuration(self, name: str) -> Configuration:
        for c in self.configurations:
            if c.name == name:
                return c
        known = ", ".join(c.name for c in self.configurations)
        raise SpecError(f"configuration {name!r} is not in the spec; known: {known}")

    def laminate(self, configuration: Configuration | str) -> Laminate:
        """The full stack of a configuration, bottom to top."""
        if isinstance(configuration, str):
            configuration = self.configuration(configuration)
        return Laminate(tuple(reversed(configuration.bottom)) + self.layers + configuration.top)

    def value(self, parameter: Parameter) -> float:
        """The current value of a parameter (SI units)."""
        if parameter.kind in ATTACHMENT_PARAMETERS:
            return float(getattr(self.attachment(parameter.target), parameter.kind))
        if parameter.kind in MATERIAL_PARAMETERS:
            try:
                return self.materials[parameter.target].value(parameter.kind)
            except KeyError:
                raise SpecError(f"parameter {parameter.name}: no material {parameter.target!r}") from None
        for layer in self.all_layers():
            if layer.label == parameter.target:
                return getattr(layer, parameter.kind)
        raise SpecError(f"parameter {parameter.name}: no layer labelled {parameter.target!r}")

    def with_values(self, values: dict[Parameter, float]) -> Specimen:
        """A copy with parameter values replaced (materials validated again)."""
        materials = dict(self.materials)
        changes: dict[str, dict[str, float]] = {}
        layer_changes: dict[str, dict[str, float]] = {}
        attachment_changes: dict[str, dict[str, float]] = {}
        for p, v in values.items():
            if p.kind in ATTACHMENT_PARAMETERS:
                self.attachment(p.target)
                target = attachment_changes
            else:
                target = changes if p.kind in MATERIAL_PARAMETERS else layer_changes
            target.setdefault(p.target, {})[p.kind] = float(v)
        for name, change in changes.items():
            if name not in materials:
                raise SpecError(f"no material {name!r} in this specimen")
            materials[name] = materials[name].with_values(**change)
        attachments = tuple(replace(a, **attachment_changes.get(a.label, {})) for a in self.attachments)
        return replace(self._with_layers(materials, layer_changes), attachments=attachments)

    def with_materials(self, materials) -> Specimen:
        """A copy with these materials (``Material`` objects) put in every layer that uses
        a material of the same name."""
        return self._with_layers({**self.materials, **{m.name: m for m in materials}}, {})

    def _with_layers(self, materials: dict, layer_changes: dict) -> Specimen:
        """Every layer (specimen and additions) with its material taken from ``materials``
        by name and its ``layer_changes`` (label -> field -> value) applied."""

        def stack(layers):
            return tuple(
                replace(layer, material=materials[layer.material.name], **layer_changes.get(layer.label, {}))
                for layer in layers
            )

        configurations = tuple(
            replace(c, bottom=stack(c.bottom), top=stack(c.top)) for c in self.configurations
        )
        return replace(self, layers=stack(self.layers), configurations=configurations)

    def with_configurations(self, configurations) -> Specimen:
        return replace(self, configurations=tuple(configurations))

    def with_attachments(self, attachments) -> Specimen:
        """A copy with these attachments (validated)."""
        return replace(self, attachments=tuple(attachments))

    def material_parameters(self) -> list[Parameter]:
        """The parameters every identified material's ``identify`` names (by default E1,
        E2, G12, nu12), material by material."""
        return [Parameter(kind, m.name) for m in self.identified_materials for kind in m.identify]
