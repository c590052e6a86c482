"""The local pole-residue fit behind every peak: its exact (variable-projection)
Jacobian against central differences, and exact poles recovered from a noise-free FRF
of two close modes with a neighbour outside the window."""

import numpy as np

from identify.recordings.peaks import _Projection, local_fit
from identify.recordings.tap_simulation import Modes

MODES = Modes([100.0, 104.0, 120.0], [0.01, 0.008, 0.01], [1.0, -0.5, 0.7])


def _pole(f, zeta):
    w, zeta = 2 * np.pi * np.asarray(f), np.asarray(zeta)
    return -zeta * w + 1j * w * np.sqrt(1 - zeta**2)


def test_jacobian_matches_central_differences():
    """Two noisy records of one FRF at once (the per-hit fits' batch), poles off their
    optimum (so the residual term of the Jacobian counts): each record's Jacobian block
    agrees with central differences of its own residual to 1e-6 of the largest entry
    (central differences with step 1e-6 are good to about 1e-9 here), and a record's
    residual does not move with the other's parameters."""
    f = np.arange(90, 115, 0.25)
    rng = np.random.default_rng(0)
    h = MODES.accelerance(f) + 1e-3 * (
        rng.standard_normal((2, len(f))) + 1j * rng.standard_normal((2, len(f)))
    )
    problem = _Projection(f, h, _pole([100.3, 103.8], [0.011, 0.009]), _pole([120.0], [0.01]))
    x = np.array([[0.3, 0.1, -0.2, -0.05], [-0.1, 0.2, 0.1, 0.05]])
    step = 1e-6
    jacobian = problem.jacobian(x)
    for j in range(2):
        moved = [
            (problem.residual(x + step * e) - problem.residual(x - step * e)) / (2 * step)
            for e in (np.eye(8)[k].reshape(2, 4) for k in range(8))
        ]
        numeric = np.column_stack([m[j] for m in moved[4 * j : 4 * j + 4]])
        assert np.abs(jacobian[j] - numeric).max() < 1e-6 * np.abs(numeric).max()
        other = np.column_stack([m[j] for m in moved[4 * (1 - j) : 4 * (1 - j) + 4]])
        assert np.abs(other).max() == 0.0


def test_noise_free_poles_are_exact():
    """The accelerance A s^2 / (s^2 + 2 zeta w s + w^2) has poles -zeta w +- i w sqrt(1 -
    zeta^2); its s^2 numerator is a residue plus a smooth remainder the model's linear
    term absorbs only approximately, so 1e-5 relative in frequency and 1 % in decay."""
    f = np.arange(92, 112, 0.1)
    seeds = _pole([100.5, 103.5], [0.012, 0.007])
    fit = local_fit(f, MODES.accelerance(f), seeds, _pole([120.0], [0.01]))
    truth = _pole([100.0, 104.0], [0.01, 0.008])
    assert fit.ok
    np.testing.assert_allclose(fit.pole.imag, truth.imag, rtol=1e-5)
    np.testing.assert_allclose(fit.pole.real, truth.real, rtol=1e-2)
