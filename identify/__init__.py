"""Identify the layers of a laminated plate from measured resonance frequencies.

The public API (each result has ``report()``, ``to_dict()`` and a notebook view)::

    import identify
    model = identify.load_spec("plate.toml")            # the spec, effects applied
    data = identify.load_measurements("measured.csv", model)
    identify.predict(model)                              # frequencies of every configuration
    result = identify.fit(model, data)                   # layer properties with std
    identify.compare(model, data)                        # where the model fails
    identify.diagnose(model, data)                       # which effect is missing

Values are SI inside (Pa, m, kg); reports and ``to_dict()`` use the spec's units
(GPa, mm, g).
"""
from fem.model import ModelOptions, SpecimenModel
from fem.spec import load_spec

from .compare import Comparison, compare
from .diagnose import Diagnosis, diagnose
from .fitting import fit
from .measurements import Measurements, load_measurements
from .predict import Prediction, predict
from .result import FitResult, FitStatus
from .statistics import FitStatistics
from .updating import FitOptions

__all__ = [
    "load_spec", "load_measurements", "predict", "fit", "compare", "diagnose",
    "SpecimenModel", "ModelOptions", "Measurements", "Prediction", "FitResult", "FitStatus", "FitStatistics",
    "FitOptions", "Comparison", "Diagnosis",
]
