"""A diagnosis of a peak list (no mode numbers, a mode missing, a spurious peak) judges
every candidate on the peaks the baseline matched, so that a model containing the
baseline can only descend from it, and matches the peaks again once, in the final
refit."""

import importlib
import tomllib

import pandas as pd
import pytest

from fem.spec import parse_spec
from identify.diagnosis.diagnose import diagnose
from identify.engine.updating import Settle
from identify.fitting import driver
from identify.fitting.driver import fit
from identify.measurements import parse_measurements
from identify.recordings.synthetic import synthetic_measurements

from ...walk import SPEC

# the module (the package exports its function)
diagnosis = importlib.import_module("identify.diagnosis.diagnose")

#: The truth the peaks come from: the walk plate with a 6 g sensor the spec leaves out.
SENSOR = {"kind": "point_mass", "mass_g": 6.0, "x_mm": 120.0, "y_mm": 95.0}


@pytest.fixture(scope="module")
def sensor_peaks():
    """Six modes of the plate with the sensor at 0.02 % scatter, without mode numbers, its
    fourth mode missing and a spurious peak (a suspension bounce at 9 Hz) added."""
    spec = tomllib.loads(SPEC)
    model = parse_spec(spec)
    truth = parse_spec({**spec, "effects": [SENSOR]})
    table = synthetic_measurements(truth, modes=6, noise_rel=2e-4, seed=4).table
    kept = table[table["mode"] != 4][["configuration", "frequency_hz", "std_hz"]]
    bounce = pd.DataFrame(
        {"configuration": [kept["configuration"].iloc[0]], "frequency_hz": [9.0], "std_hz": [0.01]}
    )
    peaks = parse_measurements(pd.concat([kept, bounce], ignore_index=True), model)
    assert not peaks.ranked
    return model, peaks


def test_candidates_are_judged_on_the_baselines_peaks_and_descend(sensor_peaks):
    """Every refitted candidate's misfit is over the peaks the baseline matched (the same
    count), and none ends above the baseline: each contains it (the effect at zero).  The
    selection finds the sensor; the final refit matches the peak list again, accounts for
    every peak and leaves the spurious one out."""
    model, peaks = sensor_peaks
    result = diagnose(model, peaks, ["point_mass", "suspension", "rotary_inertia"])
    base = result.baseline.statistics
    refitted = [c for step in result.steps for c in step.candidates if c.fit is not None]
    assert refitted
    first = [c for c in result.steps[0].candidates if c.fit is not None]
    assert all(c.fit.statistics.n == base.n for c in first), [(c.kind, c.fit.statistics.n) for c in first]
    assert all(c.fit.statistics.sum_squares <= base.sum_squares for c in first), [
        (c.kind, c.fit.statistics.sum_squares, base.sum_squares) for c in first
    ]
    assert result.above_start == ()
    assert [c.kind for c in result.selected][:1] == ["point_mass"]
    final = result.final
    assert final.peaks is not None and len(final.peaks.modes) == len(peaks)
    assert 9.0 not in final.measurements.table["frequency_hz"].tolist()
    assert final.converged, final.message
    mass = next(p for p in final.parameters if p.kind == "mass")
    # Within 3 std: ten peaks for seven unknowns leave the mass's std at about 13 %.
    assert abs(final.value(mass) - 6e-3) < 3 * final.std(mass)


def test_fit_with_an_effect_rematches_the_peak_list_once(sensor_peaks):
    """``fit --effect point_mass`` on a peak list: the effect is refitted on the baseline's
    matched peaks, then the whole peak list is matched again at the solution: the result
    accounts for every peak and its baseline is the peak-list fit."""
    model, peaks = sensor_peaks
    result = fit(model, peaks, ["point_mass"])
    assert result.peaks is not None and len(result.peaks.modes) == len(peaks)
    assert result.baseline.peaks is not None
    assert result.statistics.sum_squares < result.baseline.statistics.sum_squares
    mass = next(p for p in result.parameters if p.kind == "mass")
    assert abs(result.value(mass) - 6e-3) < 3 * result.std(mass)


def test_held_properties_are_freed_only_in_the_final_refit_of_a_peak_list(sensor_peaks, monkeypatch):
    """On a peak list the properties the thin-plate fit held stay held through the rounds
    and are freed in the final refit (``released`` with the full pairing check); with
    ranked data they are freed as each effect is chosen (``Settle.QUICK``)."""
    model, peaks = sensor_peaks
    calls = []
    released = driver.released

    def recording(result, measurements, *args, settle=Settle.FULL, **kwargs):
        calls.append((measurements.ranked, settle))
        return released(result, measurements, *args, settle=settle, **kwargs)

    monkeypatch.setattr(driver, "released", recording)
    diagnosis.diagnose(model, peaks, ["point_mass"])
    assert calls == [(False, Settle.FULL)]
    calls.clear()
    ranked = diagnosis.diagnose(
        model, diagnosis.diagnose(model, peaks, ["point_mass"]).final.measurements, ["point_mass"]
    )
    assert ranked.selected and (True, Settle.QUICK) in calls


def test_two_worker_processes_give_the_serial_diagnosis(sensor_peaks):
    """With a pool (``workers=2``, as the command line runs a diagnosis) the candidates'
    pre-checks, the point mass's linearised start ranking and the refits run in worker
    processes: the same computations, so the same selection, steps and final values as the
    serial diagnosis, to the last bit (one BLAS thread everywhere, the solver's start vector
    seeded)."""
    model, peaks = sensor_peaks
    kinds = ["point_mass", "suspension", "rotary_inertia"]
    serial = diagnose(model, peaks, kinds, workers=1)
    pooled = diagnose(model, peaks, kinds, workers=2)
    assert [c.kind for c in pooled.selected] == [c.kind for c in serial.selected] == ["point_mass"]
    assert [s.reason for s in pooled.steps] == [s.reason for s in serial.steps]
    assert pooled.final.parameters == serial.final.parameters
    assert pooled.final.values.tolist() == serial.final.values.tolist()
    assert pooled.final.statistics.sum_squares == serial.final.statistics.sum_squares
