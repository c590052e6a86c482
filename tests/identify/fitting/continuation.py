"""The shear continuation with the misfit of each of its steps recorded (for the tests
that it only descends)."""

from unittest import mock

from identify.fitting import driver


def continuation_steps(context, model, shear, factor: float, parameters):
    """``driver.shear_continuation`` from the thin-plate limit ``model`` (its ``shear``
    moduli at ``factor`` x G12): (the model it ends at, the factor reached, the misfit
    (weighted sum of squares) of each step kept; the last step tried is dropped where it
    did not descend, as the continuation drops it)."""
    misfits = []
    fit_layers = driver.fit_layers

    def recording(*args, **kwargs):
        result = fit_layers(*args, **kwargs)
        misfits.append(result.statistics.sum_squares)
        return result

    with mock.patch.object(driver, "fit_layers", recording):
        limit = driver._at_fixed_shear(context, model, shear, parameters)
        model, reached = driver.shear_continuation(context, limit, shear, factor, parameters)
    kept = misfits[:-1] if len(misfits) > 1 and misfits[-1] >= misfits[-2] else misfits
    return model, reached, kept
