"""One power-law impact in one compiled call (issue 27, goal 2).

For U = k q^n / n, dq/dx = c x^beta exactly and x(s) = s h(s) with h analytic, so
dq/dx = c h^beta s^beta: Gauss-Jacobi with weight s^beta converges geometrically (rate set
by the zero of h at s_end). `power_impact` is that whole impact in one compiled call: the
oscillator, the branch rows, the sums (`_sums.gj_rows` bound to the closed form
`_power_values`: two rule sizes, kept only when they agree to _GJ_RTOL on every row, or
to a looser ``agree`` on a smaller pair when the caller asked for less, `_rtol`;
_GJ_BETA_MIN and _GJ_ZETA_MAX bound where the pair converges fast enough, measured with
scipy's rules; the rules are now mpmath's, correctly rounded, `_branches._jacobi_rules`),
and the peak. `_strategies.power_law` and `prepared` call it.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np

from reference_impl.exact._branches import (
    _EPS,
    _GJ_BETA_MIN,
    _GJ_RTOL,
    _GJ_SIZES,
    _NODE_ULPS,
    _SUM_ULPS_PER_NODE,
    _exponent_splits,
    _fill_rows,
    _jacobi_pair,
    _pow_split,
)
from reference_impl.exact._sums import GJ_OK, gj_rows
from reference_impl.potentials.power import PowerLaw

__all__ = ["OUT_SIZE", "power_constants", "power_impact"]

# Output of `power_impact`: the six Branches fields, q_max, U'(q_max), restitution,
# restitution at zero force, wd, s_peak, s_end, ok (1.0) or not (0.0).
OUT_SIZE = 14


def power_constants(
    pot: PowerLaw, m: float, sizes: tuple[int, int] = _GJ_SIZES, agree: float = _GJ_RTOL
) -> tuple | None:
    """The arguments of `power_impact` after (v0, zeta) for ``pot`` and mass m, or None
    when its Gauss-Jacobi rule does not apply (beta = 2/n - 1 < _GJ_BETA_MIN).

    ``sizes`` are the two rule sizes compared and ``agree`` the agreement they must reach
    on every row (relative); the defaults are the full-accuracy pair, a looser pair is a
    rung of `reference_impl.exact._rtol` (``rtol=``).

    Kept per exact value of (k, p, n, m, sizes, agree) (`_constants`): a one-shot
    `solve_impact` recomputed them on every call (~12 % of its Python time, issue 38)."""
    return _constants(pot.k, pot.p, pot.leading_exponent, m, sizes, agree)


# typed: an int and a float of one value are different keys. Every argument is a checked
# finite positive float (`PowerLaw`, `positive`, `_rtol.checked_rtol`), so float equality is
# equality of bits (no -0.0, no nan): potentials one ulp apart get their own constants.
# The arrays u, W returned are `_jacobi_pair`'s own (cached there too), never written to.
@lru_cache(maxsize=64, typed=True)
def _constants(k: float, p: float, n: float, m: float, sizes: tuple, agree: float):
    beta = 2.0 / n - 1.0
    if beta < _GJ_BETA_MIN:
        return None
    a_hi, a_lo, b_hi, b_lo = _exponent_splits(p, n)
    # power_law_scale's (m/k) (n m / 2k)^(-p/n), the factor of v0^beta left for the kernel.
    c_m = (m / k) * _pow_split(0.5 * n * m / k, a_hi, a_lo)
    u, W = _jacobi_pair(beta, sizes)
    round_rel = (_SUM_ULPS_PER_NODE * sizes[1] + _NODE_ULPS) * _EPS
    q_scale = (0.5 * n * m / k) ** (1.0 / n)
    return (c_m, b_hi, b_lo, u, W, beta, round_rel, q_scale, 2.0 / n, k, p, agree)


# error_model "numpy": called inside `batch._gj_batch`'s prange loop (no exception there).
@numba.njit(cache=True, error_model="numpy")
def _power_values(rows, i, d, args, vals):  # pragma: no cover - compiled
    """c ((x/v0)(s)/s)^beta L^(beta+1) at the nodes d of branch row i (the values carry
    their scale); args = (zeta, wd, beta, c)."""
    zeta, wd, beta, c_pl = args
    s0, s1, p0, p1, L = rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4]
    scale = c_pl * L ** (beta + 1.0)
    for j in range(d.shape[0]):
        dj = d[j]
        x = np.exp(-zeta * (s0 + s1 * dj)) * np.sin(wd * (p0 + p1 * dj)) / wd
        vals[j] = scale * (x / (L * dj)) ** beta
    return True


_POWER_ROWS = gj_rows(_power_values, cache=True)


@numba.njit(cache=True, error_model="numpy")
def power_impact(
    v0,
    zeta,
    c_m,
    b_hi,
    b_lo,
    u,
    W,
    beta,
    round_rel,
    q_scale,
    two_n,
    k,
    p,
    agree,
    rtol_stated,
    tiny,
    out,
):
    """One power-law impact by Gauss-Jacobi, as `solve_impact` computes it (pragma: compiled).

    The oscillator (`VirtualOscillator`), the branch rows (`_fill_rows`), the scale
    c v0^beta (`power_law_scale`: c_m = (m/k) (n m / 2k)^(-p/n)), the sums, their
    agreement test to ``agree`` and bounds (`_sums.gj_rows`), the peak (`_strategies.peak`), and,
    given ``rtol_stated`` and ``tiny``, the bound and range checks (`solve._check_bound`,
    `_check_normal`; inf and 0 skip them): out[13] = 0 when any of them refuses.
    """  # pragma: no cover - compiled
    out[13] = 0.0
    wd = math.sqrt((1.0 - zeta) * (1.0 + zeta))
    sp = math.atan2(wd, zeta) / wd
    s_end = math.pi / wd
    lz = 2.0 * math.atan2(zeta, wd) / wd if zeta > 0.0 else 0.0
    rows = np.empty((3, 5))
    nr = _fill_rows(zeta, sp, s_end, lz, rows)
    for i in range(nr):
        if not rows[i, 4] > 0.0:
            return
    c_pl = c_m * (v0**b_hi * math.exp(b_lo * math.log(v0)))
    fine = np.empty(3)
    err = np.empty(3)
    args = (zeta, wd, beta, c_pl)
    if _POWER_ROWS(rows, nr, u, W, args, 0.0, agree, round_rel, fine, err) != GJ_OK:
        return
    rise, e_rise = fine[0], err[0]
    if zeta == 0.0:
        mid, e_mid, fall, e_fall = rise, e_rise, rise, e_rise
    else:
        fall, e_fall = fine[1], err[1]
        mid, e_mid = fall - fine[2], e_fall + err[2]
    x_peak = v0 * math.exp(-zeta * sp)
    q_max = q_scale * x_peak**two_n
    f_max = k * q_max**p
    for t, e in ((rise + fall, e_rise + e_fall), (rise + mid, e_rise + e_mid)):
        if math.isfinite(t) and not e <= rtol_stated * t:
            return
    if not (q_max >= tiny and f_max >= tiny and rise + fall >= tiny):
        return
    out[0], out[1], out[2], out[3], out[4], out[5] = rise, e_rise, mid, e_mid, fall, e_fall
    out[6], out[7] = q_max, f_max
    out[8] = math.exp(-math.pi * zeta / wd)
    out[9] = math.exp(-2.0 * zeta * sp) if zeta > 0.0 else 1.0
    out[10], out[11], out[12] = wd, sp, s_end
    out[13] = 1.0
