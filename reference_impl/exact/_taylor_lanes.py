"""Many impacts of one sum of power laws through the Taylor kernel, `LANES` side by side.

The batch of `solve_impacts` (`_law_batch`) solves many speeds of one potential and one
law. Their scaled models differ in values only: the same degrees, the same powers of rho,
so their series follow one recurrence. Here `LANES` impacts step together: their series
are formed in one pass (`_taylor_lanes_series`, one chain of multiply-adds per lane in the
same loop body), and each lane then takes its own step (`_taylor_step.after`: its radius,
events and scans). A lane whose impact ends takes the next speed. Every lane's operations
are the single impact's (`_general_taylor.solve_taylor`), so each row is bit for bit that
of `_general_taylor.solve` (test), whatever lane, neighbours or order.

An impact whose series differ in structure from the first (a coefficient that is zero
at one speed only), or whose model is not for the Taylor method (exponents, degree), is
marked for the single call (`codes` 1), which runs it as `_general_taylor.solve` does.
One the Taylor method hands over on the way (no return within the step budget; a radius
not finite) is marked `HANDED` (2): `solve_taylor` hands it over alike, bit for bit, so
its row is the GBS kernel's (`_general_taylor.solve`), without running the Taylor steps
again.

Measured (Hertz, 20 000 speeds 0.1-10 m/s, one thread): the series were ~47 % of an
impact, ~0.85 us each; side by side they cost ~0.36 us a lane.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.exact._general_taylor import (
    _NO_CY,
    DEG_MAX,
    N_MAX,
    OUT_FIELDS,
    SC_TOL,
    THETA,
    TOL,
    common_n,
    finish_row,
    model,
    scale,
    series_plan,
)
from reference_impl.exact._taylor_lanes_series import LANES, series_lanes
from reference_impl.exact._taylor_poly import NS, K
from reference_impl.exact._taylor_step import GO_ON, NPK, NST, PK_L, after, before, constants, start

__all__ = ["HANDED", "LANES", "solve_lanes"]

# `codes` of a speed that the Taylor method handed over in its lane (`solve_lanes`).
HANDED = 2

_NF = len(OUT_FIELDS)
_DN_MAX = DEG_MAX + N_MAX  # the right-hand side's degree: D + N - 1 < DEG_MAX + N_MAX


@numba.njit(cache=True, error_model="numpy")
def solve_lanes(v, q_top, ks, ps, cs, es, sc, rows, codes):  # pragma: no cover - compiled
    """``rows[i]`` = the kernel row (`OUT_FIELDS`) of speed ``v[i]`` (m/s, its turning point
    ``q_top[i]`` m) and ``codes[i]`` 0, as `_general_taylor.solve_taylor` gives them; or
    ``codes[i]`` 1 where that speed is for the single call, `HANDED` where the Taylor
    method handed it over as `solve_taylor` does (``rows[i]`` void for both).

    ``ks``, ``ps``, ``cs``, ``es``, ``sc``: the law's arrays (`_general_contact.law_arrays`)."""
    n = v.shape[0]
    for i in range(n):
        codes[i] = 1
        for k in range(_NF):
            rows[i, k] = math.nan
    N = common_n(ks, ps, cs, es, sc)
    if N == 0 or n == 0:
        return
    m = sc[0]
    tol, theta = TOL, THETA
    if sc.shape[0] > SC_TOL:
        tol, theta = sc[SC_TOL], sc[SC_TOL + 1]
    # each lane's model, right-hand side, carried numbers and constants, series and work
    F = np.zeros((LANES, DEG_MAX + 1))
    C = np.zeros((LANES, DEG_MAX + 1))
    FN = np.zeros((LANES, _DN_MAX + 1))
    CN = np.zeros((LANES, _DN_MAX + 1))
    no_cyn = np.zeros(_DN_MAX + 1)
    st = np.zeros((LANES, NST))
    pk = np.zeros((LANES, NPK))
    for lane in range(LANES):
        start(st[lane], 0.0)  # an idle lane's series stay finite
    P = np.zeros((LANES, (_DN_MAX + 1) * (K + 1)))  # row j of a lane: the series of rho^j
    for lane in range(LANES):
        P[lane, 0] = 1.0
    CS = np.zeros((LANES, K + 1))
    R = np.zeros((LANES, K + 1))
    W = np.zeros((LANES, K + 1))
    T = np.zeros((LANES, K + 1))
    pw = np.empty(K + 1)
    xs = np.empty(NS + 1)
    rs = np.empty(NS + 1)
    ws = np.empty(NS + 1)
    who = np.full(LANES, -1)  # the speed in each lane, -1: idle
    Ds = np.zeros(LANES, np.int64)
    j0s = np.zeros(LANES, np.int64)
    # the lanes' common structure: that of the first speed modelled
    fidx = np.zeros(0, np.int64)
    cidx = np.zeros(0, np.int64)
    plan = np.zeros(0, np.int64)
    shaped = False
    nxt = 0
    busy = 0
    while True:
        # fill idle lanes, and take each lane's step head (its new speed's first)
        for lane in range(LANES):
            while True:
                if who[lane] < 0:
                    while nxt < n and who[lane] < 0:
                        i = nxt
                        nxt += 1
                        L = scale(v[i], q_top[i], ks, ps, m)
                        Fi, Ci = model(v[i], L, N, ks, ps, cs, es, sc)
                        if Fi.shape[0] == 0:
                            continue  # codes[i] stays 1: the single call
                        D, j0, FNi, CNi, _, fi, ci, _, pl = series_plan(N, Fi, Ci, _NO_CY, False)
                        if not shaped:
                            fidx, cidx, plan = fi, ci, pl
                            shaped = True
                        elif not (_same(fi, fidx) and _same(ci, cidx) and _same(pl, plan)):
                            continue  # another structure: the single call
                        F[lane, :] = Fi
                        C[lane, :] = Ci
                        FN[lane, :] = 0.0
                        CN[lane, :] = 0.0
                        FN[lane, : FNi.shape[0]] = FNi
                        CN[lane, : CNi.shape[0]] = CNi
                        Ds[lane] = D
                        j0s[lane] = j0
                        constants(pk[lane], v[i], L, N, Fi, Ci, _NO_CY, None, D, sc, tol, theta)
                        start(st[lane], Ci[0])
                        who[lane] = i
                        busy += 1
                    if who[lane] < 0:
                        break
                i = who[lane]
                code = before(
                    st[lane], pk[lane], N, F[lane], C[lane], _NO_CY, None, Ds[lane], rows[i]
                )
                if code == GO_ON:
                    break
                _end(lane, code, i, who, rows, codes, ks, ps, pk, q_top)
                busy -= 1
        if busy == 0:
            return
        series_lanes(N, FN, CN, fidx, cidx, plan, P, CS, R, W, T, st)
        for lane in range(LANES):
            i = who[lane]
            if i < 0:
                continue
            code = after(
                st[lane], pk[lane], R[lane], W[lane], T[lane], pw, xs, rs, ws, N,
                F[lane], C[lane], _NO_CY, None, j0s[lane], Ds[lane], CN[lane], FN[lane], no_cyn,
                rows[i],
            )  # fmt: skip
            if code != GO_ON:
                _end(lane, code, i, who, rows, codes, ks, ps, pk, q_top)
                busy -= 1


@numba.njit(cache=True, error_model="numpy")
def _end(lane, code, i, who, rows, codes, ks, ps, pk, q_top):  # pragma: no cover - compiled
    """Lane ``lane``'s speed ``i`` ends with ``code`` (0: its row finished as `solve_taylor`
    finishes it; 1: handed over by the Taylor method, `HANDED`, its row void); the lane is
    idle."""
    if code == 0:
        finish_row(rows[i], ks, ps, pk[lane, PK_L], q_top[i])
        codes[i] = 0
    else:
        codes[i] = HANDED
        for k in range(_NF):
            rows[i, k] = math.nan
    who[lane] = -1


@numba.njit(cache=True, error_model="numpy")
def _same(a, b):  # pragma: no cover - compiled
    if a.shape[0] != b.shape[0]:
        return False
    for k in range(a.shape[0]):
        if a[k] != b[k]:
            return False
    return True
