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
(GPa, mm, g).  The names are imported when first used, so that the command line
(``identify.cli``) starts without loading the whole fit and diagnosis.
"""

from fem.lazy import lazy_package

#: Public name -> the module that defines it.
_HOMES = {
    "load_spec": "fem.spec",
    "SpecimenModel": "fem.model",
    "ModelOptions": "fem.model",
    "load_measurements": "identify.measurements",
    "Measurements": "identify.measurements",
    "predict": "identify.predict",
    "Prediction": "identify.predict",
    "fit": "identify.fitting.driver",
    "FitOptions": "identify.engine.updating",
    "FitResult": "identify.engine.result",
    "FitStatus": "identify.engine.result",
    "FitStatistics": "identify.engine.statistics",
    "compare": "identify.diagnosis.compare",
    "Comparison": "identify.diagnosis.compare",
    "diagnose": "identify.diagnosis.diagnose",
    "Diagnosis": "identify.diagnosis.diagnose",
}

__all__ = [
    "load_spec",
    "load_measurements",
    "predict",
    "fit",
    "compare",
    "diagnose",
    "SpecimenModel",
    "ModelOptions",
    "Measurements",
    "Prediction",
    "FitResult",
    "FitStatus",
    "FitStatistics",
    "FitOptions",
    "Comparison",
    "Diagnosis",
]

__getattr__ = lazy_package(__name__, _HOMES)


def __dir__():
    return sorted(set(globals()) | set(__all__))
