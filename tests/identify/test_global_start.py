"""The global stage before the local fit (``identify.fitting.global_start``): its starts are
reproducible and inside every property's bounds, and it does nothing when the local fit
is already below ``GLOBAL_FROM``."""
import math

from identify.diagnosis.compare import compare
from identify.fitting.global_start import GLOBAL_FROM, SPREAD, STARTS, global_fit, starts
from identify.recordings.synthetic import synthetic_measurements
from studies.common import start_model, true_model


def test_starts_are_seeded_spread_and_inside_the_bounds():
    model = start_model()
    parameters = model.specimen.material_parameters()
    first, again = starts(model, parameters), starts(model, parameters)
    assert first == again and len(first) == STARTS
    for values in first:
        for p, v in values.items():
            low, high = model.specimen.materials[p.target].bound(p.kind)
            assert low <= v <= high, (p, v)
            if p.kind != "nu12":
                assert abs(math.log(v / model.value(p))) <= math.log(SPREAD) + 1e-12
    # a Latin hypercube: every parameter's factors spread over the whole range
    for p in parameters:
        if p.kind != "nu12":
            logs = sorted(math.log(values[p] / model.value(p)) for values in first)
            assert logs[0] < -0.5 * math.log(SPREAD) and logs[-1] > 0.5 * math.log(SPREAD)


def test_no_global_stage_below_the_threshold():
    """The bundled plate from Table 6's starts, nothing missing: the local fit is at the
    noise level, far below GLOBAL_FROM; the global stage returns it unchanged."""
    truth = true_model().with_options(modes=6)
    data = synthetic_measurements(truth, modes=6, noise_rel=5e-4, seed=2, labels="close")
    local = compare(start_model().with_options(modes=6), data).fitted
    assert local.rms_rel_error < GLOBAL_FROM
    result, note = global_fit(start_model().with_options(modes=6), data, local)
    assert result is local and note == ""
