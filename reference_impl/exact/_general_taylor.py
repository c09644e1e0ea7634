"""Taylor-series integrator for sums of power laws: a faster twin of `_general_kernel` (issue 27).

One impact m q'' + C(q) q' + U'(q) = 0 with U' = sum k_i q^p_i and C any law of
`reference_impl.theory.laws` whose exponents are multiples of 1/N (N <= `N_MAX`):
Hertz with every law of the table (N = 2; the universal law N = 4), Hooke, Tsuji; and,
through `integrate` with a factor y = (1 - beta rho^N)^alpha on U' (and on C's part
alpha_HC U'), a single volumetric cap (`_taylor_cap`).
The same signature and outputs (`OUT_FIELDS`) as `_general_kernel.solve`; cases
outside that set, creeping returns (overdamped: no return) and contacts longer than
`MAX_STEPS` steps are handed to it.

Method. Scaled overlap Q = q / L = rho^N, speed W = q' / v0, time T = t v0 / L
(L the elastic turning point), and the independent variable s of a Sundman
transformation dT/ds = N rho^(N-1):

    d rho / ds = W,    dW / ds = -N rho^(N-1) (c(rho) W + f(rho)),    dT / ds = N rho^(N-1),

with f = scaled U' and c = scaled C, polynomials in rho. The right-hand side is a
polynomial: (rho, W, T) are analytic in s over the whole contact, through the
onset (rho = 0, where q(t) is singular: q ~ v0 t - c t^(p+2)), the turning point
(W = 0, where q is singular as a function of q-like variables) and the exit, a
simple root of rho(s). The Taylor series of order `K` at each step comes from the
recurrences of products (Cauchy convolutions; powers of rho by squaring), no
derivative is approximated. About ten steps cover an impact (the GBS kernel takes
~30 steps of 57 evaluations and re-integrates each event).

Events are roots of the step's polynomials (dense output, no re-integration):
W = 0 (maximum penetration), rho = 0 (exit: T and W are stationary in s there,
dT/ds = 0 for N > 1, so the exit's location error does not reach them), the total
force F = f + c W through 0 after the turning point (the zero-force end; read as
F / rho^j0, j0 the lowest degree, so that it keeps its sign near rho = 0 instead of
vanishing; at the exit its sign is read at rho = 0 exactly, not at the exit root's
round-off; its root checked, `_taylor_force.zero_force_root`; not searched where the law never pulls, ``sc[6]``: Hunt-Crossley), and dF/ds
through 0 from above (a peak of the force).

Step and error. The radius of convergence r is estimated by the root test over the
last `_taylor_poly.WIN` coefficients of rho, W and T, each relative to its size; the step is
h = theta r with theta^(K+1) / (1 - theta) = `TOL`, the sum of a geometric tail of
the series beyond order K: its truncation, relative to the state (a looser truncation
when the caller asks for less, ``rtol``: `SC_TOL`). The error sums
reported (err_t, err_w, in the scaled units of `_general_kernel`) add these
estimates over the steps (for N = 1, where dT/ds = 1 at the exit, plus the exit's
shift e / |W|); `general_law` multiplies them by its safety factor and adds round-off.
Measured on the study's Hertz laws (v0 = 1 m/s): 9-10 steps, 2-4e-16 relative error on
every output against the 30-digit truth, the kernel ~14x faster than the GBS kernel
(`benchmarks.bench_general_taylor`).

The zero-force search skips a step on which an interval bound proves the force positive
(`_taylor_scan.force_stays_positive`), where it could find nothing: the same results, bit
for bit.

A step after its series (radius, events, scans, exit) is `_taylor_step`'s, its carried
numbers in a small array, so that the batch can step several impacts side by side with
the same operations (`_taylor_lanes`: their series in one pass).

The compiled `solve` calls the GBS kernel's compiled `solve` and the polynomial helpers of
`_taylor_poly`, and numba's disk cache of this module is keyed by this file alone: a change
of `_general_kernel`, `_general_step`, `_taylor_poly` or `_taylor_force` leaves this module's cached machine
code running the old code until this file changes too (measured: the hand-over tests then
differ from the kernel), so such a change comes with a line here (all of them are in
`reference_impl._numba_dir._COMPILED_SOURCES` too, which selects a fresh cache directory). Last: the near-critical error control (2026-11-26);
the truncation per step read from ``sc`` when an ``rtol`` is asked (2026-11-29); no
zero-force scan for a law that never pulls, the samples four at a time (2026-11-29); the
GBS kernel's exit steps end no nearer q = 0 than their length (2026-11-29); the
polynomial helpers and the radius estimate moved to `_taylor_poly`, unchanged (2026-11-29); the cap's factor
and the force and event functions in `_taylor_force` (2026-11-29); the zero-force end's
root checked and bisected where Illinois fails, `_taylor_force.zero_force_root` (2026-11-29); a
step's end read once, its three series in one pass, `_taylor_poly.horner3` (2026-11-29); the
scans' ninth sample with points 4-8 in `_taylor_poly.samples`; `law_exponents_fit` (2026-11-29); the step after its series in `_taylor_step` (2026-11-30).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.exact._general_kernel import OUT_FIELDS
from reference_impl.exact._general_kernel import solve as _gbs_solve
from reference_impl.exact._taylor_force import cap_series as _cap_series
from reference_impl.exact._taylor_poly import NS, K
from reference_impl.exact._taylor_step import (
    GO_ON,
    MAX_STEPS,  # steps before the GBS kernel takes over
    NPK,
    NST,
    ST_R,
    ST_T,
    ST_W,
)
from reference_impl.exact._taylor_step import after as _after
from reference_impl.exact._taylor_step import before as _before
from reference_impl.exact._taylor_step import constants as _constants
from reference_impl.exact._taylor_step import start as _start

__all__ = [
    "DEG_MAX",
    "K",
    "MAX_STEPS",
    "N_MAX",
    "OUT_FIELDS",
    "SC_TOL",
    "as_int",
    "common_n",
    "finish_row",
    "model",
    "scale",
    "series_plan",
    "THETA",
    "TOL",
    "integrate",
    "law_exponents_fit",
    "solve",
    "solve_taylor",
    "theta_for",
]

# Truncation per step relative to the state (the tail of the series beyond order K).
TOL = 1e-16
# Largest common denominator N of the exponents (q = L rho^N) and largest degree in rho.
N_MAX = 8
DEG_MAX = 48
# N e is taken as an integer within this (the exponents are decimal fractions like 1.5, 0.25).
_INT_TOL = 1e-12


def theta_for(tol: float) -> float:
    """theta with theta^(K+1) / (1 - theta) = tol (fixed point; converges in a few rounds):
    the step, a fraction of the radius of convergence, whose truncation is ``tol``."""
    th = tol ** (1.0 / (K + 1))
    for _ in range(20):
        th = (tol * (1.0 - th)) ** (1.0 / (K + 1))
    return th


THETA = theta_for(TOL)
# Where the scalars ``sc`` of a solve carry a looser truncation and its theta (an ``rtol``
# asked, `reference_impl.exact._rtol.taylor_tol`): sc[SC_TOL], sc[SC_TOL + 1]. An ``sc`` of
# SC_TOL entries (no rtol) runs at TOL and THETA, bit for bit as before the argument.
SC_TOL = 7
# A sum of powers has no cap factor (`integrate`: cp None, CY = 0, read as a constant).
_NO_CY = np.zeros(DEG_MAX + 1)
_RECIP = 1.0 / np.arange(1.0, K + 1.0)  # 1 / (n + 1): a multiply, not a divide, in the recurrences


@numba.njit(cache=True, error_model="numpy")
def _as_int(x):
    """round(x) when x is a non-negative integer within _INT_TOL, else -1."""
    r = math.floor(x + 0.5)
    if r < 0 or abs(x - r) > _INT_TOL * max(1.0, abs(x)):
        return -1
    return int(r)


as_int = _as_int  # for the cap's model (`_taylor_cap`)


@numba.njit(cache=True, error_model="numpy")
def common_n(ks, ps, cs, es, sc):
    """Smallest N <= N_MAX making every exponent of f and c an integer multiple of 1/N, or 0."""
    A, zf = sc[2], sc[3]
    for N in range(1, N_MAX + 1):
        ok = True
        for i in range(ps.shape[0]):
            if _as_int(N * ps[i]) < 0:
                ok = False
            if A != 0.0 and _as_int(N * (ps[i] - 1.0)) < 0:
                ok = False
            if zf != 0.0 and _as_int(N * (ps[i] - 1.0) / 2.0) < 0:
                ok = False
        if not law_exponents_fit(N, cs, es):
            ok = False
        if ok:
            return N
    return 0


@numba.njit(cache=True, error_model="numpy")
def law_exponents_fit(N, cs, es):
    """N e_j an integer for every term c_j q^e_j of C, c_j != 0 (also the cap's N test)."""
    for j in range(cs.shape[0]):
        if cs[j] != 0.0 and _as_int(N * es[j]) < 0:
            return False
    return True


@numba.njit(cache=True, error_model="numpy")
def scale(v0, qE, ks, ps, m):
    """The elastic turning point L: sum k L^(p+1) / (p+1) = m v0^2 / 2 (Newton from qE >= L)."""
    E = 0.5 * m * v0 * v0
    if ks.shape[0] == 1:
        return ((ps[0] + 1.0) * E / ks[0]) ** (1.0 / (ps[0] + 1.0))
    L = qE
    for _ in range(60):
        g = -E
        dg = 0.0
        for i in range(ks.shape[0]):
            lp = L ** ps[i]
            g += ks[i] * lp * L / (ps[i] + 1.0)
            dg += ks[i] * lp
        step = g / dg
        L -= step
        if abs(step) <= 1e-13 * L:
            break
    return L


@numba.njit(cache=True, error_model="numpy")
def model(v0, L, N, ks, ps, cs, es, sc):
    """Scaled polynomials f(rho) (U') and c(rho) (C), by degree; None-like (empty) if unfit."""
    m, alpha, A, zf = sc[0], sc[1], sc[2], sc[3]
    f = np.zeros(DEG_MAX + 1)
    c = np.zeros(DEG_MAX + 1)
    if zf != 0.0 and ks.shape[0] != 1:
        return f[:0], c[:0]
    for i in range(ks.shape[0]):
        d = _as_int(N * ps[i])
        if d > DEG_MAX:
            return f[:0], c[:0]
        a = ks[i] * L ** (ps[i] + 1.0) / (m * v0 * v0)
        f[d] += a
        if alpha != 0.0:
            c[d] += alpha * v0 * a
        if A != 0.0:
            c[_as_int(N * (ps[i] - 1.0))] += A * v0 / L * a * ps[i]
        if zf != 0.0:
            c[_as_int(N * (ps[i] - 1.0) / 2.0)] += (
                zf * math.sqrt(ks[i] * (ps[i] + 1.0) / 2.0) * L ** ((ps[i] + 1.0) / 2.0) / (m * v0)
            )
    for j in range(cs.shape[0]):
        if cs[j] != 0.0:
            d = _as_int(N * es[j])
            if d > DEG_MAX:
                return f[:0], c[:0]
            c[d] += cs[j] * L ** (es[j] + 1.0) / (m * v0)
    return f, c


@numba.njit(cache=True, error_model="numpy")
def _series(N, FN, CN, fidx, cidx, plan, P, CS, R, W, T, r0, w0, t0, CYN, cyidx, cp, X):
    """Taylor coefficients 0..K of (rho, W, T) at (r0, w0, t0); FN, CN = N rho^(N-1) f, c;
    P (flat, rows of K + 1) receives the series of the powers rho^j.

    With a cap's factor (``cp`` = (beta, alpha), `_taylor_force.cap_factor`; None for a
    sum of powers), f = FN y and c = CN + CYN y with y = (1 - beta rho^N)^alpha: X's rows receive the series of h = 1 - beta rho^N, y
    (the power recurrence k h0 y_k = sum_{j=1..k} (alpha j - (k - j)) h_j y_(k-j)), and
    the polynomial parts FN and CYN before their product with y."""
    R[0], W[0], T[0] = r0, w0, t0
    M = K + 1
    for n in range(K):
        P[M + n] = R[n]
        for ii in range(plan.shape[0]):
            j = plan[ii]
            s = 0.0
            if j % 2 == 0:  # a square: each cross term once, doubled
                o = (j // 2) * M
                for i in range((n + 1) // 2):
                    s += P[o + i] * P[o + n - i]
                s *= 2.0
                if n % 2 == 0:
                    s += P[o + n // 2] * P[o + n // 2]
            else:
                o = (j - 1) * M
                for i in range(n + 1):
                    s += P[o + i] * R[n - i]
            P[j * M + n] = s
        fn = 0.0
        for ii in range(fidx.shape[0]):
            fn += FN[fidx[ii]] * P[fidx[ii] * M + n]
        cn = 0.0
        for ii in range(cidx.shape[0]):
            cn += CN[cidx[ii]] * P[cidx[ii] * M + n]
        # a cap: f = (FN) y, c = CN + (CYN) y; a sum of powers passes cp = None, a branch
        # numba prunes when it compiles that case (measured: the branch cost ~1 us of ~22)
        if cp is not None:
            fn, cn = _cap_series(n, N, M, P, fn, cn, CYN, cyidx, cp[0], cp[1], X)
        CS[n] = cn
        cw = 0.0
        for i in range(n + 1):
            cw += CS[i] * W[n - i]
        W[n + 1] = -(cw + fn) * _RECIP[n]
        R[n + 1] = W[n] * _RECIP[n]
        T[n + 1] = N * P[(N - 1) * M + n] * _RECIP[n]


@numba.njit(cache=True, error_model="numpy")
def solve_taylor(v0, qE, ks, ps, cs, es, sc, out):
    """One impact into ``out`` (`OUT_FIELDS`); returns 0, or 1 when the case is not for
    this method (exponents, degree, no return within MAX_STEPS): ``out`` is then void."""
    m = sc[0]
    N = common_n(ks, ps, cs, es, sc)
    if N == 0:
        return 1
    L = scale(v0, qE, ks, ps, m)
    F, C = model(v0, L, N, ks, ps, cs, es, sc)
    if F.shape[0] == 0:
        return 1
    if integrate(v0, L, N, F, C, _NO_CY, None, sc, out, None) != 0:
        return 1
    finish_row(out, ks, ps, L, qE)
    return 0


@numba.njit(cache=True, error_model="numpy")
def finish_row(out, ks, ps, L, qE):
    """A sum of powers' row once integrated: U'(q_max), and the time bound in units of qE / v0."""
    qm = out[1]
    fm = 0.0
    for i in range(ks.shape[0]):
        fm += ks[i] * qm ** ps[i]
    out[2] = fm
    out[9] = out[9] * L / qE


@numba.njit(cache=True, error_model="numpy", inline="always")
def series_plan(N, F, C, CY, capped):
    """What the series of the scaled model F, C, CY (by degree in rho) need: the highest
    and lowest degree D, j0 of its terms; the right-hand side's polynomials FN, CN, CYN
    (N rho^(N-1) times f, c and the cap's part); the degrees of their nonzero terms fidx,
    cidx, cyidx; and ``plan``, the powers of rho whose series are formed, lowest first
    (each by squaring, or one more factor of rho)."""
    D = 0
    j0 = DEG_MAX
    for j in range(DEG_MAX + 1):
        if F[j] != 0.0 or C[j] != 0.0 or CY[j] != 0.0:
            D = j
            j0 = min(j0, j)
    # the right-hand side's polynomials N rho^(N-1) f and N rho^(N-1) c
    DN = D + N - 1
    FN = np.zeros(DN + 1)
    CN = np.zeros(DN + 1)
    CYN = np.zeros(DN + 1)
    nf = 0
    nc = 0
    ny = 0
    for j in range(D + 1):
        FN[j + N - 1] = N * F[j]
        CN[j + N - 1] = N * C[j]
        CYN[j + N - 1] = N * CY[j]
        nf += F[j] != 0.0
        nc += C[j] != 0.0
        ny += CY[j] != 0.0
    fidx = np.empty(nf, np.int64)
    cidx = np.empty(nc, np.int64)
    cyidx = np.empty(ny, np.int64)
    nf = 0
    nc = 0
    ny = 0
    need = np.zeros(DN + 2, np.bool_)
    for j in range(DN + 1):
        if FN[j] != 0.0:
            fidx[nf] = j
            nf += 1
            need[j] = True
        if CN[j] != 0.0:
            cidx[nc] = j
            nc += 1
            need[j] = True
        if CYN[j] != 0.0:
            cyidx[ny] = j
            ny += 1
            need[j] = True
    need[N - 1] = True
    if capped:  # h = 1 - beta rho^N reads the series of rho^N
        need[N] = True
    # powers of rho by squaring (even) or one more factor (odd), lowest first
    for j in range(DN, 1, -1):
        if need[j]:
            if j % 2 == 0:
                need[j // 2] = True
            else:
                need[j - 1] = True
    npl = 0
    for j in range(2, DN + 1):
        npl += need[j]
    plan = np.empty(npl, np.int64)
    npl = 0
    for j in range(2, DN + 1):
        if need[j]:
            plan[npl] = j
            npl += 1
    return D, j0, FN, CN, CYN, fidx, cidx, cyidx, plan


@numba.njit(cache=True, error_model="numpy")
def integrate(v0, L, N, F, C, CY, cp, sc, out, X):
    """One impact of the scaled model into ``out`` (`OUT_FIELDS` but ``max_force``, out[2],
    left to the caller); returns 0, or 1 when the case is not for this method (no return
    within MAX_STEPS, a radius not finite): ``out`` is then void.

    ``L`` is the scale of q (m), ``N`` the power q = L rho^N, ``F``, ``C`` and ``CY`` the
    polynomials in rho (by degree, `DEG_MAX` + 1) of the scaled U', C and of C's part
    multiplied by the cap's factor, ``cp`` = (beta, alpha) that factor
    y = (1 - beta rho^N)^alpha (None: sums of powers, y = 1, CY = 0: every operation as
    before the factor, the cap's branches pruned when numba compiles it), ``sc`` the law's scalars (`_general_contact.law_arrays`), ``X``
    the cap's work array, shape (4, K + 1) (`_cap_series`), or None for a sum of powers."""
    tol, theta = TOL, THETA
    if sc.shape[0] > SC_TOL:
        tol, theta = sc[SC_TOL], sc[SC_TOL + 1]
    capped = cp is not None
    D, j0, FN, CN, CYN, fidx, cidx, cyidx, plan = series_plan(N, F, C, CY, capped)
    DN = D + N - 1
    P = np.zeros((max(DN, 1) + 1) * (K + 1))  # row j: the series of rho^j
    P[0] = 1.0
    CS = np.zeros(K + 1)
    R = np.zeros(K + 1)
    W = np.zeros(K + 1)
    T = np.zeros(K + 1)
    pw = np.empty(K + 1)
    xs = np.empty(NS + 1)
    rs = np.empty(NS + 1)
    ws = np.empty(NS + 1)
    pk = np.empty(NPK)
    _constants(pk, v0, L, N, F, C, CY, cp, D, sc, tol, theta)
    st = np.empty(NST)
    _start(st, C[0] + CY[0] if capped else C[0])  # the force just after contact, C(0) v0
    while True:
        code = _before(st, pk, N, F, C, CY, cp, D, out)
        if code != GO_ON:
            return code
        r0, w0, t0 = st[ST_R], st[ST_W], st[ST_T]
        _series(N, FN, CN, fidx, cidx, plan, P, CS, R, W, T, r0, w0, t0, CYN, cyidx, cp, X)
        code = _after(st, pk, R, W, T, pw, xs, rs, ws, N, F, C, CY, cp, j0, D, CN, FN, CYN, out)
        if code != GO_ON:
            return code


@numba.njit(cache=True, error_model="numpy")
def solve(v0, qE, ks, ps, cs, es, sc):
    """One impact, as `_general_kernel.solve` (same arguments, `OUT_FIELDS`): by the Taylor
    method where it applies (module docstring), else by the GBS kernel."""
    out = np.full(len(OUT_FIELDS), np.nan)
    if solve_taylor(v0, qE, ks, ps, cs, es, sc, out) == 0:
        return out
    return _gbs_solve(v0, qE, ks, ps, cs, es, sc)
