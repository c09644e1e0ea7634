"""The Taylor kernel's force and event functions, and the series of a cap's factor (issue 38).

Split from `reference_impl.exact._general_taylor` (its stepping stays there): the scaled
total force G = f(rho) + c(rho) W of a step (`force`, its derivative in s `dforce`), the
event functions and their root (`event`, `root`: Illinois on a step's polynomials), and,
for a volumetric cap (`reference_impl.exact._taylor_cap`), the factor y = h^alpha,
h = 1 - beta rho^N on U' (``cp`` = (beta, alpha); None for sums of powers, where every
function runs the operations it ran before the factor, bit for bit: numba compiles that
case with the cap's branches pruned): its value
(`cap_factor`), (f, c) at a point (`fc`) and its Taylor series (`cap_series`).
"""

from __future__ import annotations

import math

import numba

from reference_impl.exact._taylor_poly import horner as _horner
from reference_impl.exact._taylor_poly import poly as _poly
from reference_impl.exact._taylor_poly import poly_d as _poly_d
from reference_impl.exact._taylor_poly import rw as _rw

__all__ = ["cap_factor", "cap_series", "dforce", "event", "zero_force_root", "fc", "force", "root"]

# Root iterations (Illinois: superlinear; a float bracket needs < 2 x 53 halvings).
_ROOT_ITER = 120


@numba.njit(cache=True, error_model="numpy")
def cap_series(n, N, M, P, fn, cn, CYN, cyidx, hb, ha, X):
    """Order n of f = FS y and c = cn + CYS y (`_series` with a cap's factor): X rows 0 h,
    1 y = h^ha, 2 FS (the series of FN alone), 3 CYS; ``fn``, ``cn`` the polynomial parts.
    O(n) per order: three Cauchy sums and the power recurrence of y."""
    H, Y, FS, CYS = X[0], X[1], X[2], X[3]
    cy = 0.0
    for ii in range(cyidx.shape[0]):
        cy += CYN[cyidx[ii]] * P[cyidx[ii] * M + n]
    FS[n] = fn
    CYS[n] = cy
    if n == 0:
        H[0] = 1.0 - hb * P[N * M]
        Y[0] = math.sqrt(H[0]) if ha == 0.5 else H[0] ** ha
    else:
        H[n] = -hb * P[N * M + n]
        acc = 0.0
        for j in range(1, n + 1):
            acc += (ha * j - (n - j)) * H[j] * Y[n - j]
        Y[n] = acc / (n * H[0])
    f = 0.0
    c = 0.0
    for i in range(n + 1):
        f += FS[i] * Y[n - i]
        c += CYS[i] * Y[n - i]
    return f, cn + c


@numba.njit(cache=True, error_model="numpy")
def cap_factor(cp, N, r):
    """(y, dy/drho) of the cap's factor y = h^alpha, h = 1 - beta rho^N (``cp`` = (beta,
    alpha)); (1, 0) for sums of powers (``cp`` None)."""
    if cp is None:
        return 1.0, 0.0
    hb, ha = cp[0], cp[1]
    rn1 = 1.0
    for _ in range(N - 1):
        rn1 *= r
    h = 1.0 - hb * rn1 * r
    y = math.sqrt(h) if ha == 0.5 else h**ha
    return y, -ha * y * hb * N * rn1 / h


@numba.njit(cache=True, error_model="numpy")
def fc(F, C, CY, cp, N, D, r):
    """(f, c) at rho: the scaled U' and C (with a cap's factor, f = F y, c = C + CY y)."""
    if cp is None:
        return _poly(F, 0, D, r), _poly(C, 0, D, r)
    y = cap_factor(cp, N, r)[0]
    return _poly(F, 0, D, r) * y, _poly(C, 0, D, r) + _poly(CY, 0, D, r) * y


@numba.njit(cache=True, error_model="numpy")
def force(F, C, CY, cp, N, j0, D, r, w):
    """(G, G / rho^j0) with G = f(rho) + c(rho) W, the scaled total force."""
    if cp is None:
        g0 = _poly(F, j0, D, r) + _poly(C, j0, D, r) * w
    else:
        y = cap_factor(cp, N, r)[0]
        g0 = _poly(F, j0, D, r) * y + (_poly(C, j0, D, r) + _poly(CY, j0, D, r) * y) * w
    rj = 1.0
    for _ in range(j0):
        rj *= r
    return g0 * rj, g0


