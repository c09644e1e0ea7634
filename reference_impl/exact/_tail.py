"""The overdamped tail of the exact solver: the time from the zero-force instant to q = 0
when zeta >= 1.

Past the peak x(s) falls to 0 only as s -> inf, like exp(-a s) (a = 1/(zeta + r),
r = sqrt(zeta^2 - 1); s exp(-s) at zeta = 1), and dq/dx ~ c x^beta (beta = 2/n - 1),
so the time is finite only for beta > 0 (n < 2), and the integrand decays like
exp(-a beta s): slowly when beta is small, so that x leaves float64's range (m x^2 / 2
below the smallest normal number) while a share ~ (x / v0)^beta of the tail is left
(1e-3 at x = 1e-100 v0 for beta = 0.03). Two parts:

* the head [s0, s_b] (s0 = 2 s_peak) with the solver's dq/dx, down at most to the
  smallest x at which q, U'(q) and dq/dx are normal float64 numbers (`_floor_x`);
* the rest [s_b, inf), with ln(x / x_b) in closed form (no underflow however far),
  out to where its remainder, bounded through the concavity of ln x(s), is below
  round-off: the law g_b (x / x_b)^beta anchored at g_b = dq/dx(x_b), times
  (1 + delta(x)) / (1 + delta(x_b)) for power laws and sums of power laws, which makes
  it exact (`_power_sum_correction`); other families use the law alone, from where
  its bound is negligible (`_law_start`).

Both are Gauss-Legendre sums on pieces (`_edges`, `_integrate`), each bisected while
its fine-minus-coarse estimate exceeds its round-off. The law's error: with
delta = dq/dx / (c x^beta) - 1 for the leading law c x^beta (the potential's
``leading_coefficient``), |dq/dx / law - 1| <= |delta(x_b)| / (1 - |delta(x_b)|)
below x_b when |delta| shrinks monotonically to 0 with one sign (so for sums of power
laws: 1 + delta = (1 + sum A_i y_i)^(1 - 1/n) / (1 + sum B_i y_i) with y_i =
q^(n_i - n) and 0 < (1 - 1/n) A_i < B_i, which falls from 1 as q grows). That is
checked on a ladder of x down to the floor and charged with a safety factor; without a
leading coefficient, or when the ladder does not show it, the law's whole integral
is charged (nothing is known below the floor). A bound above the solver's stated
accuracy is then refused by `solve._check_bound`, never returned.

scipy.quad on [s0, inf) with the law below 1e-100 v0, used before, charged neither
the law's error nor enough of its own: 3.2e-10 against a bound of 2.8e-13 for
U = 50 q^2 + (100 / 1.9375) q^1.9375 at zeta = 1 (2e-10 from the law, 1.3e-10 from
quad, measured against mpmath).
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.potentials._terms import TERM_POWER, term_rows
from reference_impl.potentials.base import Potential

__all__ = ["overdamped_tail"]

_EPS = float(np.finfo(float).eps)
# dq/dx is evaluated down to the energy m x^2 / 2 = _U_FLOOR (J) and, when the leading
# law is known, to its overlap _Q_FLOOR (m): 1e18 above float64's smallest normal
# number, so that q, U'(q) and dq/dx stay normal; x stays above _X_FLOOR (x^2 normal).
_U_FLOOR = 1e-290
_Q_FLOOR = 1e-290
_X_FLOOR = 1e-150
# When a node below the floor fails (not a finite positive number), the energy floor is
# raised by _FLOOR_STEP, up to _U_FLOOR_MAX (the old fixed floor x = 1e-100 v0 was
# u ~ 1e-200 m v0^2); then the error is raised.
_FLOOR_STEP = 1e50
_U_FLOOR_MAX = 1e-90
# Pieces: lengths doubling from the tail's start (the integrand's singularities nearest
# the real axis lie on Re s = 0, where x = 0, at distance >= s from it), each at most
# _DECAYS decay lengths 1/(beta |d ln x / ds|) of the law, so that none spans a steep
# exponential.
_DECAYS = 8.0
# Gauss-Legendre rule sizes on each piece (analytic there; the nearest singularity,
# at s = 0, lies 3 half-lengths from a doubling piece's centre, so the 10-point rule
# already reaches ~1e-15): the larger rule's value, their difference as its error.
_GL_SIZES = (10, 16)
# A piece is bisected while its fine-minus-coarse estimate exceeds its round-off bound
# and _PIECE_RTOL of the tail (pieces that carry nothing are left alone), at most
# _SPLITS rounds; the estimate is charged either way.
_PIECE_RTOL = 1e-16
_SPLITS = 10
# The law is integrated until it has decayed by exp(-_LAW_DECAY) (doubled until its
# rest, added to the bound, is below _CUT of the tail).
_LAW_DECAY = 45.0
_CUT = 1e-17
# Round-off of the nodes deep in the tail, in ulps per e-fold of x / v0: beta and 1/n
# are rounded, and the potential's exponents known to an ulp (its U and U' hooks may
# differ there), and x^beta moves by |ln x| times that (3.7e-14 at x = 1e-145 v0,
# above the _NODE_ULPS charged for the other branches).
_LOG_ULPS = 2.0
# The law's deviation is measured at _LADDER displacements, log-spaced from the floor
# up to _LADDER_TOP x(s0); its round-off is _DEV_ULPS ulps plus 4 ulps per e-fold of
# the logarithms in the law (`_law_start`). The deviation at x_b, times _LAW_SAFETY,
# bounds the law's relative error below x_b. The law takes over at the highest point
# where that bound on its share is below _LAW_TARGET of the tail's scale (fewer
# evaluations of dq/dx, which costs mpmath near 0 for some expressions).
_LADDER = 9
_LADDER_TOP = 1e-3
_DEV_ULPS = 32.0
_LAW_SAFETY = 2.0
_LAW_TARGET = 1e-17
# Newton iterations locating s where x(s) reaches a value (converges in ~5-10).
_NEWTON_MAX = 200


def overdamped_tail(
    g_of,
    osc: VirtualOscillator,
    beta: float,
    pot: Potential,
    m: float,
    node_ulps: float,
) -> tuple[float, float]:
    """Physical time from the zero-force instant to q = 0 when zeta >= 1, and a bound
    on its absolute error (s).

    Parameters
    ----------
    g_of : callable
        dq/dx (s) at an array of virtual displacements x (m); raises when a value is
        not a finite positive number.
    osc : VirtualOscillator
        The virtual oscillator, zeta >= 1.
    beta : float
        2/n - 1 for the potential's leading exponent n; the time is inf for beta <= 0.
    pot : Potential
        The potential (its ``leading_exponent`` and ``leading_coefficient``).
    m : float
        Mass (kg).
    node_ulps : float
        Relative round-off of one value of g_of, in ulps.
    """
    if beta <= 0:
        return math.inf, 0.0
    u_floor = _U_FLOOR
    while True:
        try:
            return _tail(g_of, osc, beta, pot, m, node_ulps, _floor_x(pot, m, u_floor))
        except HCVInputError:
            # A node below this floor is not a finite positive number (a node function
            # whose internals leave float range before q does): a higher floor.
            u_floor *= _FLOOR_STEP
            if u_floor > _U_FLOOR_MAX:
                raise


def _tail(g_of, osc: VirtualOscillator, beta, pot, m, node_ulps, x_floor):
    """`overdamped_tail` with dq/dx evaluated down to x_floor (m)."""
    v0 = osc.v0
    s0 = osc.s_zero_force
    x0 = float(osc.x(s0))
    ln_v0 = math.log(v0)
    b_hi, b_lo = _beta_split(pot.leading_exponent)
    corr = _power_sum_correction(pot, m)
    if corr is None:
        # The law from where its bound is negligible (or the floor); this probes dq/dx
        # at the floor first, where it fails if anywhere.
        s_b, dev = _law_start(g_of, osc, pot, m, beta, x0, x_floor)
    else:
        dev = 0.0
        s_b = _s_where(osc, math.log(x_floor), s0) if x_floor < x0 else s0
    x_b = float(osc.x(s_b))
    ln_xb = math.log(x_b)
    g_b = float(g_of(np.array([x_b]))[0])
    # g_b's round-off (as the head's nodes), inherited by every node below, which also
    # carry _LOG_ULPS per e-fold of x: the potential's exponents are known to an ulp
    # (PowerLaw: U' = k q^p but U = k q^(p+1) / (p+1) with p + 1 rounded), so x^beta to
    # |ln x| ulps; the tail's integral ~ 1 / beta feels that as ~ 1/beta ulps.
    ulps_b = node_ulps + _LOG_ULPS * abs(ln_xb - ln_v0)
    corr_b = 0.0
    if corr is not None:
        c_b, u_b = corr(np.array([ln_xb]))
        corr_b = float(c_b[0])
        ulps_b += float(u_b[0])

    def below_f(s):
        # beta ln(x / x_b) with beta carried beyond float precision (its rounding would
        # cost |ln(x / x_b)| / 2 ulps, 1e-13 of the tail for beta = 0.001).
        lr = _log_x_ratio(osc, s, s_b)
        y = b_hi * lr + b_lo * lr
        ulps = ulps_b + _LOG_ULPS * np.abs(lr) + 4.0
        if corr is not None:
            c, u = corr(ln_xb + lr)
            y = y + (c - corr_b)
            ulps = ulps + u
        return g_b * np.exp(y), ulps + 2.0 * np.abs(y)

    def head_f(s):
        x = osc.x(s)
        return g_of(x), node_ulps + _LOG_ULPS * np.abs(np.log(x) - ln_v0)

    if s_b > s0:
        head, e_head = _integrate(head_f, _edges(osc, beta, s0, s_b), 0.0)
    else:
        head, e_head = 0.0, 0.0
    # Past s_far, dq/dx lies below g_b (x / x_b)^beta / (1 + delta_b) (power sums:
    # 1 + delta <= 1, see the module docstring), or is the law g_b (x / x_b)^beta.
    ln_ref = math.log(g_b) - corr_b
    decay = _LAW_DECAY
    while True:
        s_far = _s_where(osc, ln_xb - decay / beta, s_b)
        below, e_below = _integrate(below_f, _edges(osc, beta, s_b, s_far), head)
        # ln x is concave: past s_far, x^beta lies below its tangent there.
        ln_far = ln_ref + beta * float(_log_x_ratio(osc, s_far, s_b))
        rest = math.exp(ln_far) / (beta * _rate(osc, s_far))
        if rest <= _CUT * (head + below) or decay > 1e4:
            break
        decay *= 2.0
    total = head + below
    # The two sums and their sum: one ulp each.
    err = e_head + e_below + rest + dev * below + 3.0 * _EPS * total
    return total, err


@lru_cache(maxsize=64)
def _beta_split(n: float) -> tuple[float, float]:
    """beta = 2/n - 1 = (2 - n)/n for the float n, exactly as hi + lo."""
    y = (2 - Fraction(n)) / Fraction(n)
    hi = float(y)
    return hi, float(y - Fraction(hi))


def _power_terms(pot: Potential):
    """[(k, p), ...] (U' = sum k q^p) when the potential's term table holds only power
    terms (a power law, a sum of them, a user expression that is one), else None."""
    rows = term_rows(pot)
    if rows is None or any(r[0] != TERM_POWER for r in rows):
        return None
    return [(r[1], r[3]) for r in rows]


def _power_sum_correction(pot: Potential, m: float):
    """ln(1 + delta) and its round-off in ulps against ln x, for a power law or a sum
    of power laws (None for other families), delta = dq/dx / (c x^beta) - 1 (see the
    module docstring).

    With U = c q^n (1 + sum A_i y_i), U' = n c q^(n-1) (1 + sum B_i y_i) and
    y_i = q^(n_i - n) for the terms above the leading exponent n,
    1 + delta = (1 + sum A_i y_i)^(1 - 1/n) / (1 + sum B_i y_i) exactly. ln q = t solves
    ln U(e^t) = ln(m x^2 / 2), convex and increasing in t (a log-sum-exp of lines), by
    Newton from the smallest single-term root (above the root, so it falls onto it
    monotonically), in logarithms so that any x > 0 is in range. An error in t moves
    y_i by (n_i - n) times it, and delta by less.
    """
    terms = _power_terms(pot)
    if terms is None:
        return None
    k = np.array([t[0] for t in terms])
    p = np.array([t[1] for t in terms])
    n_i = p + 1.0  # as the potential forms it
    ln_a = np.log(k) - np.log(n_i)
    n = float(np.min(n_i))
    lead = n_i == n
    c = float(np.sum(k[lead] / n_i[lead]))
    e = n_i[~lead] - n
    A = k[~lead] / n_i[~lead] / c
    B = k[~lead] / (n * c)
    ln_m = math.log(m)

    def corr(ln_x):
        ln_x = np.asarray(ln_x, dtype=float)
        if e.size == 0:
            return np.zeros_like(ln_x), np.zeros_like(ln_x)
        ln_u = (ln_m + 2.0 * ln_x - math.log(2.0))[..., None]
        t = np.min((ln_u - ln_a) / n_i, axis=-1, keepdims=True)
        for _ in range(_NEWTON_MAX):
            z = ln_a + n_i * t
            top = np.max(z, axis=-1, keepdims=True)
            w = np.exp(z - top)
            sw = np.sum(w, axis=-1, keepdims=True)
            step = (top + np.log(sw) - ln_u) * sw / np.sum(w * n_i, axis=-1, keepdims=True)
            t = t - step
            if np.all(np.abs(step) <= 4.0 * _EPS * (1.0 + np.abs(t))):
                break
        y = np.exp(e * t)
        sa, sb = np.sum(A * y, axis=-1), np.sum(B * y, axis=-1)
        # |d ln(1 + delta) / dt| times t's error (Newton's tolerance and the rounding
        # of ln u and n t), in ulps.
        slope = (1.0 - 1.0 / n) * np.sum(A * e * y, axis=-1) / (1.0 + sa) + np.sum(
            B * e * y, axis=-1
        ) / (1.0 + sb)
        ulps = 4.0 + slope * (4.0 + 4.0 * np.abs(t[..., 0]) + np.abs(ln_u[..., 0]))
        return (1.0 - 1.0 / n) * np.log1p(sa) - np.log1p(sb), ulps

    return corr


def _ln_leading_law(pot: Potential, m: float, ln_x):
    """ln(c x^beta) for the leading law U = c q^n: q = (m x^2 / 2c)^(1/n) and
    dq/dx = m x / (n c q^(n-1)), in logarithms (no intermediate leaves float range)."""
    c, n = pot.leading_coefficient, pot.leading_exponent
    ln_m, ln_c = math.log(m), math.log(c)
    return (ln_m - math.log(n * c) + ln_x) - (1.0 - 1.0 / n) * (
        math.log(0.5) + ln_m - ln_c + 2.0 * ln_x
    )


def _floor_x(pot: Potential, m: float, u: float) -> float:
    """The smallest x (m) at which dq/dx is evaluated, for an energy floor u (J)."""
    c, n = pot.leading_coefficient, pot.leading_exponent
    if c is not None and c > 0 and math.isfinite(c):
        # The leading law's overlap (u / c)^(1/n) >= _Q_FLOOR.
        u = max(u, c * _Q_FLOOR**n)
    return max(math.sqrt(2.0 * u) / math.sqrt(m), _X_FLOOR)


def _log_x(osc: VirtualOscillator, s: float) -> float:
    """ln x(s) in closed form (no underflow), zeta >= 1."""
    if osc.zeta == 1.0:
        return math.log(osc.v0) + math.log(s) - s
    r = osc.r
    a = 1.0 / (osc.zeta + r)
    return math.log(osc.v0) - a * s + math.log(-math.expm1(-2.0 * r * s)) - math.log(2.0 * r)


def _log_x_ratio(osc: VirtualOscillator, s, s_b: float):
    """ln(x(s) / x(s_b)) without cancellation (vectorised), zeta >= 1."""
    s = np.asarray(s, dtype=float)
    d = s - s_b
    if osc.zeta == 1.0:
        return np.log1p(d / s_b) - d
    r = osc.r
    a = 1.0 / (osc.zeta + r)
    # (1 - e^{-2rs}) / (1 - e^{-2r s_b}) - 1 = e^{-2r s_b} expm1(-2r d) / expm1(-2r s_b).
    rel = math.exp(-2.0 * r * s_b) * np.expm1(-2.0 * r * d) / math.expm1(-2.0 * r * s_b)
    return -a * d + np.log1p(rel)


def _rate(osc: VirtualOscillator, s: float) -> float:
    """-d ln x / ds at s (> 0 past the peak, increasing: ln x is concave)."""
    if osc.zeta == 1.0:
        return 1.0 - 1.0 / s
    r = osc.r
    e = math.exp(-2.0 * r * s)
    return 1.0 / (osc.zeta + r) - 2.0 * r * e / -math.expm1(-2.0 * r * s)


def _s_where(osc: VirtualOscillator, ln_x: float, s_start: float) -> float:
    """s >= s_start (past the peak) where ln x(s) = ln_x, by Newton.

    ln x is concave and decreasing there: the first step overshoots, and the
    iterates then fall monotonically onto the root.
    """
    s = s_start
    for _ in range(_NEWTON_MAX):
        step = (_log_x(osc, s) - ln_x) / _rate(osc, s)
        s += step
        if abs(step) <= 1e-13 * s:
            break
    return max(s, s_start)


def _edges(osc: VirtualOscillator, beta: float, lo: float, hi: float) -> np.ndarray:
    """Piece boundaries from lo to hi: doubling lengths, at most _DECAYS decay lengths."""
    edges = [lo]
    while edges[-1] < hi:
        s = edges[-1]
        h = min(s, _DECAYS / (beta * _rate(osc, s)))
        edges.append(min(s + h, hi))
    return np.array(edges)


@lru_cache(maxsize=1)
def _gauss_pair():
    """Nodes in (0, 1) of the _GL_SIZES Gauss-Legendre rules, concatenated, and a
    (nodes, 2) weight matrix whose columns give the two rules (zeros elsewhere)."""
    us, W, i = [], np.zeros((sum(_GL_SIZES), 2)), 0
    for j, size in enumerate(_GL_SIZES):
        y, w = np.polynomial.legendre.leggauss(size)
        us.append(0.5 * (1.0 + y))
        W[i : i + size, j] = 0.5 * w
        i += size
    return np.concatenate(us), W


def _integrate(f, edges: np.ndarray, scale: float):
    """Sum of the integrals of f over the pieces ``edges``, and a bound on its error.

    ``f(s)`` returns the integrand and its relative round-off in ulps at s. Each piece
    takes the larger Gauss-Legendre rule's value, and the two rules' difference as
    its error estimate; a piece is bisected while that estimate exceeds both its
    round-off and _PIECE_RTOL of the tail (``scale`` plus the first pass's sum).
    """
    u, W = _gauss_pair()
    lo, hi = edges[:-1], edges[1:]
    val = err = 0.0
    count = 0
    for rnd in range(_SPLITS + 1):
        L = hi - lo
        fv, node = f(lo[:, None] + L[:, None] * u)
        coarse = L * np.sum(fv * W[:, 0], axis=-1)
        v = L * np.sum(fv * W[:, 1], axis=-1)
        q = np.abs(v - coarse)
        wf = np.abs(fv) * W[:, 1]
        # The sum of N terms: N ulps of the sum of |w f| (any order), plus the nodes'.
        ro = _EPS * L * (_GL_SIZES[1] * np.sum(wf, axis=-1) + np.sum(wf * node, axis=-1))
        if rnd == 0:
            scale = scale + float(np.sum(v))
        split = (q > ro) & (q > _PIECE_RTOL * scale)
        if rnd == _SPLITS:
            split[:] = False
        done = ~split
        val += float(np.sum(v[done]))
        err += float(np.sum(q[done] + ro[done]))
        count += int(np.sum(done))
        if not split.any():
            break
        mid = 0.5 * (lo[split] + hi[split])
        lo, hi = np.concatenate([lo[split], mid]), np.concatenate([mid, hi[split]])
    # Summing the pieces' values: one ulp of the total per piece.
    return val, err + count * _EPS * abs(val)


def _law_start(g_of, osc: VirtualOscillator, pot, m, beta, x0, x_floor):
    """(s_b, dev): where the law g_b (x / x_b)^beta takes over, and a bound on its
    relative error below (see the module docstring).

    delta = dq/dx / (c x^beta) - 1 is measured at _LADDER points from x_floor up to
    _LADDER_TOP x0. The law starts at the highest of them whose bound, _LAW_SAFETY
    |delta| times the law's integral, is below _LAW_TARGET of the tail's scale, with
    |delta| shrinking towards x_floor over the points below it (and at least the
    lower half); else at x_floor, where dev is 1 when |delta| does not shrink there,
    or the leading coefficient c is unknown.
    """
    s0 = osc.s_zero_force
    s_floor = _s_where(osc, math.log(x_floor), s0) if x_floor < x0 else s0
    c = pot.leading_coefficient
    if c is None or not (c > 0 and math.isfinite(c)):
        return s_floor, 1.0
    ln_lo = math.log(float(osc.x(s_floor)))
    ln_hi = max(ln_lo, math.log(x0) + math.log(_LADDER_TOP))
    s_j = np.array([_s_where(osc, t, s0) for t in np.linspace(ln_lo, ln_hi, _LADDER)])
    s_j[0] = s_floor
    xs = osc.x(s_j)
    ln_xs = np.log(xs)
    g = g_of(xs)
    with np.errstate(all="ignore"):
        delta = np.expm1(np.log(g) - _ln_leading_law(pot, m, ln_xs))
    noise = _EPS * (
        _DEV_ULPS
        + _LOG_ULPS * np.abs(ln_xs - math.log(osc.v0))
        + 4.0 * (abs(math.log(m)) + abs(math.log(c)) + 2.0 * np.abs(ln_xs) + 1.0)
    )
    if not np.all(np.isfinite(delta)):
        return s_floor, 1.0
    d = np.abs(delta) + noise
    # |delta| shrinks towards x_floor over points 0..j, with one sign beyond round-off.
    ok = np.ones(_LADDER, dtype=bool)
    sign = 0.0
    for j in range(_LADDER):
        if j > 0:
            grows = abs(delta[j]) >= abs(delta[j - 1]) - noise[j] - noise[j - 1]
            ok[j] = ok[j - 1] and grows
        if abs(delta[j]) > noise[j]:
            sign = sign or math.copysign(1.0, delta[j])
            ok[j] = ok[j] and math.copysign(1.0, delta[j]) == sign
        ok[j] = ok[j] and d[j] < 0.5
    dev = np.where(d < 0.5, _LAW_SAFETY * d / (1.0 - np.minimum(d, 0.5)), 1.0)
    # The law's integral past s_j is below g_j / (beta |d ln x / ds|) (ln x is concave).
    law = g / (beta * np.array([_rate(osc, float(t)) for t in s_j]))
    half = _LADDER // 2
    for j in range(_LADDER - 1, 0, -1):
        if ok[max(j, half)] and dev[j] * law[j] <= _LAW_TARGET * float(np.max(law)):
            return float(s_j[j]), float(dev[j])
    return s_floor, float(dev[0]) if ok[half] else 1.0
