"""Candidate configurations: one known plate (material x thickness x placement) bonded to
the specimen with the design's adhesive."""

from __future__ import annotations

from dataclasses import dataclass, replace

from fem.design_space import DesignSpace
from fem.laminates.laminate import Layer
from fem.laminates.material import Material
from fem.specimen import Configuration, Specimen


def plate_configuration(
    material: Material, thickness: float, placement: str, adhesive: Layer | None, name: str | None = None
) -> Configuration:
    """The specimen with a ``thickness`` [m] plate of ``material`` bonded on ``placement``.

    Layers are listed from the specimen outward (adhesive first) and labelled as the spec
    loader labels them (``NAME.top1``, ``NAME.top2``), so the same design read from a spec
    is the same laminate.
    """
    name = name or f"{material.name}_{thickness * 1e3:g}mm_{placement}"
    layers = ([adhesive] if adhesive is not None else []) + [Layer(material, thickness)]
    labelled = tuple(
        Layer(l.material, l.thickness, l.angle, f"{name}.{placement}{j + 1}") for j, l in enumerate(layers)
    )
    return Configuration(name, **{placement: labelled})


def outer_face(configuration: Configuration) -> str:
    """The face whose outermost layer is the added plate (top when both carry layers)."""
    return "top" if configuration.top else "bottom"


def with_plate_thickness(
    configuration: Configuration, thickness: float, rename: bool = False
) -> Configuration:
    """The configuration with its outermost added layer ``thickness`` [m] thick; with
    ``rename`` named after it (e.g. 'brass_1.37mm_top')."""
    face = outer_face(configuration)
    layers = getattr(configuration, face)
    name = f"{layers[-1].material.name}_{thickness * 1e3:.3g}mm_{face}" if rename else configuration.name
    return replace(
        configuration, name=name, **{face: layers[:-1] + (replace(layers[-1], thickness=thickness),)}
    )


@dataclass(frozen=True)
class CandidateSet:
    """The candidate configurations a design space allows, and those it had to leave out
    (name -> reason)."""

    configurations: tuple[Configuration, ...]
    excluded: dict[str, str]

    def __len__(self) -> int:
        return len(self.configurations)


def candidates(space: DesignSpace, specimen: Specimen) -> CandidateSet:
    """Every material x thickness x placement, minus those over the mass or thickness limit."""
    area = specimen.length * specimen.width
    kept, excluded = [], {}
    for material in space.materials:
        for thickness in space.thicknesses:
            for placement in space.placements:
                configuration = plate_configuration(material, thickness, placement, space.adhesive)
                broken = space.limits.violations(configuration, area)
                if broken:
                    excluded[configuration.name] = "; ".join(broken)
                else:
                    kept.append(configuration)
    return CandidateSet(tuple(kept), excluded)
