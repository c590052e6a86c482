"""The fit statistics, the score test of compare and the uncertainty flags, each against
numbers worked out by hand (fast unit tests: no model solves)."""

import math

import numpy as np
import pandas as pd
import pytest

from fem.laminates.laminate import Layer
from fem.laminates.material import Material
from fem.specimen import Configuration, Parameter, Specimen
from identify.engine.statistics import CHI2_WARNING, FitStatistics
from identify.engine.uncertainty import WEAK_REL_STD, parameter_flags
from identify.fitting.patterns import ScoreTest
from identify.measurements import Measurements


def measurements(frequencies, std=None) -> Measurements:
    n = len(frequencies)
    return Measurements(
        pd.DataFrame(
            {
                "configuration": ["original"] * n,
                "mode": np.arange(1, n + 1),
                "frequency_hz": frequencies,
                "std_hz": std if std is not None else np.nan,
                "label": [""] * n,
            }
        )
    )


def test_statistics_with_stated_scatter():
    """Residuals of 1, -2, 0.5, 1 std: chi^2 = 6.25, 2 parameters -> dof 2, reduced 3.125
    (below the warning level 4, so the covariance uses the stated scatter)."""
    measured = np.array([100.0, 200.0, 300.0, 400.0])
    std = np.array([0.1, 0.2, 0.3, 0.4])
    model = measured + std * np.array([1.0, -2.0, 0.5, 1.0])
    st = FitStatistics.of(model, measurements(measured, std), k=2)
    assert (st.n, st.k, st.dof) == (4, 2, 2)
    assert st.chi2 == pytest.approx(6.25) and st.reduced_chi2 == pytest.approx(3.125)
    assert st.noise_scale == 1.0 and not st.inflated and st.chi2_unit == 1.0
    assert st.bic == pytest.approx(6.25 + 2 * math.log(4))
    assert st.rms_rel_error == pytest.approx(math.sqrt(np.mean((std / measured * [1, -2, 0.5, 1]) ** 2)))


def test_statistics_inflate_when_the_misfit_exceeds_the_scatter():
    measured = np.array([100.0, 200.0, 300.0])
    std = np.full(3, 0.1)
    st = FitStatistics.of(measured + 0.5, measurements(measured, std), k=1)  # 5 std each: chi^2 75, dof 2
    assert st.reduced_chi2 == pytest.approx(37.5) and st.reduced_chi2 > CHI2_WARNING
    assert st.inflated and st.noise_scale == pytest.approx(37.5) and "inflated" in st.noise_source


def test_statistics_without_stated_scatter():
    """Relative errors 1e-3, -1e-3, 2e-3: RSS 6e-6; dof 1 -> residual variance 6e-6 is
    the chi^2 unit; there is no chi^2, and the BIC uses n ln(RSS/n)."""
    measured = np.array([100.0, 200.0, 400.0])
    model = measured * (1 + np.array([1e-3, -1e-3, 2e-3]))
    st = FitStatistics.of(model, measurements(measured), k=2)
    assert st.chi2 is None and not st.scatter_known
    assert st.sum_squares == pytest.approx(6e-6) and st.chi2_unit == pytest.approx(6e-6)
    assert st.noise_scale == pytest.approx(6e-6) and "estimated from the residual" in st.noise_source
    assert st.bic == pytest.approx(3 * math.log(2e-6) + 2 * math.log(3))
    assert math.isnan(FitStatistics.of(model, measurements(measured), k=3).reduced_chi2)


def test_score_test_explains_only_what_the_fit_cannot_absorb():
    """A residual exactly along a signature orthogonal to the Jacobian is fully explained
    (share 1, coefficient recovered); one inside the Jacobian's span is absorbed by the
    layer properties (share 0), however well the signature alone would fit it."""
    rng = np.random.default_rng(0)
    jacobian = rng.standard_normal((12, 3))
    q = np.linalg.qr(jacobian)[0]
    signature = rng.standard_normal(12)
    signature -= q @ (q.T @ signature)  # orthogonal to the Jacobian
    weight = np.ones(12)
    share, coef = ScoreTest(0.3 * signature, weight, jacobian)(signature[:, None])
    assert share == pytest.approx(1.0) and coef[0] == pytest.approx(0.3)
    inside = jacobian @ np.array([1.0, -2.0, 0.5])
    share, _ = ScoreTest(inside, weight, jacobian)(inside[:, None])
    assert share == pytest.approx(0.0, abs=1e-20)
    share, _ = ScoreTest(inside, weight, None)(inside[:, None])  # without the fit: all of it
    assert share == pytest.approx(1.0)


@pytest.fixture(scope="module")
def plate():
    steel = Material("steel", 200e9, 200e9, 77e9, 0.3, 7850, identify=True)
    return Specimen("plate", 0.1, 0.1, (Layer(steel, 1e-3, 0.0, "layer1"),), (Configuration("original"),))


@pytest.mark.parametrize(
    "kind,value,std,expected",
    [
        ("E1", 200e9, 1e9, ()),
        ("E1", 200e9, (WEAK_REL_STD + 0.01) * 200e9, ("weakly identifiable",)),
        ("E1", 200e9, math.inf, ("not identifiable",)),
        ("nu12", 0.3, 0.01, ()),
        ("nu12", 0.3, 0.05, ("weakly identifiable",)),  # std above 0.1 x 0.3, nu's usual size
        ("nu12", 0.995, 0.01, ("at bound (nu12^2 -> E1/E2)",)),  # 0.99 > 0.98 x E1/E2 = 0.98
    ],
)
def test_uncertainty_flags(plate, kind, value, std, expected):
    assert parameter_flags(Parameter(kind, "steel"), value, std, plate) == expected
