"""Compiled (numba) node inversion for a single volumetric cap (sphere or ellipsoid).

The cap's energy is U = Kn / (alpha + 1) V^(alpha + 1) with the cubic overlap volume
V = c0 (a q^2 - q^3 / 3). At each quadrature node `cap_nodes` computes V from the node's
energy u = m x^2 / 2 in closed form (`_cap_powers`), q from V by an interpolant of the
cubic's root and one Halley step (`_cap_root`; bracketed Newton, `_cap_newton`, where that
step is not accepted), and U' = (alpha + 1) u V' / V without a second power. No node waits
on another, so the arithmetic passes vectorise. `reference_impl.exact._nodes` dispatches
here for a term table of one cap row; every other family is inverted there.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["DESCENT", "NEWTON_MAX_ITER", "cap_nodes"]

_EPS = float(np.finfo(float).eps)
# Relative step at which the cap's cubic Newton stops: a few ulps of q (each step is
# arithmetic only, so the confirming evaluation costs nothing worth saving).
_CUBIC_XRTOL = 4.0 * _EPS
# Steps allowed per node (Halley needs ~2 from the warm start; bisection from
# [0, q_max] with geometric steps needs at most ~2200 to span float64); also the
# budget of `_nodes._newton_loop`.
NEWTON_MAX_ITER = 3000
# Fraction of hi tried when the lower bracket is still 0 (geometric descent); also
# `_nodes._newton_loop`'s.
DESCENT = 1.0 / 64.0

# The cap's cubic a q^2 - q^3/3 = w, in y = q / a and s = sqrt(w / a^3): y^2 (1 - y/3) = s^2,
# whose root on 0 < y < 2 is y = s h(s), h analytic for |s| < 2/sqrt(3) (the double root
# at y = 2). Its closed form y = 4 sin(psi) sin(psi + pi/3), psi = asin(sqrt(3) s / 2) / 3,
# costs an asin and two sines per node; Newton warm-started from the previous node took
# 3.6 cubic evaluations per node, each waiting on the last (and every node on the one
# before). Instead h is its interpolant at the 11 Chebyshev points of 0 <= s <= sqrt(2/3)
# (y <= 1), in powers of s (generated from the closed form at 40 digits): relative error
# <= 3.6e-8 there (verification/test_exact_cap_nodes.py). One Halley step from it leaves
# ~ r^3 / 3 of q for a start off by r (the cubic's Halley constant f'''/(6 f') - (f''/(2 f'))^2
# is about -1 / (3 y^2) on 0 < y <= 1): 2e-23. Nodes whose start is farther (y > 1, or
# inputs outside the interpolant's range) are iterated by `_cap_newton`.
_CAP_H = (
    1.0000000148361918,
    0.16666228127286292,
    0.069656354630884,
    0.033090852700476514,
    0.059447884418367986,
    -0.18633455414159766,
    0.670336948839665,
    -1.3436104704983995,
    1.6864996083627941,
    -1.1725404474449665,
    0.36315427680879814,
)
_H0, _H1, _H2, _H3, _H4, _H5, _H6, _H7, _H8, _H9, _H10 = _CAP_H
# s^2 at y = 1, the end of the interpolant's range.
_CAP_OMEGA_MAX = 2.0 / 3.0
# Largest Halley step from the interpolant accepted, relative to q: the step is the start's
# error to first order, and a start off by 2e-6 is left at ~ (2e-6)^3 / 3 = 3e-18 of q (the
# interpolant's own 3.6e-8 is 55 times smaller). Anything larger is iterated.
_CAP_STEP_MAX = 2e-6
# Smallest f'^2 q for which the Halley step is taken. At tiny scales its numerator 2 p f'
# (~ r a^5 y^3 for a start off by r) underflows: rounded to 2^-1074 absolute, i.e. to
# 2^-1075 / (f'^2 q) of q, which this keeps below 2^-57 (eps / 32); below it (a < ~1e-58:
# the step was 0 and the start's 3.6e-8 accepted) `_cap_newton`, whose step p / f' does
# not underflow, takes the node.
_CAP_SCALE_MIN = 2.0**-1018
_PI_3 = math.pi / 3.0


@numba.njit(cache=True, error_model="numpy")
def _cap_root(w, a, ia3, q_hi):  # pragma: no cover - compiled
    """(q, accepted): the root of a q^2 - q^3/3 = w by the interpolant of h and one Halley
    step (see _CAP_H), ia3 = 1 / a^3; accepted when the start was in the interpolant's range,
    the step within _CAP_STEP_MAX of q, its numerator a normal float (f'^2 q at least
    _CAP_SCALE_MIN), and 0 < q < q_hi (the bracket of `_cap_newton`)."""
    om = w * ia3
    s = math.sqrt(om)
    h = _H9 + s * _H10
    h = _H8 + s * h
    h = _H7 + s * h
    h = _H6 + s * h
    h = _H5 + s * h
    h = _H4 + s * h
    h = _H3 + s * h
    h = _H2 + s * h
    h = _H1 + s * h
    h = _H0 + s * h
    q = a * (s * h)
    p = q * q * (a - q / 3.0) - w
    dp = q * (2.0 * a - q)
    dd = dp * dp
    step = 2.0 * p * dp / (2.0 * dd - p * (2.0 * (a - q)))
    qn = q - step
    ok = (
        (om <= _CAP_OMEGA_MAX)
        & (dd * q >= _CAP_SCALE_MIN)
        & (abs(step) <= _CAP_STEP_MAX * q)
        & (qn > 0.0)
        & (qn < q_hi)
    )
    return qn, ok


@numba.njit(cache=True, error_model="numpy")
def _cap_newton(w, a, q_hi):  # pragma: no cover - compiled
    """The root of a q^2 - q^3/3 = w by Newton inside the bracket (0, q_hi), from the
    closed form (see _CAP_H; nan for w outside (0, 4 a^3 / 3], then the bracket's middle),
    stopped when the step is below _CUBIC_XRTOL of q."""
    psi = math.asin(math.sqrt(0.75 * (w / (a * a * a)))) / 3.0
    q = a * (4.0 * math.sin(psi) * math.sin(psi + _PI_3))
    lo, hi = 0.0, q_hi
    if not (q > lo and q < hi):
        q = 0.5 * hi
    for _ in range(NEWTON_MAX_ITER):
        p = q * q * (a - q / 3.0) - w
        if p < 0.0:
            lo = q
        elif p > 0.0:
            hi = q
        else:
            break
        dp = q * (2.0 * a - q)
        step = p / dp if dp > 0.0 else np.inf
        if abs(step) <= _CUBIC_XRTOL * q:
            break
        qn = q - step
        if not (qn > lo and qn < hi):
            qn = math.sqrt(lo * hi) if lo > 0.0 else hi * DESCENT
        q = qn
    return q


# alpha = 1/2 (the default of both caps): V = t^(2/3) = r^2 with r = cbrt(t), t = u (alpha + 1)
# / Kn. pow(t, 2/3) costs a libm call per node, and its exponent is the float fl(2/3),
# 3.7e-17 off, which moves V by t^(3.7e-17): up to 112 eps for |ln t| ~ 700, 3-7 eps for
# t ~ 1e-11 (the scenes'). Instead r starts from t's bits (its exponent divided by 3:
# within 6 %), then two Halley steps (6e-2 -> ~1e-4 -> ~1e-13) and a Newton step, whose
# size confirms it (<= _CBRT_STEP_MAX of r) and leaves r within an ulp: V within 1.8 eps
# of t^(2/3) (verification/test_exact_cap_nodes.py). Arithmetic only, so it vectorises.
_CBRT_BIAS = 0x2AA0000000000000  # 2/3 of the bits of 1.0: the bits of cbrt(1) = 1
_CBRT_STEP_MAX = 1e-10  # the last step's size: ~1e-13 of r; 1e-10 leaves ~1e-20
# t outside (_CBRT_T_MIN, 1 / _CBRT_T_MIN): pow (subnormal t has no such bits; near the
# top, r^3 and 2 r^3 + t would overflow).
_CBRT_T_MIN = 1e-290
# Every other alpha (and alpha = 1/2 outside that range): pow(t, e) with e = fl(1/A), A =
# alpha + 1, is off by t^(1/A - e): |1/A - e| is up to half an ulp of e (3.7e-17 for 2/3,
# 5.5e-17 in general), i.e. ~5.5e-17 |ln t|, 1e-14 at |ln t| = 240, twice the 16 ulps a node
# is charged (measured: contact times 1.4-3.7 times their bounds at |ln t| = 110-300). So
# V = pow(t, e) (1 + c ln t), c = 1/A - e (`_exponent_residual`).
_SPLIT = 134217729.0  # 2^27 + 1: Veltkamp's splitting constant for Dekker's product


@numba.njit(cache=True, error_model="numpy")
def _cap_powers(x, m, alpha, kn, v, scratch):  # pragma: no cover - compiled
    """V = (u (alpha + 1) / Kn)^(1 / (alpha + 1)) at every node into v (``scratch`` as
    large: overwritten); for alpha = 1/2 by the cube root of `_CBRT_BIAS`, else by pow
    times 1 + c ln t (c = `_exponent_residual`, see _SPLIT)."""
    to_v = (alpha + 1.0) / kn
    n = x.shape[0]
    for j in range(n):
        xj = x[j]
        v[j] = to_v * (0.5 * m * xj * xj)  # t
    rest = n
    if alpha == 0.5:
        ti = v.view(np.int64)
        ri = scratch.view(np.int64)
        for j in range(n):
            ri[j] = np.int64(np.float64(ti[j]) * (1.0 / 3.0)) + _CBRT_BIAS
        rest = 0
        for j in range(n):
            t = v[j]
            r = scratch[j]
            r3 = r * r * r
            r = r * ((r3 + 2.0 * t) / (2.0 * r3 + t))
            r3 = r * r * r
            r = r * ((r3 + 2.0 * t) / (2.0 * r3 + t))
            dr = (r * r * r - t) / (3.0 * r * r)
            r = r - dr
            ok = (t > _CBRT_T_MIN) & (t < 1.0 / _CBRT_T_MIN) & (abs(dr) <= _CBRT_STEP_MAX * r)
            v[j] = r * r if ok else -1.0
            rest += not ok
    if rest > 0:
        e_inv = 1.0 / (alpha + 1.0)
        c = _exponent_residual(alpha + 1.0, e_inv)
        for j in range(n):
            if alpha != 0.5 or v[j] < 0.0:
                xj = x[j]
                t = to_v * (0.5 * m * xj * xj)
                vj = t**e_inv
                if c != 0.0:
                    # t^(1/A) = t^e_inv t^c, and t^c = 1 + c ln t to ~(c ln t)^2 ~ 1e-27.
                    vj = vj * (1.0 + c * math.log(t))
                v[j] = vj


@numba.njit(cache=True, error_model="numpy")
def _exponent_residual(A, e):  # pragma: no cover - compiled
    """1 / A - e for e = fl(1 / A), within an ulp of itself (Dekker's exact product A e =
    p + err, and 1 - p exact: p is within an ulp of 1; measured <= 0.5 ulp for A in 1..31).
    For A beyond ~1e150 the low part of e's split is subnormal and c loses digits (c is
    then below 1e-150: no effect on V); 0 where the split overflows (nan)."""
    p = A * e
    ta, te = _SPLIT * A, _SPLIT * e
    ah, eh = ta - (ta - A), te - (te - e)
    al, el = A - ah, e - eh
    err = ((ah * eh - p) + ah * el + al * eh) + al * el
    c = ((1.0 - p) - err) / A
    return c if abs(c) <= _EPS * e else 0.0


@numba.njit(cache=True, error_model="numpy")
def cap_nodes(x, m, q_hi, P, g, qs):  # pragma: no cover - compiled
    """`nodes` for a single cap: V in closed form, q from the cubic, U' = (alpha+1) u V'/V.

    Three passes over the nodes, none depending on another node: the powers V
    (`_cap_powers`), then the cubic by `_cap_root` (arithmetic only, which the compiler
    vectorises), then `_cap_newton` for the nodes `_cap_root` did not accept (none below
    y = 1 in practice).
    """
    kn, alpha, a, c0 = P[0, 1], P[0, 2], P[0, 3], P[0, 4]
    ia3 = 1.0 / (a * a * a)
    n = x.shape[0]
    _cap_powers(x, m, alpha, kn, qs, g)  # V into qs
    rest = 0
    for j in range(n):
        xj = x[j]
        u = 0.5 * m * xj * xj
        v = qs[j]
        q, ok = _cap_root(v / c0, a, ia3, q_hi)
        du = (alpha + 1.0) * u * (c0 * q * (2.0 * a - q)) / v
        g[j] = m * xj / du if ok else v  # V kept for the last pass
        qs[j] = q if ok else -1.0
        rest += not ok
    if rest == 0:
        return
    for j in range(n):
        if qs[j] < 0.0:
            xj = x[j]
            u = 0.5 * m * xj * xj
            v = g[j]
            q = _cap_newton(v / c0, a, q_hi)
            du = (alpha + 1.0) * u * (c0 * q * (2.0 * a - q)) / v
            g[j] = m * xj / du
            qs[j] = q
