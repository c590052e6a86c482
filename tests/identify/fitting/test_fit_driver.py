"""The fit driver's boundary: every argument of ``fit`` is honoured or refused with a
clear error (with effects too), and the stop reason is kept on the result and in the JSON."""

import pytest

from fem.errors import LayerIdError
from fem.spec import load_spec
from fem.specimen import Parameter
from identify import FitOptions, fit, load_measurements
from identify.engine.stopping import Stop
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED

STEEL = [Parameter(kind, "steel") for kind in ("E1", "E2", "G12")]


@pytest.fixture(scope="module")
def example():
    model = load_spec(COATED_PLATE)
    return model, load_measurements(COATED_PLATE_MEASURED, model)


def test_refuses_what_it_cannot_honour(example):
    model, data = example
    with pytest.raises(LayerIdError, match=r"effects = 'point_mass': give a list"):
        fit(model, data, "point_mass")
    with pytest.raises(LayerIdError, match=r"options = \{'max_iterations': 3\}: need a FitOptions"):
        fit(model, data, options={"max_iterations": 3})


def test_effects_honour_parameters_and_options(example):
    """With an effect, the baseline identifies exactly the ``parameters`` given, with the
    ``options`` given (one iteration: it cannot converge from the spec's start values),
    and the refit with the effect adds its parameters to them under the same options."""
    model, data = example
    result = fit(model, data, ["rotary_inertia"], parameters=STEEL, options=FitOptions(max_iterations=1))
    assert result.baseline.parameters == tuple(STEEL)
    assert result.baseline.iterations == 1 and result.baseline.stop is Stop.MAX_ITERATIONS
    assert result.parameters[: len(STEEL)] == tuple(STEEL)
    assert result.iterations <= 1


def test_stop_reason_on_the_result_and_in_the_json(example):
    model, data = example
    converged = fit(model, data)
    assert converged.converged and converged.stop.converged
    assert converged.to_dict()["stop_reason"] == converged.stop.code == converged.stop.name.lower()
    cut = fit(model, data, options=FitOptions(max_iterations=1))
    assert cut.to_dict()["stop_reason"] == "max_iterations" and cut.to_dict()["status"] == "not_converged"
