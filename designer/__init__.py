"""Test planning: which known plates to bond where, scored by the conditioning of the
global sensitivity matrix (seed paper sections 4.1, 4.3, 4.6).

The public API takes the model a spec file loads into (``fem.load_spec``)::

    import designer, fem
    model = fem.load_spec("plate.toml")
    designer.check(model)        # is the spec's own set identifiable?
    designer.recommend(model)    # the best sets of added plates from its [design] space
    designer.sweep(model, ["thickness=0.5:3:6", "material"])

``fem.design_space`` reads the [design] table, ``candidates`` builds the configurations,
``problem`` solves them once each, ``scoring``/``design`` score a set, ``search``
recommends sets (exhaustive or ``relaxation``), ``refine`` tunes thicknesses,
``check`` and ``sweep`` judge and explore the spec's own design; ``cli`` is plan-tests.
"""
from .check import CheckResult, check
from .problem import Problem
from .refine import refine
from .search import Recommendation, recommend
from .sweep import SweepResult, sweep

__all__ = ["check", "recommend", "sweep", "refine", "Problem", "CheckResult", "Recommendation", "SweepResult"]
