"""The sub-band LSCF estimator (``identify.recordings.lscf``) against closed forms and
against sdypy-EMA's full-band LSCF, the field library's implementation of the same
estimator."""

import numpy as np
import pytest

from identify.recordings.lscf import lscf_poles

#: Five modes of the paper's plate: natural frequency [Hz], damping ratio, residue.
MODES = [
    (129.2, 0.006, 1.0),
    (191.6, 0.005, -0.8),
    (238.8, 0.004, 0.6),
    (383.0, 0.005, 1.2),
    (440.0, 0.011, -0.7),
]
RESOLUTION_HZ = 0.5


def pole(f_hz: float, zeta: float) -> complex:
    w = 2 * np.pi * f_hz
    return -zeta * w + 1j * w * np.sqrt(1 - zeta**2)


def accelerance(frequency_hz: np.ndarray, modes=MODES) -> np.ndarray:
    """s^2 sum A/(s - p) + conj(A)/(s - conj p): a free plate's accelerance."""
    s = 2j * np.pi * frequency_hz
    h = sum(a / (s - pole(f, z)) + np.conj(a) / (s - np.conj(pole(f, z))) for f, z, a in modes)
    return s**2 * h


TRUE = np.array([pole(fn, z) for fn, z, _ in MODES])


def nearest(poles: np.ndarray, to: np.ndarray = TRUE) -> np.ndarray:
    """The pole of ``poles`` nearest each of ``to`` (the others are the computational
    poles of an over-modelled fit, which a stabilisation diagram sorts out)."""
    return poles[np.argmin(np.abs(poles[None, :] - to[:, None]), axis=1)]


def zeta(p: np.ndarray) -> np.ndarray:
    return -p.real / np.abs(p)


def test_exact_frf_gives_its_poles():
    """Noise-free data of five modes on 100-500 Hz: at degree 20 (room for the residual
    terms of the modes outside) every pole is recovered to 1e-7 of its frequency and 1e-4
    of its damping ratio (the data are exact to round-off; the rational model of the
    band's lines is not exactly the partial-fraction form, so not to 1e-12)."""
    f = np.arange(0.0, 1000.0, RESOLUTION_HZ)
    found = nearest(lscf_poles(f, accelerance(f), (100.0, 500.0), [20])[0])
    np.testing.assert_allclose(np.abs(found), np.abs(TRUE), rtol=1e-7)
    np.testing.assert_allclose(zeta(found), zeta(TRUE), rtol=1e-4)


def test_one_qr_serves_every_degree():
    """The poles at degree m from the one QR of the highest degree equal those of a QR
    made for degree m alone (the leading columns of a QR are the QR of the leading
    columns)."""
    f = np.arange(0.0, 1000.0, RESOLUTION_HZ)
    rng = np.random.default_rng(1)
    h = accelerance(f) * (1 + 1e-3 * (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))))
    together = lscf_poles(f, h, (100.0, 500.0), [8, 14, 30])
    for degree, poles in zip([8, 14, 30], together, strict=True):
        alone = lscf_poles(f, h, (100.0, 500.0), [degree])[0]
        np.testing.assert_allclose(np.sort_complex(poles), np.sort_complex(alone), rtol=1e-9)


def test_same_poles_as_sdypy_ema():
    """On noisy data (0.1 % of each line) the sub-band estimator's poles on 100-500 Hz
    at degree 24 and sdypy-EMA's full-band LSCF (10-1000 Hz, degree 60) are equally
    close to the truth: over seeds 2-6 both within 1.2-2.7e-5 in frequency and 0.2-0.5 %
    in damping (the two fit different bands, so the noise moves each differently).
    Asserted: each within 5e-5 and 1 % of the truth, and so within 1e-4 and 2 % of each
    other."""
    sdypy = pytest.importorskip("sdypy.EMA")
    f = np.arange(0.0, 1000.0 + RESOLUTION_HZ, RESOLUTION_HZ)
    rng = np.random.default_rng(2)
    h = accelerance(f) * (1 + 1e-3 * (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))))
    ours = nearest(lscf_poles(f, h, (100.0, 500.0), [24])[0])
    model = sdypy.Model(frf=h[None, :], freq=f, lower=10.0, upper=f[-1], pol_order_high=30)
    model.get_poles("lscf", show_progress=False)
    theirs = nearest(np.asarray(model.all_poles[-1]))
    for found in (ours, theirs):
        np.testing.assert_allclose(np.abs(found), np.abs(TRUE), rtol=5e-5)
        np.testing.assert_allclose(zeta(found), zeta(TRUE), rtol=0.01)
    np.testing.assert_allclose(np.abs(ours), np.abs(theirs), rtol=1e-4)
    np.testing.assert_allclose(zeta(ours), zeta(theirs), rtol=0.02)


def test_too_few_lines_is_an_error():
    f = np.arange(0.0, 1000.0, RESOLUTION_HZ)
    with pytest.raises(ValueError, match="degree 40 needs at least 82 lines"):
        lscf_poles(f, accelerance(f), (100.0, 130.0), [40])
