"""The compiled DOP853 peer on the Sundman-regularised equations (issue 38, goal 1): numba.

The strongest explicit peer measured for power-law contacts: DOP853 (the stepping core
`benchmarks._dop853_core`, shared with `benchmarks.peer_dop853`) on the transformation
that `reference_impl.exact._general_taylor` documents for its own kernel. With L the
elastic turning point (sum a_i L^(b_i+1) / (b_i+1) = m v0^2 / 2), the scaled overlap
Q = q / L = rho^N, speed W = q' / v0, time T = t v0 / L and the independent variable s
of dT/ds = N rho^(N-1):

    d rho / ds = W,    dW / ds = -N rho^(N-1) (c(rho) W + f(rho)),    dT / ds = N rho^(N-1),

f = L U'(L rho^N) / (m v0^2) and c = L C(L rho^N) / (m v0) the scaled force and damping.
A term a q^b of U' is a rho^(N b), a term c q^e of C is c rho^(N e): the right-hand
side is a polynomial in (rho, W) when N b and N e are integers, N chosen per law by
`sundman_n` (the smallest N <= `N_MAX`). On Hertz (U' = k q^1.5):

=====================================  ======================  ===
law                                    C(q)                    N
=====================================  ======================  ===
universal (Tsuji's q^(1/4) form)       ~ U' / sqrt(2 U) ~ q^(1/4)  4
power with exponent 1/4 (Tsuji)        c q^(1/4)               4
linear dashpot                         c                       2
power (e = 1), polynomial (c0 + c1 q)  c q, c0 + c1 q          2
viscoelastic (A U'')                   A k 1.5 q^(1/2)         2
Hunt-Crossley (alpha U')               alpha k q^(3/2)         2
=====================================  ======================  ===

Where it is not a polynomial, and what is done there: a power law whose exponent needs
N > `N_MAX` (e.g. C = c q^0.3 on Hertz) keeps N from the elastic terms and evaluates
|rho|^(N e) by pow (the even extension past the exit, rho < 0); the universal law on a
*sum* of power terms (U' / sqrt(2 U) is no monomial) evaluates that ratio at
q = L rho^N from the physical terms, with N making the leading exponents integral (the
ratio is analytic in rho there). Caps (sphere, ellipsoid) are not run (`sundman_n`
returns 0): their U is no power of q.

Every output of the exact solvers, as `benchmarks.peer_dop853` (`OUT_FIELDS`, physical
units): the overlap end (rho through 0, a simple root in s, where T and W are
stationary for N > 1, so its location error barely reaches them), the zero-force end
(F / U' = 1 + c W / f through 0), q_max = L rho^N (W through 0) and U'(q_max), and the
peak force (dF/ds = W (f' + c' W) + c dW/ds through 0, the sign of dF/dt inside the
contact), each on the dense output of the step that crosses it. The tolerances act on
the scaled state (rho, W, T), each of order 1: atol = rtol.
"""

from __future__ import annotations

import math
import sys

import numba
import numpy as np

from ._dop853_core import OUT_FIELDS, integrate
from .peer_dop853 import _KIND_POWER, _Q_ONSET, _elastic, _force

__all__ = ["N_MAX", "OUT_FIELDS", "S_BOUND", "solve_sundman", "sundman_n"]

# Largest N tried: the table's exponents (decimals like 1.5, 0.25) need 2 or 4.
N_MAX = 8
# N x exponent counts as an integer within this (exponents are decimal fractions).
_INT_TOL = 1e-12
# Largest power of rho kept in the per-evaluation table (rho^0 .. rho^_DMAX by products);
# a higher integer power (none in the table laws on Hertz) is computed by `**`.
_DMAX = 24
# Scaled independent variable at which a contact without an end is abandoned (status 1):
# a Hertz contact takes s ~ 2-4 (rho goes 0 -> 1 -> 0 at |d rho / ds| <= 1), but a strongly
# damped return drifts out at d rho / ds = W ~ -e: the universal law at zeta = 0.85
# (e ~ 6e-3) needs s ~ 1e2-1e3 (50 left 4 of 200 such impacts without an end, measured).
S_BOUND = 1e4
# See `benchmarks.peer_dop853._M`: model functions named through the module, so that
# numba caches the kernel.
_M = sys.modules[__name__]


def _is_int(x: float) -> bool:
    return abs(x - round(x)) <= _INT_TOL * max(1.0, abs(x))


