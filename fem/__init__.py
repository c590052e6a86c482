"""The shared physics core: laminate theory, plate elements, free-free modal solves,
exact frequency sensitivities and physical effects.

``load_spec(path)`` reads a spec file into a ``SpecimenModel``: the specimen with its
fixed effects switched on, the model options and the validated ``[design]`` table.
Every command and API function takes that object.  Inside, all quantities are SI
(Pa, m, kg); results print in the spec's units (GPa, mm, g).  The names are imported
when first used, so that a command line that needs only a part (its version, its help)
starts fast.
"""

from .lazy import lazy_package

#: Public name -> the module that defines it.
_HOMES = {
    "Effect": "fem.effects",
    "SwitchedOn": "fem.effects",
    "effect": "fem.effects",
    "register": "fem.effects",
    "DesignError": "fem.errors",
    "LayerIdError": "fem.errors",
    "MeasurementError": "fem.errors",
    "ModelError": "fem.errors",
    "OptionsError": "fem.errors",
    "SpecError": "fem.errors",
    "Laminate": "fem.laminates.laminate",
    "Layer": "fem.laminates.laminate",
    "Material": "fem.laminates.material",
    "ModelOptions": "fem.model",
    "SpecimenModel": "fem.model",
    "load_spec": "fem.spec",
    "parse_spec": "fem.spec",
    "Configuration": "fem.specimen",
    "Parameter": "fem.specimen",
    "Specimen": "fem.specimen",
}

__all__ = [
    "load_spec",
    "parse_spec",
    "SpecimenModel",
    "ModelOptions",
    "Specimen",
    "Configuration",
    "Layer",
    "Laminate",
    "Material",
    "Parameter",
    "Effect",
    "SwitchedOn",
    "effect",
    "register",
    "LayerIdError",
    "SpecError",
    "MeasurementError",
    "ModelError",
    "DesignError",
    "OptionsError",
]

__getattr__ = lazy_package(__name__, _HOMES)


def __dir__():
    return sorted(set(globals()) | set(__all__))
