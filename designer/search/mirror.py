"""Mirror designs: the same plates bonded on the other faces.

When the specimen's laminate is symmetric about its mid-plane, turning a configuration
upside down (its top additions to the bottom and back) only mirrors the stack through
that plane: B changes sign, the frequencies and their sensitivities to every layer do
not.  So a set and its mirror (A top + B bottom against A bottom + B top) score alike
and would fill a ranking with ties; rankings keep the better-ranked one and name the
other beside it.  Symmetric means equal in the properties and thicknesses (not the
names) at the nominal values: two coatings that are different materials with equal
start values count, which is exactly when the ties appear.
"""

from __future__ import annotations

from fem.laminates.laminate import Layer
from fem.specimen import Configuration, Specimen


def _physics(layer: Layer) -> tuple:
    m = layer.material
    return (m.E1, m.E2, m.G12, m.nu12, m.density, m.G13, m.G23, layer.thickness, layer.angle)


def is_mirror_symmetric(specimen: Specimen) -> bool:
    """The specimen's layers read the same from the bottom and from the top."""
    layers = specimen.layers
    return all(_physics(a) == _physics(b) for a, b in zip(layers, reversed(layers)))


def signature(configuration: Configuration) -> tuple:
    """What a configuration adds, as (bottom, top) stacks of layer physics."""
    return (tuple(_physics(l) for l in configuration.bottom), tuple(_physics(l) for l in configuration.top))


def set_key(configurations) -> tuple:
    """A set of added configurations, independent of order and names."""
    return tuple(sorted(signature(c) for c in configurations if not c.is_original))


def mirror_key(configurations) -> tuple:
    """The key of the set turned upside down."""
    return tuple(
        sorted((top, bottom) for bottom, top in (signature(c) for c in configurations if not c.is_original))
    )


def collapse(designs: list, configurations_of, symmetric: bool) -> tuple[list, list]:
    """``designs`` (best first) without the mirrors of better-ranked ones, and for each
    kept design the configurations of its collapsed mirror (None when there is none).
    ``configurations_of(design)`` gives a design's configurations."""
    if not symmetric:
        return list(designs), [None] * len(designs)
    kept, mirrors, index = [], [], {}
    for d in designs:
        configurations = configurations_of(d)
        key = set_key(configurations)
        if key in index:  # the mirror of a kept design (a self-mirror set is never met twice)
            k = index[key]
            if mirrors[k] is None:
                mirrors[k] = configurations
            continue
        kept.append(d)
        mirrors.append(None)
        index[key] = len(kept) - 1
        mirrored = mirror_key(configurations)
        if mirrored != key:
            index[mirrored] = len(kept) - 1
    return kept, mirrors
