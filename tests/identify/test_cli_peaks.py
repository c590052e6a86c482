"""identify-layers peaks: recordings in, the peak list out, and fit takes it."""

import json

import numpy as np
import pandas as pd

from fem.spec import load_spec
from identify.cli import main
from identify.examples import COATED_PLATE
from identify.measurements import load_measurements
from identify.recordings.tap_simulation import Modes, Session, write_csv

#: Three modes of a plate-like spectrum, a node of the third near the sensor.
MODES = Modes(np.array([129.2, 191.6, 238.8]), np.array([0.005, 0.006, 0.008]), np.array([1.0, -0.7, 0.4]))


def test_peaks_writes_the_peak_list_and_fit_reads_it(tmp_path, capsys):
    """Four hits, one a double hit: JSON with the peaks and the rejected hit; the CSV has
    exactly the contract's columns and loads as a peak list (no mode numbers)."""
    paths = []
    for i, hit in enumerate(Session(MODES, n_hits=4, seed=3, double_hits=(1,)).hits()):
        paths.append(tmp_path / f"hit{i + 1}.csv")
        write_csv(hit, paths[-1])
    out_csv = tmp_path / "peaks.csv"
    code = main(
        [
            "peaks",
            *map(str, paths),
            "--configuration",
            "brass_top",
            "--out",
            str(out_csv),
            "--json",
            "--report",
            str(tmp_path / "report"),
        ]
    )
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["configuration"] == "brass_top"
    found = [p["frequency_hz"] for p in data["peaks"]]
    np.testing.assert_allclose(found, MODES.frequencies_hz, rtol=2e-3)
    assert len(data["rejected"]) == 1 and "hit2" in data["rejected"][0]["source"]
    table = pd.read_csv(out_csv)
    assert list(table.columns) == ["configuration", "frequency_hz", "std_hz", "damping_ratio", "damping_std"]
    measurements = load_measurements(out_csv, load_spec(COATED_PLATE))
    assert not measurements.ranked and len(measurements) == 3
    assert (tmp_path / "report" / "frf.png").exists()


def test_unknown_configuration_with_a_spec_is_a_one_line_error(tmp_path, capsys):
    hit = Session(MODES, n_hits=1, seed=1).hits()[0]
    write_csv(hit, tmp_path / "hit.csv")
    code = main(
        ["peaks", str(tmp_path / "hit.csv"), "--configuration", "brass_tpo", "--spec", str(COATED_PLATE)]
    )
    err = capsys.readouterr().err
    assert code == 2 and "brass_tpo" in err and err.count("\n") == 1
