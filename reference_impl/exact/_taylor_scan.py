"""Where the Taylor kernel's zero-force scan can find nothing (issue 38, goal 5).

`_general_taylor.solve_taylor` samples the zero-force function G / rho^j0 at NS + 1 points of
every step after the turning point until the zero-force end is found. On a step where an
interval bound proves it positive at every point, as evaluated, no sample can be <= 0 and
the scan finds no sign change: it is skipped, every result bit for bit
(`verification/test_general_taylor_scan.py` compares the kernel with its twin that never
skips). Measured on Hertz: it skips 3 of the ~4 scans of a linear-dashpot impact (all but
the step of the zero-force end), 5.7 of the ~6 of a Hunt-Crossley one.
"""

from __future__ import annotations

import numba

__all__ = ["SKIP_MARGIN", "force_stays_positive", "series_range"]

# A step's scan is skipped only where the force's lower bound exceeds this fraction of the
# absolute sum of its terms: the samples' own rounding (Horner of degree K = 30, then a
# polynomial of degree D <= 48) is ~1e-14 of that sum, so every sample is then > 0.
SKIP_MARGIN = 1e-8


@numba.njit(cache=True, error_model="numpy")
def series_range(c, x):
    """(lo, hi) holding sum_k c[k] y^k for every y in [0, x] (x >= 0), as evaluated in floats.

    |p(y) - c[0]| <= sum_{k>=1} |c[k]| x^k; widened by 1e-12 of the absolute sum for the
    rounding of that sum and of any Horner evaluation of p (<= ~2 K eps = 1.3e-14 of it for
    the kernel's K = 30 coefficients)."""
    b = 0.0
    xk = 1.0
    for k in range(1, c.shape[0]):
        xk *= x
        b += abs(c[k]) * xk
    b += 1e-12 * (abs(c[0]) + b)
    return c[0] - b, c[0] + b


@numba.njit(cache=True, error_model="numpy")
def force_stays_positive(F, C, j0, D, R, W, x):
    """True when the zero-force function G / rho^j0 = sum_j (F_j + C_j W) rho^(j - j0)
    (`_general_taylor._event` kind 2: F, C the scaled U' and C by degree in rho, j0 <= j <= D)
    is positive, as evaluated, at every point of the step [0, x] (x >= 0, in s) whose
    Taylor series of rho and W are R and W.

    Interval bounds over the box of `series_range` of rho and W on [0, x], term by term; the
    lower bound must exceed `SKIP_MARGIN` times the absolute sum of the terms, far above
    the rounding of any sample there. Every sample of the zero-force scan then is > 0, so
    the scan would find no sign change: skipping it leaves every result bit for bit (a
    skipped scan samples rho and W at NS + 1 points and evaluates G at each, ~0.4 us of a
    ~2 us step; issue 38, goal 5). NaN anywhere gives False (the scan runs)."""
    rlo, rhi = series_range(R, x)
    wlo, whi = series_range(W, x)
    wmax = max(abs(wlo), abs(whi))
    lb = 0.0
    size = 0.0
    for j in range(j0, D + 1):
        e = j - j0
        if e == 0:
            plo, phi = 1.0, 1.0
        elif rlo >= 0.0:
            plo, phi = rlo**e, rhi**e
        else:  # rho may reach below 0 (the exit step): |rho^e| <= max |rho|^e
            phi = max(-rlo, abs(rhi)) ** e
            plo = -phi
        a1 = F[j] + C[j] * wlo
        a2 = F[j] + C[j] * whi
        alo, ahi = min(a1, a2), max(a1, a2)  # (F_j + C_j W) is linear in W
        lb += min(min(alo * plo, alo * phi), min(ahi * plo, ahi * phi))
        size += (abs(F[j]) + abs(C[j]) * wmax) * max(abs(plo), abs(phi))
    return lb > SKIP_MARGIN * size
