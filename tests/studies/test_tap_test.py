"""The lab's chain on simulated recordings (studies.tap_test): recordings -> peaks -> fit."""

import numpy as np

from fem.specimen import Parameter
from studies import tap_test


def test_recordings_to_layers(tmp_path):
    """Every double hit rejected (one per configuration); the peaks' errors in their std
    as calibrated as 4 hits allow (identify.recordings.peaks: (f - truth) / std_hz follows
    Student's t with 3 degrees of freedom, which puts 5.8 % beyond 3: 1.3 of the 23 peaks
    expected, 5 or more in 1.2 % of sessions; this session has one, at 3.7, the stronger
    mode of the 0.35 % pair at 336 Hz); the fit from Table 6's start consistent with the
    scatter and every layer property within 3 reported std of Table 1.  Frequencies alone
    leave the merged pairs' assignment open, so the coatings' std is wide (several %) and
    says so: a flag on the parameters."""
    r = tap_test.run(tmp_path)
    assert r.rejected == 3
    z = []
    for name, true in r.true_hz.items():
        rows = r.peaks[r.peaks["configuration"] == name]
        nearest = np.min(np.abs(rows["frequency_hz"].to_numpy()[:, None] - true[None, :]), axis=1)
        z += list(nearest / rows["std_hz"].to_numpy())
    assert len(z) >= 20 and np.sum(np.array(z) > 3) <= 4 and max(z) < 10, np.round(z, 2)
    assert r.fit.finished and r.fit.statistics.consistent, r.fit.message
    assert max(abs(z) for z in r.z.values()) < 3, r.z
    i = r.fit.parameters.index(Parameter("E1", "bottom_coating"))
    assert r.fit.uncertainty.std[i] / r.fit.values[i] > 0.03
    assert any("twin" in f for f in r.fit.uncertainty.flags[i])
    assert (tmp_path / "summary.txt").exists() and (tmp_path / "peaks.csv").exists()
