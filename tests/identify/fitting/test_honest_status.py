"""Results never claim more than the data show: a misfit the scatter cannot
explain is a poor fit with its likely cause, never 'converged', and exits non-zero."""

import json

import numpy as np
import pandas as pd
import pytest

from fem.specimen import Parameter
from identify.cli import main
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED
from identify.fitting.driver import fit
from identify.measurements import parse_measurements
from identify.recordings.synthetic import synthetic_measurements

GOOD = pd.read_csv(COATED_PLATE_MEASURED, comment="#")


def fit_cli(capsys, tmp_path, frame) -> tuple[int, dict]:
    path = tmp_path / "data.csv"
    frame.to_csv(path, index=False)
    code = main(["fit", str(COATED_PLATE), str(path), "--json"])
    return code, json.loads(capsys.readouterr().out)


def test_frequencies_in_the_wrong_unit(capsys, tmp_path):
    """x 1000 (kHz read as Hz): the moduli run to their 2000 GPa bound and cannot follow;
    the cause named is the units, with the factor."""
    code, out = fit_cli(
        capsys, tmp_path, GOOD.assign(frequency_hz=1000 * GOOD.frequency_hz, std_hz=1000 * GOOD.std_hz)
    )
    assert code == 1 and out["status"] == "poor_fit" and not out["converged"]
    assert out["causes"][0]["cause"] == "units" and "x the model's" in out["causes"][0]["text"]


def test_configurations_mixed_up(capsys, tmp_path):
    mixed = GOOD.assign(
        configuration=GOOD.configuration.replace({"original": "brass_top", "brass_top": "original"})
    )
    code, out = fit_cli(capsys, tmp_path, mixed)
    assert code == 1 and out["status"] == "poor_fit"
    cause = out["causes"][0]
    assert (
        cause["cause"] == "configurations"
        and "'original'" in cause["text"]
        and "'brass_top'" in cause["text"]
    )


def test_random_frequencies(capsys, tmp_path):
    """Uniform random frequencies, sorted per configuration: never converged."""
    rng = np.random.default_rng(1)
    random = GOOD.assign(frequency_hz=np.sort(rng.uniform(100, 800, (3, 5)), axis=1).ravel(), label="")
    code, out = fit_cli(capsys, tmp_path, random)
    assert code == 1 and out["status"] in ("poor_fit", "not_converged") and out["causes"]


def test_another_plates_data(example_spec, capsys, tmp_path):
    """Frequencies of a 200 x 120 mm plate with a 1.5 mm aluminium core (same
    configurations) fitted to this spec: a poor fit, not converged on wrong layers."""
    import copy
    import tomllib

    from fem.spec import parse_spec

    data = tomllib.loads(COATED_PLATE.read_text())
    other = copy.deepcopy(data)
    other["specimen"].update(length_mm=200.0, width_mm=120.0)
    other["specimen"]["layers"][1]["thickness_mm"] = 1.5
    other["materials"]["steel"].update(
        E1_GPa=70.0, E2_GPa=70.0, G12_GPa=26.3, nu12=0.33, density_kg_m3=2700.0
    )
    frame = synthetic_measurements(parse_spec(other), noise_rel=5e-4, seed=3).table.drop(
        columns="damping_ratio"
    )
    code, out = fit_cli(capsys, tmp_path, frame)
    assert code == 1 and out["status"] == "poor_fit" and out["causes"]


def test_without_std_no_chi2_is_printed_and_the_assumed_scatter_judges(example_spec):
    """No std_hz: a 2 % error everywhere is far beyond the assumed 0.1 % scatter, so it is
    a poor fit; the report states the misfit against that assumed scatter and prints no
    'reduced chi^2' (there is no stated scatter to take it against)."""
    frame = GOOD.drop(columns=["std_hz"]).assign(
        frequency_hz=GOOD.frequency_hz * np.tile([1.02, 0.98, 1.0, 1.02, 1.02], 3)
    )
    result = fit(example_spec, parse_measurements(frame, example_spec))
    assert result.status.value == "poor_fit"
    text = result.report()
    assert "reduced chi^2" not in text and "assumed 0.1 %" in text


def test_converged_means_consistent(example_spec):
    """The bundled data (0.05 % stated scatter) are consistent: converged, p-value above
    the 0.001 level."""
    from identify.measurements import load_measurements

    result = fit(example_spec, load_measurements(COATED_PLATE_MEASURED, example_spec))
    assert result.converged and result.statistics.consistent and result.statistics.p_value > 0.01


def test_a_bound_holds_and_is_flagged(example_spec, paper_model):
    """nu12 of steel bounded to 0..0.25 while the truth is 0.29: the estimate sits on the
    bound, is flagged so, and the misfit shows it; a start outside the bounds begins at the
    bound with a note."""
    import copy
    import tomllib

    from fem.spec import parse_spec

    data = tomllib.loads(COATED_PLATE.read_text())
    bounded = copy.deepcopy(data)
    bounded["materials"]["steel"]["bounds"] = {"nu12": [0.0, 0.25]}
    model = parse_spec(bounded).with_values({Parameter("nu12", "steel"): 0.27})
    result = fit(model, synthetic_measurements(paper_model, noise_rel=5e-4, seed=2, labels="close"))
    assert result.value(Parameter("nu12", "steel")) == pytest.approx(0.25)
    flags = result.uncertainty.flags[result.parameters.index(Parameter("nu12", "steel"))]
    assert any(f.startswith("at bound (nu12 = 0.25") for f in flags)
    assert any("outside its bounds" in w for w in result.warnings)


def test_peak_list_without_a_spare_frequency_is_not_identifiable(capsys, tmp_path):
    """A bare peak list of as many peaks as unknowns (12 of the bundled data's 15, mode
    numbers dropped): the fit picks the pairing and every pairing fits exactly, so nothing
    tests it: not identifiable, exit 1, never 'converged'.  With one peak more it is the
    usual fit again (the test is not vacuous)."""
    peaks = GOOD.drop(columns=[c for c in ("mode", "label") if c in GOOD.columns])
    twelve = peaks.drop(index=[4, 9, 14])
    code, out = fit_cli(capsys, tmp_path, twelve)
    assert code == 1 and out["status"] == "not_identifiable" and not out["converged"], out["status"]
    code, out = fit_cli(capsys, tmp_path, peaks.drop(index=[4, 9]))
    assert code == 0 and out["status"] == "converged"
