"""The tap chain with damping (studies.damping.tap_chain): simulated recordings of the
paper's plate with damping coatings -> peaks -> fit of the peak lists -> the layers' loss
factors, each within 3 reported std of the truth.  The damping status may be poor_fit:
peaks' damping_std of overlapping close modes (0.1-1 %) is below their estimation error
(2-6 %), which the chi^2 test then reports; the values are what is asserted."""

import numpy as np

from studies.damping import tap_chain


def test_tap_chain_recovers_the_loss_factors(tmp_path):
    chain = tap_chain(tmp_path)
    assert chain.result.converged
    d = chain.result.damping
    assert d.status in ("converged", "poor_fit") and np.isfinite(d.values).all()
    assert np.all(np.abs(chain.z) < 3), chain.z
    assert {"damping_ratio", "damping_std"} <= set(chain.peaks.columns)
    assert (chain.peaks["damping_std"] > 0).all()
