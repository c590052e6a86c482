"""The fit's code for parameters the scatter does not determine (``Uncertainty.undetermined``)."""

import numpy as np
import pytest

from fem.solver.attachments import PointMass
from fem.specimen import Parameter
from identify.fitting.driver import fit
from identify.recordings.synthetic import synthetic_measurements
from studies.common import true_model

MASS = Parameter("mass", "point_mass")


@pytest.mark.parametrize("true_grams", [0.0, 3.0])
def test_a_mass_the_data_cannot_tell_from_none_is_coded_undetermined(true_grams):
    """A free sensor mass at a known point (120, 110) mm of the paper's plate: measured
    with no sensor there, the fitted mass's std is at least its value (its sensitivities
    vanish with it) and the code says undetermined while E1 of every identified material is
    determined; measured with a 3 g sensor, the mass comes back within 3 std and is
    determined.  Scatter 0.05 % of each frequency, 8 modes of each configuration."""
    x, y = 0.120, 0.110
    truth = true_model().with_options(modes=8)
    if true_grams:
        truth = truth.with_attachments([PointMass(true_grams * 1e-3, x, y, "point_mass")])
    data = synthetic_measurements(truth, modes=8, noise_rel=5e-4, seed=3, labels="close")
    start = true_model().with_options(modes=8).with_attachments([PointMass(1e-3, x, y, "point_mass")])
    materials = list(start.specimen.material_parameters())
    result = fit(start, data, parameters=materials + [MASS])
    coded = dict(zip(result.parameters, result.uncertainty.undetermined, strict=True))
    assert not any(coded[p] for p in result.parameters if p.kind == "E1")
    if true_grams:
        assert not coded[MASS]
        assert abs(result.value(MASS) - true_grams * 1e-3) < 3 * result.std(MASS)
        # The code reads the std as it stands: a known input's share (the budget's
        # covariance) that widens the mass's std to its value makes it undetermined.
        i = result.parameters.index(MASS)
        extra = np.zeros((len(result.parameters),) * 2)
        extra[i, i] = result.value(MASS) ** 2
        assert result.uncertainty.with_covariance(extra).undetermined[i]
    else:
        assert coded[MASS], (result.value(MASS), result.std(MASS))
        assert result.std(MASS) >= result.value(MASS)


@pytest.mark.parametrize("nu12", [0.0, 1e-10])
def test_a_parameter_held_at_zero_leaves_the_others_determined(paper_model, nu12):
    """nu12 held on its bound (0, or the 1e-10 real-like spruce plates' thin-plate fits ended
    at): (p / f) df/dp makes its column of the paper's relative sensitivity matrix zero, which
    made the matrix singular and every parameter's std void.  Its column is now scaled by
    its fit variable's unit (1 for nu12), and equals the plain derivative / f; the other
    columns keep the paper's scaling; the condition number is finite and E1's std is the
    linearised one of the same Jacobian, computed here independently."""
    from identify.engine.objective import Objective, relative_sensitivity
    from identify.engine.uncertainty import Uncertainty

    data = synthetic_measurements(paper_model, modes=5, noise_rel=5e-4, seed=3, labels="close")
    steel = [Parameter(kind, "steel") for kind in ("E1", "E2", "G12", "nu12")]
    objective = Objective(paper_model.with_values({steel[3]: nu12}), data, steel)
    values = np.array([objective.model.value(p) for p in steel])
    assert values[3] == nu12
    e = objective.evaluate(values, None)
    relative = relative_sensitivity(e, objective.space)
    np.testing.assert_allclose(relative[:, 3], e.derivatives[:, 3] / e.model_hz, rtol=1e-12)
    np.testing.assert_allclose(relative[:, :3], e.derivatives[:, :3] * values[:3] / e.model_hz[:, None])
    assert np.all(np.abs(relative[:, 3]) > 0)
    statistics = objective.statistics(e)
    uncertainty = Uncertainty.at(objective, e, statistics)
    assert np.isfinite(uncertainty.condition_number) and np.all(np.isfinite(uncertainty.std))
    jacobian = objective.jacobian(e)
    cov_z = statistics.noise_scale * np.linalg.inv(jacobian.T @ jacobian)
    assert uncertainty.std[0] == pytest.approx(values[0] * np.sqrt(cov_z[0, 0]), rel=1e-6)
