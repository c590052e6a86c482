"""The shared physics core: laminate theory, plate elements, free-free modal solves,
exact frequency sensitivities and physical effects.

``load_spec(path)`` reads a spec file into a ``SpecimenModel``: the specimen with its
fixed effects switched on, the model options and the validated ``[design]`` table.
Every command and API function takes that object.  Inside, all quantities are SI
(Pa, m, kg); results print in the spec's units (GPa, mm, g).
"""
from .effects import Effect, SwitchedOn, effect, register
from .errors import DesignError, LayerIdError, MeasurementError, ModelError, OptionsError, SpecError
from .laminate import Laminate, Layer
from .material import Material
from .model import ModelOptions, SpecimenModel
from .spec import load_spec, parse_spec
from .specimen import Configuration, Parameter, Specimen

__all__ = [
    "load_spec", "parse_spec", "SpecimenModel", "ModelOptions", "Specimen", "Configuration", "Layer", "Laminate",
    "Material", "Parameter", "Effect", "SwitchedOn", "effect", "register",
    "LayerIdError", "SpecError", "MeasurementError", "ModelError", "DesignError", "OptionsError",
]
