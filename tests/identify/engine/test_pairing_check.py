"""The pairing is checked at the solution: a pair the start has the wrong way
round, and mode labels copied from predict."""

import copy
import tomllib

import numpy as np

from fem.spec import parse_spec
from fem.specimen import Parameter
from identify.examples import COATED_PLATE
from identify.fitting.driver import fit
from identify.predict import predict
from identify.recordings.synthetic import synthetic_measurements
from tests.conftest import table1_values


def narrow_plate():
    """The paper's plate 150 x 140 mm (Table 6 start) and its truth with steel E1 = 300,
    E2 = 150 GPa: the original plate's (1,2) then lies 1.3 % below (2,1), while the start
    has (2,1) 5 % below (1,2)."""
    data = tomllib.loads(COATED_PLATE.read_text())
    narrow = copy.deepcopy(data)
    narrow["specimen"]["width_mm"] = 140.0
    start = parse_spec(narrow)
    truth = start.with_values(
        {**table1_values(), Parameter("E1", "steel"): 300e9, Parameter("E2", "steel"): 150e9}
    )
    return start, truth


def test_a_pair_the_start_has_the_wrong_way_round():
    """Ranked, unlabelled, noise-free data: rank pairing at the start puts the measured
    (1,2) on the start's (2,1).  The pair is 1.3 % apart, beyond the 1 % of a 'close pair'
    (the CFRP case of the issue): the check at the solution re-pairs it, the fit reaches
    the truth to 1e-4 and its message says it re-paired."""
    start, truth = narrow_plate()
    assert start.solve("original").labels[3:5] == ("(2,1)", "(1,2)")
    assert truth.solve("original").labels[3:5] == ("(1,2)", "(2,1)")
    result = fit(start, synthetic_measurements(truth, modes=5))
    assert result.converged, result.message
    errors = [abs(v / truth.value(p) - 1) for p, v in zip(result.parameters, result.values)]
    assert max(errors) < 1e-4
    assert "re-paired" in result.message


def test_labels_copied_from_predict_pair_the_right_modes(example_spec, paper_model):
    """A lab copies predict's labels of the close pairs; the fit solves on another mesh
    (the default for 5 modes + 3) and still pairs them by shape: noise-free data labelled
    from a 20 x 20 mesh's predict reach the truth (1e-4) and the labelled rows keep their
    labelled partners."""
    fine = paper_model.with_options(divisions=20)
    labels = predict(fine).labels
    data = synthetic_measurements(fine, modes=5)
    table = data.table.copy()
    for name in ("original", "brass_bottom", "brass_top"):
        rows = table.index[table["configuration"] == name][3:5]
        table.loc[rows, "label"] = [labels[name][3], labels[name][4]]
    from identify.measurements import Measurements

    result = fit(example_spec, Measurements(table, "<labelled>"))
    assert result.converged
    errors = [abs(v / paper_model.value(p) - 1) for p, v in zip(result.parameters, result.values)]
    # The 20 x 20 data differ from the fit's mesh by up to 0.006 % in frequency; the
    # condition number (35) amplifies that to at most ~0.2 % in the parameters.
    assert max(errors) < 2e-3
    for name, pairing in result.pairings.items():
        solution = result.model.with_options(modes=8).solve(name)
        assert [solution.labels[i] for i in pairing.indices[3:5]] == [labels[name][3], labels[name][4]]
    assert np.isfinite(result.uncertainty.std).all()
