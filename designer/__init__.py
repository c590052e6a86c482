"""Test planning: which known plates to bond where, scored by the conditioning of the
global sensitivity matrix (seed paper sections 4.1, 4.3, 4.6).

The public API takes the model a spec file loads into (``fem.load_spec``)::

    import designer, fem
    model = fem.load_spec("plate.toml")
    designer.check(model)        # is the spec's own set identifiable? (.test_sheet: how to test it)
    result = designer.recommend(model)    # the best sets of added plates from its [design] space
    designer.write_spec(designer.Problem.of(model), result.best, "plan.toml")
    designer.sweep(model, ["thickness=0.5:3:6", "material"])

``fem.design_space`` reads the [design] table, ``candidates`` builds the configurations,
``problem`` solves them once each (at the prior's points too: ``robust``),
``scoring``/``design`` score a set, ``search`` recommends sets (exhaustive or
``relaxation``; ``mirror`` collapses mirror designs), ``refine`` tunes thicknesses to
stock, ``check`` and ``sweep`` judge and explore the spec's own design, ``sheet`` says
how to carry out the test, ``spec_file`` writes a design as a spec; ``cli`` is plan-tests.
The names are imported when first used, so that ``plan-tests --help`` starts without
loading the planner.
"""

from fem.lazy import lazy_package

#: Public name -> the module that defines it.
_HOMES = {
    "CheckResult": "designer.check",
    "check": "designer.check",
    "Problem": "designer.problem",
    "refine": "designer.search.refine",
    "Recommendation": "designer.search.ranking",
    "recommend": "designer.search.ranking",
    "TestSheet": "designer.sheet",
    "write_spec": "designer.spec_file",
    "SweepResult": "designer.sweep",
    "sweep": "designer.sweep",
}

__all__ = [
    "check",
    "recommend",
    "sweep",
    "refine",
    "write_spec",
    "Problem",
    "CheckResult",
    "Recommendation",
    "SweepResult",
    "TestSheet",
]

__getattr__ = lazy_package(__name__, _HOMES)


def __dir__():
    return sorted(set(globals()) | set(__all__))