def sundman_n(EL: np.ndarray, DA: np.ndarray, zeta: float) -> int:
    """N of the transformation q = L rho^N for tables of `benchmarks.peer_dop853`, or 0.

    The smallest N <= `N_MAX` making every exponent of f and c (and the universal law's
    (b - 1) / 2 of the lowest elastic exponent b) an integer multiple of 1/N; where no
    such N exists, the smallest making the elastic exponents integral (the rest then by
    pow; see the module docstring). 0 where the elastic table has a row that is not a
    power term (a cap), or no N makes the elastic exponents integral.
    """
    if EL.shape[0] == 0 or np.any(EL[:, 0] != _KIND_POWER):
        return 0
    bs = [float(b) for b in EL[:, 2]]
    es = [float(e) for e in DA[:, 1]]
    if zeta > 0.0:
        es.append(0.5 * (min(bs) - 1.0))
    elastic = [n for n in range(1, N_MAX + 1) if all(_is_int(n * b) for b in bs)]
    if not elastic:
        return 0
    for n in elastic:
        if all(_is_int(n * e) for e in es):
            return n
    return elastic[0]


@numba.njit(cache=True, error_model="numpy")
def _powers(rho, pw, dmax):  # pragma: no cover - compiled
    """pw[j] = rho^j, j = 0 .. dmax, by products."""
    pw[0] = 1.0
    for j in range(1, dmax + 1):
        pw[j] = pw[j - 1] * rho


@numba.njit(cache=True, error_model="numpy")
def _mono(rho, pw, dmax, d, di):  # pragma: no cover - compiled
    """rho^d: from the table where d = di is an integer <= dmax, else by pow."""
    if di >= 0:
        return pw[di] if di <= dmax else rho**di
    return abs(rho) ** d


@numba.njit(cache=True, error_model="numpy")
def _poly(rho, pw, dmax, T, deriv):  # pragma: no cover - compiled
    """sum T[i, 0] rho^T[i, 1] (T[i, 2]: the integer degree, -1 if none), or its
    derivative in rho (deriv True)."""
    acc = 0.0
    for i in range(T.shape[0]):
        co, d, di = T[i, 0], T[i, 1], int(T[i, 2])
        if not deriv:
            acc += co * _mono(rho, pw, dmax, d, di)
        elif d != 0.0:
            acc += co * d * _mono(rho, pw, dmax, d - 1.0, di - 1 if di > 0 else -1)
    return acc


@numba.njit(cache=True, error_model="numpy")
def _fc(y, P):  # pragma: no cover - compiled
    """(f, c, N rho^(N-1)) at the state y: scaled force, damping, dT/ds."""
    N, FT, CT, uni, pw, dmax, m, zeta, EL, DA, L, v0, Fs = P
    rho = y[0]
    _powers(rho, pw, dmax)
    f = _poly(rho, pw, dmax, FT, False)
    c = _poly(rho, pw, dmax, CT, False)
    if uni != 0.0 and rho != 0.0:  # the universal law on a sum: not a polynomial
        u, du, _d2u = _elastic(L * abs(rho) ** N, EL)
        if u > 0.0:
            c += uni * du / math.sqrt(2.0 * u)
    return f, c, N * _mono(rho, pw, dmax, N - 1.0, N - 1)  # N: an int


@numba.njit(cache=True, error_model="numpy")
def _rhs(y, P, dy):  # pragma: no cover - compiled
    f, c, dts = _fc(y, P)
    dy[0] = y[1]
    dy[1] = -dts * (c * y[1] + f)
    dy[2] = dts


@numba.njit(cache=True, error_model="numpy")
def _event(kind, y, P):  # pragma: no cover - compiled
    """0: rho, 1: W, 2: F / U' = 1 + c W / f, 3: dF/ds (-1 for the universal law)."""
    if kind == 0:
        return y[0]
    if kind == 1:
        return y[1]
    zeta = P[7]
    if kind == 3 and zeta != 0.0:
        return -1.0
    f, c, dts = _fc(y, P)
    w = y[1]
    if kind == 2:
        return (f + c * w) / f
    FT, CT, pw, dmax = P[1], P[2], P[4], P[5]
    df = _poly(y[0], pw, dmax, FT, True)
    dc = _poly(y[0], pw, dmax, CT, True)
    return w * (df + dc * w) - c * dts * (c * w + f)


@numba.njit(cache=True, error_model="numpy")
def _events(y, P, g):  # pragma: no cover - compiled
    g[0], g[1] = y[0], y[1]
    g[2] = _event(2, y, P)
    g[3] = _event(3, y, P)


@numba.njit(cache=True, error_model="numpy")
def _observe(s, y, P):  # pragma: no cover - compiled
    """(t, q, q', F, U'(q)) in physical units at the state y."""
    N, L, v0, Fs = P[0], P[10], P[11], P[12]
    f, c, _dts = _fc(y, P)
    rho = max(y[0], 0.0)
    return y[2] * L / v0, L * rho**N, v0 * y[1], Fs * (f + c * y[1]), Fs * f


