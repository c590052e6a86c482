"""Layer loss factors from modal damping: the paper's plate with damping coatings
(studies.damping), one plate alone, a misfit the layers cannot explain, the outputs and
the Oberst beam against ASTM E756."""

import json

import numpy as np
import pandas as pd
import pytest

from fem.errors import MeasurementError
from fem.io import to_json
from identify.fitting.damping import identify_damping
from identify.measurements import Measurements, parse_measurements
from identify.reporting.report import parameter_table, report_text
from studies import damping as study


@pytest.fixture(scope="module")
def fitted():
    """One stiffness and damping identification of the study's simulated data."""
    from identify.fitting.driver import fit

    return fit(study.start(), study.simulate(seed=3))


def test_every_loss_factor_within_3_std(fitted):
    d = fitted.damping
    assert fitted.converged and d.status == "converged" and d.verdict == "good"
    assert d.method == "first_order", "coatings at 0.02-0.05: first order is within the scatter"
    z = (d.values - study.true_values(d.targets)) / d.std
    assert np.all(np.abs(z) < 3), z
    assert len(d.targets) == 7


def test_reported_std_is_the_observed_scatter(fitted):
    """60 damping draws (3 %) at the fitted stiffness: the mean reported std is 0.8-1.25 of
    the observed scatter of every loss factor (sampling error of a std from 60 draws: 9 %),
    and the estimates are unbiased to within 0.5 std."""
    rep = study.repeats(fitted, draws=60)
    assert np.all((rep.ratio > 0.8) & (rep.ratio < 1.25)), rep.ratio
    assert np.all(np.abs(rep.mean_error) < 0.5), rep.mean_error


def test_one_plate_alone_is_not_identifiable(fitted):
    """The original plate alone: seven loss factors of three layers cannot be told apart.
    No values, no error bars, never a silent fit."""
    model = fitted.model.with_configurations([fitted.specimen.configuration("original")])
    table = fitted.measurements.table
    alone = Measurements(table[table["configuration"] == "original"].reset_index(drop=True), "<original>")
    d = identify_damping(model, alone)
    assert d.status == "not_identifiable" and "not identifiable" in d.message
    assert np.isnan(d.values).all() and np.isnan(d.std).all()
    document = d.to_dict()
    assert all(p["value"] is None and p["std"] is None for p in document["parameters"])
    json.dumps(document, allow_nan=False)


def test_extra_damping_is_a_poor_fit(fitted):
    """Air damping falling with frequency (zeta += 0.1 Hz / f: 0.08 % at the first mode,
    0.007 % at the highest) that the layers' loss factors cannot explain: poor_fit.  (A
    floor equal on every mode is not caught: the layer that stores most energy absorbs it
    -- docs/damping.md says so.)"""
    table = fitted.measurements.table.copy()
    table["damping_ratio"] += 0.1 / table["frequency_hz"]
    d = identify_damping(fitted.model, Measurements(table, "<air>"), fitted.pairings)
    assert d.status == "poor_fit" and d.p_value < 1e-3


def test_no_damping_measured(fitted):
    table = fitted.measurements.table.assign(damping_ratio=np.nan, damping_std=np.nan)
    d = identify_damping(fitted.model, Measurements(table, "<none>"), fitted.pairings)
    assert d.status == "not_identifiable" and "damping_ratio" in d.message


def test_outputs(fitted):
    """Fit JSON: eta_* under each material with their std in the same table, the known
    materials' loss factors, the damping block; parameters.csv rows; the text section."""
    document = json.loads(to_json(fitted.to_dict()))
    coating = document["materials"]["top_coating"]
    assert {"eta_E1", "eta_E2", "eta_G12", "E1_GPa"} <= set(coating) and coating["std"]["eta_G12"] > 0
    steel = document["materials"]["steel"]
    assert steel["eta_E1"] == steel["eta_E2"] == steel["eta_G12"] and "shared eta" in steel["flags"]["eta_E1"]
    assert document["materials"]["brass"]["eta_E1"] == 0.001
    block = document["damping"]
    assert block["status"] == "converged" and block["condition_number"] > 1 and block["rms_rel_error"] > 0
    assert {"configuration", "mode", "measured_damping_ratio", "model_damping_ratio"} <= set(
        block["residuals"][0]
    )
    rows = parameter_table(fitted)
    assert "top_coating.eta_G12" in set(rows["parameter"])
    assert "== damping: converged" in report_text(fitted)


