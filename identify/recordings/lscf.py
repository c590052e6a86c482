"""Poles of an FRF on a frequency band: the least-squares complex frequency-domain (LSCF)
estimator, one band at a time.

The common-denominator model H(z) = N(z) / D(z) in z = exp(i (w - w_c) T) is fitted by
linear least squares, min sum |N(z_k) - H_k D(z_k)|^2 with D monic (Guillaume, Verboven,
Vanlanduit, Van der Auweraer and Peeters, "A poly-reference implementation of the
least-squares complex frequency-domain estimator", IMAC XXI, 2003; the same estimator as
sdypy-EMA's ``Model.get_poles("lscf")``, which ``tests/identify/recordings/test_lscf.py`` checks it
against).  Two things differ from that full-band form, both for speed on a plate with
30-60 modes in band:

- The band, not 0..f_max, is mapped onto an arc of ``ARC`` of the unit circle around its
  centre w_c.  A band holding a few modes then needs a denominator of a few times their
  number, where the full-band form needs one of degree 4 x (modes in 0..f_max) + 40; the
  cost of the roots grows with the cube of the degree (the full-band diagram of a
  38-mode plate spent 0.4 s in them).  The complex coefficients fit the positive
  frequencies alone (the full-band form has real ones and the band's mirror image).
- One QR of the interleaved columns [1, -H, z, -H z, ..., z^n, -H z^n] serves every
  degree m <= n: its leading 2 (m + 1) columns are the degree-m problem, so the monic
  solution is one triangular solve in the leading block of R.  No normal equations are
  formed, so nothing cancels at high signal-to-noise ratios.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

#: The band is mapped onto this fraction of the unit circle.  Nearly all of it: where no
#: data lie, roots cost the fit nothing and an over-modelled fit puts its noise there, so
#: on a half circle a weak mode's pole wandered from order to order (nine 30 dB sessions of
#: the tap plate of ``studies.tap_test``, 72 modes: 31 found within 3 std on a half circle,
#: 61 here, 58 by sdypy-EMA's full band).  The band's ends, 5 % of the circle apart, lie
#: beyond the kept core of every sub-band but the first and last.
ARC = 0.95


def lscf_poles(
    frequency_hz: np.ndarray, h: np.ndarray, band_hz: tuple[float, float], degrees
) -> list[np.ndarray]:
    """Poles [rad/s] (s = -zeta w + i w sqrt(1 - zeta^2) for a mode) of the common
    denominator of degree m fitted to the complex FRF ``h`` on the lines of
    ``frequency_hz`` [Hz] inside ``band_hz`` [Hz], for each m in ``degrees``.  Every root is
    returned, the computational ones included: the stabilisation diagram sorts them."""
    lo, hi = band_hz
    inside = (frequency_hz >= lo) & (frequency_hz <= hi)
    f, hk = frequency_hz[inside], h[inside]
    n = max(degrees)
    if 2 * (n + 1) > len(f):
        raise ValueError(
            f"degree {n} needs at least {2 * (n + 1)} lines in band_hz = ({lo:g}, {hi:g}) Hz; "
            f"it holds {len(f)}"
        )
    period = ARC / (hi - lo)  # T [s]: the band spans ARC x 2 pi in w T
    centre = 0.5 * (lo + hi)
    z = np.exp(2j * np.pi * np.outer(f - centre, np.arange(n + 1)) * period)
    basis = np.empty((len(f), 2 * (n + 1)), dtype=complex)
    basis[:, 0::2], basis[:, 1::2] = z, -hk[:, None] * z
    r = linalg.qr(basis, mode="r", check_finite=False)[0]
    out = []
    for m in degrees:
        k = 2 * m + 1  # the column of -H z^m, whose coefficient is 1 (D monic)
        c = linalg.solve_triangular(r[:k, :k], -r[:k, k], check_finite=False)
        denominator = np.append(c[1::2], 1.0)  # a_0 .. a_m
        roots = np.roots(denominator[::-1])
        out.append(np.log(roots) / period + 2j * np.pi * centre)
    return out