@numba.njit(cache=True, error_model="numpy")
def _onset(y, P):  # pragma: no cover - compiled
    """The physical force and the sign of dF/dt at q = 0+ (`benchmarks.peer_dop853`'s)."""
    m, zeta, EL, DA, v0 = P[6], P[7], P[8], P[9], P[11]
    f, df, _du = _force(_Q_ONSET, v0, m, zeta, EL, DA)
    return f, (df if zeta == 0.0 else -1.0)


@numba.njit(cache=True, error_model="numpy")
def _turning_point(E, EL):  # pragma: no cover - compiled
    """L with sum a L^(b+1) / (b+1) = E (power rows): closed form for one, else Newton
    from the smallest single-term root (>= L: the sum is increasing and convex in L)."""
    L = np.inf
    for i in range(EL.shape[0]):
        a, b = EL[i, 1], EL[i, 2]
        L = min(L, ((b + 1.0) * E / a) ** (1.0 / (b + 1.0)))
    if EL.shape[0] == 1:
        return L
    for _ in range(60):
        g = -E
        dg = 0.0
        for i in range(EL.shape[0]):
            a, b = EL[i, 1], EL[i, 2]
            lb = a * L**b
            g += lb * L / (b + 1.0)
            dg += lb
        step = g / dg
        L -= step
        if abs(step) <= 1e-16 * L:
            break
    return L


@numba.njit(cache=True, error_model="numpy")
def _row(T, i, co, d):  # pragma: no cover - compiled
    T[i, 0], T[i, 1] = co, d
    r = math.floor(d + 0.5)
    T[i, 2] = r if (r >= 0 and abs(d - r) <= _INT_TOL * max(1.0, d)) else -1.0


@numba.njit(cache=True, error_model="numpy")
def solve_sundman(m, v0, zeta, EL, DA, N, rtol, s_bound, h_first, out):
    """One impact from q = 0, q' = v0 until q falls back to 0, on the regularised system.

    Parameters
    ----------
    m : float
        Mass (kg).
    v0 : float
        Impact speed (m/s).
    zeta : float
        The universal law's damping ratio (0 for the laws of ``DA``).
    EL, DA : ndarray
        `benchmarks.peer_dop853.elastic_table` (power rows only) and `damping_table`.
    N : int
        The transformation's N (`sundman_n`, >= 1).
    rtol : float
        Relative tolerance; atol = rtol on the scaled state (rho, W, T), each O(1).
    s_bound : float
        Largest scaled s (`S_BOUND`).
    h_first : float
        First step in s; <= 0 selects it by Hairer's rule.
    out : ndarray
        Receives `OUT_FIELDS` (s, m/s, m, N); returned.
    """  # pragma: no cover - compiled
    L = _turning_point(0.5 * m * v0 * v0, EL)
    Fs = m * v0 * v0 / L  # force scale: F = Fs f
    Cs = L / (m * v0)  # damping scale: c = Cs C
    FT = np.empty((EL.shape[0], 3))
    dmax = N - 1
    for i in range(EL.shape[0]):
        a, b = EL[i, 1], EL[i, 2]
        _row(FT, i, a * L**b / Fs, N * b)
    single = zeta > 0.0 and EL.shape[0] == 1
    CT = np.empty((DA.shape[0] + (1 if single else 0), 3))
    for j in range(DA.shape[0]):
        c, e = DA[j, 0], DA[j, 1]
        _row(CT, j, Cs * c * L**e, N * e)
    uni = 0.0
    if single:
        # C = 2 zeta sqrt(m) sqrt(a (b+1) / 2) q^((b-1)/2) for U' = a q^b
        a, b = EL[0, 1], EL[0, 2]
        cu = 2.0 * zeta * math.sqrt(m) * math.sqrt(0.5 * a * (b + 1.0))
        _row(CT, DA.shape[0], Cs * cu * L ** (0.5 * (b - 1.0)), 0.5 * N * (b - 1.0))
    elif zeta > 0.0:
        uni = Cs * 2.0 * zeta * math.sqrt(m)
    for T in (FT, CT):
        for i in range(T.shape[0]):
            dmax = max(dmax, int(T[i, 2]))
    dmax = min(dmax, _DMAX)
    pw = np.empty(_DMAX + 1)
    P = (N, FT, CT, uni, pw, dmax, m, zeta, EL, DA, L, v0, Fs)
    y0 = np.array([0.0, 1.0, 0.0])
    atol = np.array([rtol, rtol, rtol])
    return integrate(
        _M._rhs, _M._events, _M._event, _M._observe, _M._onset, y0, P, rtol, atol, s_bound,
        h_first, out,
    )  # fmt: skip