@numba.njit(cache=True, error_model="numpy")
def dforce(F, C, CY, cp, N, D, r, w):
    """dG/ds = (f'(rho) + c'(rho) W) W - c(rho) N rho^(N-1) G."""
    f, df = _poly_d(F, D, r)
    c, dc = _poly_d(C, D, r)
    if cp is not None:  # f = F y, c = C + CY y
        y, dy = cap_factor(cp, N, r)
        cy, dcy = _poly_d(CY, D, r)
        f, df = f * y, df * y + f * dy
        c, dc = c + cy * y, dc + dcy * y + cy * dy
    G = f + c * w
    rn = 1.0
    for _ in range(N - 1):
        rn *= r
    return (df + dc * w) * w - c * N * rn * G


@numba.njit(cache=True, error_model="numpy")
def event(kind, R, W, F, C, CY, cp, N, j0, D, x):
    """Event functions at x along the step: 0 rho, 1 W, 2 G / rho^j0, 3 dG/ds."""
    if kind == 0:
        return _horner(R, x)
    if kind == 1:
        return _horner(W, x)
    r, w = _rw(R, W, x)
    if kind == 2:
        return force(F, C, CY, cp, N, j0, D, r, w)[1]
    return dforce(F, C, CY, cp, N, D, r, w)


@numba.njit(cache=True, error_model="numpy")
def root(kind, R, W, F, C, CY, cp, N, j0, D, a, b, ga, gb, rtol):
    """x in [a, b] where event ``kind`` goes from ga > 0 to gb <= 0 (Illinois), to a
    bracket of rtol relative (two ulps, 4.5e-16, where the output moves with x)."""
    side = 0
    x = b
    for _ in range(_ROOT_ITER):
        x = (a * gb - b * ga) / (gb - ga)
        if not (a < x < b):
            x = 0.5 * (a + b)
        g = event(kind, R, W, F, C, CY, cp, N, j0, D, x)
        if g > 0.0:
            a, ga = x, g
            if side == 1:
                gb *= 0.5
            side = 1
        else:
            b, gb = x, g
            if side == -1:
                ga *= 0.5
            side = -1
        # two ulps: the bracket cannot shrink further
        if b - a <= rtol * max(abs(a), abs(b)) or g == 0.0:
            break
    return x


@numba.njit(cache=True, error_model="numpy")
def _zf(R, W, F, C, CY, cp, N, j0, D, x):
    """G / rho^j0 at x along the step, rho read as 0 where its polynomial rounds below 0
    (only at the exit, within its root's bracket: the sign there is the exit's)."""
    r, w = _rw(R, W, x)
    return force(F, C, CY, cp, N, j0, D, max(r, 0.0), w)[1]


@numba.njit(cache=True, error_model="numpy")
def zero_force_root(R, W, F, C, CY, cp, N, j0, D, a, b, ga, gb, rtol, at_exit):
    """x in [a, b] where G / rho^j0 goes from ga > 0 to gb <= 0: `root` (Illinois); where
    b is the exit (``at_exit``: gb read at rho = 0), kept only where G / rho^j0 is > 0 just
    before it and <= 0 just after (2 rtol of x either side, rho >= 0), else bisection to
    adjacent floats.

    Illinois fails where the end value is ~0 against the other: a zero-force end at a
    tiny overlap just before the exit (C = c0 + c1 q, c0 = 3.6e-291: the end, read at
    rho = 0, is c0 W = -6e-291 against ga ~ 5e-5). Its secant lands on the exit itself,
    where rho rounds to -3e-17 and c0 W + c1 rho W read > 0 moved the bracket onto the
    exit (found at rtol 1e-10: a crossing at rho = 8e-9, 5.5e-10 s before the exit,
    reported at it); or it creeps from that end by ulps with ga halved each time. The
    check costs two evaluations; a result it keeps is `root`'s, bit for bit. The other
    brackets end at a sample at rho > 0, a value of its own, and keep `root`'s result
    unchecked: the check also fails where G's rounding flickers its sign within 2 rtol of
    a right root (44 of 3036 impacts of every law, whose bisection moved t_zf by an ulp),
    and those results stay bit for bit."""
    x = root(2, R, W, F, C, CY, cp, N, j0, D, a, b, ga, gb, rtol)
    if not at_exit:
        return x
    d = 2.0 * rtol * abs(x)
    lo, hi = x - d, x + d
    if (lo <= a or _zf(R, W, F, C, CY, cp, N, j0, D, lo) > 0.0) and (
        hi >= b or _zf(R, W, F, C, CY, cp, N, j0, D, hi) <= 0.0
    ):
        return x
    for _ in range(2 * _ROOT_ITER):  # ~60 halvings of a sample interval to adjacent floats
        x = 0.5 * (a + b)
        if not (a < x < b):
            break
        if _zf(R, W, F, C, CY, cp, N, j0, D, x) > 0.0:
            a = x
        else:
            b = x
    return b