def test_damping_std_column_validated(example_spec):
    frame = pd.DataFrame(
        {
            "configuration": ["original"] * 2,
            "mode": [1, 2],
            "frequency_hz": [129.0, 190.0],
            "damping_ratio": [0.01, np.nan],
            "damping_std": [-1e-4, 1e-4],
        }
    )
    with pytest.raises(MeasurementError, match="line 2: damping_std = -0.0001"):
        parse_measurements(frame, example_spec)
    frame.loc[0, "damping_std"] = 1e-4
    with pytest.raises(MeasurementError, match="line 3: damping_std = 0.0001 without a damping_ratio"):
        parse_measurements(frame, example_spec)
    frame.loc[1, "damping_ratio"] = 0.0
    with pytest.raises(MeasurementError, match="damping_ratio = 0.0"):
        parse_measurements(frame, example_spec)


def test_oberst_beam_against_astm_e756():
    """A steel strip with one coating (eta 0.3, a free layer): E756's closed form from the
    composite loss factors, and this tool, give the coating's loss factor.  E756 is exact
    for Euler-Bernoulli beams with an undamped base; the strip's plate model with equal
    Poisson ratios follows it to 0.1 % (the tolerance).  The tool is refined on the
    complex eigenproblem (eta 0.3) and lands within 0.1 % too, well inside its 3 % scatter."""
    strip = study.oberst()
    assert strip.closed_form == pytest.approx(np.full(3, strip.truth), rel=1e-3)
    assert strip.tool == pytest.approx(strip.truth, rel=1e-3)
    assert abs(strip.tool - strip.truth) < 3 * strip.tool_std


def test_without_damping_std_the_assumed_scatter(fitted):
    """No damping_std: 3 % of each damping ratio is assumed (the data's own scatter here),
    so the std match the stated case's to the misfit's scaling (chi^2 / dof <= 1.3 here);
    with 3x the noise the std are scaled up by the misfit and the fit is a poor one."""
    table = fitted.measurements.table
    stated = fitted.damping
    d = identify_damping(
        fitted.model, Measurements(table.assign(damping_std=np.nan), "<no std>"), fitted.pairings
    )
    assert not d.scatter_stated and "assumed 3 %" in d.to_dict()["scatter"]
    assert d.std == pytest.approx(stated.std, rel=0.15)
    rng = np.random.default_rng(5)
    noisy = table.assign(
        damping_std=np.nan,
        damping_ratio=table["damping_ratio"] * (1 + 0.09 * rng.standard_normal(len(table))),
    )
    d = identify_damping(fitted.model, Measurements(noisy, "<noisy>"), fitted.pairings)
    assert d.status == "poor_fit" and any("scaled by the misfit" in n for n in d.notes)
    assert np.mean(d.std / stated.std) > 1.5


def test_report_folder_has_the_damping_table_and_figure(fitted, tmp_path):
    from identify.reporting.report import write_report

    folder = write_report(fitted, tmp_path / "report")
    page = (folder / "report.html").read_text()
    assert "Damping" in page and "damping.png" not in page, "figures are embedded, not linked"
    assert (folder / "damping.png").stat().st_size > 1000
    table = pd.read_csv(folder / "damping.csv")
    assert len(table) == 30 and table["model_damping_ratio"].notna().all()
    assert "top_coating.eta_E1" in (folder / "parameters.csv").read_text()
