"""One extrapolated step of `reference_impl.exact._general_kernel`, and its right-hand sides.

The Gragg-Bulirsch-Stoer step (modified midpoint rule with n_j = 2, 4, ..., 2 KCOL,
Aitken-Neville in h^2; the order-14 result with the order-12 entry as its error) of the
kernel's three variables (``mode``): 0, physical time with unknowns (q, w); 1, the end
substitution q = q_s sigma^KSUB with unknowns (w, t); 2, the Hunt-Crossley log variable,
(q, l = log(1 + alpha w)) in physical time. Also the force function ``fc`` of sums of
power laws and of term tables (`_general_rows`; the compiled path); `_general_kernel.python_solver` re-binds these functions'
Python source to another ``fc``, so they read ``fc`` and the constants from the
namespace they are bound to.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.extending import overload

from reference_impl.exact._general_rows import fc_rows

__all__ = ["KCOL", "KSUB", "deriv", "fc", "gbs", "pw", "state"]


# GBS columns: n_j = 2 j, j = 1..7 (order 14; measured fewest right-hand sides at 1e-14).
KCOL = 7
# Exponent of the end substitution q = q_s sigma^KSUB.
KSUB = 8.0


# ---- force function of sums of power laws (the compiled path) -------------------
# error_model "numpy": these run under `_law_batch`'s prange loop (see `_general_kernel`).


@numba.njit(cache=True, error_model="numpy")
def pw(q, p):
    if p == 1.5:
        return q * math.sqrt(q)
    if p == 1.0:
        return q
    if p == 0.5:
        return math.sqrt(q)
    if p == 0.25:
        return math.sqrt(math.sqrt(q))
    if p == 2.0:
        return q * q
    if p == 2.5:
        return q * q * math.sqrt(q)
    if p == 3.0:
        return q * q * q
    if p == 0.0:
        return 1.0
    return q**p


def fc(q, full, ks, ps, cs, es, sc):
    """(U, U', U'', C, C') at overlap q: of a sum of power laws (``ks``, ``ps`` 1-D: the k
    and p of U' = sum k q^p), or of a term table (``ks`` 2-D: its rows, ``ps``: the limit
    of `_general_rows.table_arrays`). In compiled code the type of ``ks`` picks one at
    compile time (the overload below), so each form has its own machine code in the one
    algorithm of `_general_kernel`; called from Python, the same choice at run time."""
    if np.ndim(ks) == 2:
        return fc_rows(q, full, ks, ps, cs, es, sc)
    return _fc_powers(q, full, ks, ps, cs, es, sc)


@overload(fc, jit_options={"error_model": "numpy"})
def _fc_overload(q, full, ks, ps, cs, es, sc):
    if getattr(ks, "ndim", 1) == 2:

        def rows_impl(q, full, ks, ps, cs, es, sc):
            return fc_rows(q, full, ks, ps, cs, es, sc)

        return rows_impl

    def powers_impl(q, full, ks, ps, cs, es, sc):
        return _fc_powers(q, full, ks, ps, cs, es, sc)

    return powers_impl


@numba.njit(cache=True, error_model="numpy")
def _fc_powers(q, full, ks, ps, cs, es, sc):
    alpha, A, zf = sc[1], sc[2], sc[3]
    need_U = full or zf != 0.0
    need_2 = full or A != 0.0 or (alpha != 0.0 and full)
    U = 0.0
    dU = 0.0
    d2U = 0.0
    d3U = 0.0
    for i in range(ks.shape[0]):
        k, p = ks[i], ps[i]
        qp = pw(q, p)
        dU += k * qp
        if need_U:
            U += k * qp * q / (p + 1.0)
        if need_2:
            if p == 1.0:
                d2U += k
            else:
                qm = pw(q, p - 1.0)
                d2U += k * p * qm
                if full and A != 0.0:
                    if p == 2.0:
                        d3U += 2.0 * k
                    else:
                        d3U += k * p * (p - 1.0) * pw(q, p - 2.0)
    C = 0.0
    dC = 0.0
    for j in range(cs.shape[0]):
        c, e = cs[j], es[j]
        if e == 0.0:
            C += c
        else:
            C += c * pw(q, e)
            if full:
                dC += c * e * pw(q, e - 1.0)
    if alpha != 0.0:
        C += alpha * dU
        dC += alpha * d2U
    if A != 0.0:
        C += A * d2U
        dC += A * d3U
    if zf != 0.0:
        if U > 0.0:
            r = math.sqrt(2.0 * U)
            C += zf * dU / r
            if full:
                dC += zf * (d2U / r - dU * dU / (r * r * r))
        else:
            # q = 0: the limit of U'/sqrt(2U) from the leading term, sqrt(k (p+1)/2) q^((p-1)/2)
            i0 = np.argmin(ps)
            p0 = ps[i0]
            lim = math.sqrt(ks[i0] * (p0 + 1.0) / 2.0)
            C += zf * (lim if p0 == 1.0 else (0.0 if p0 > 1.0 else np.inf))
    return U, dU, d2U, C, dC


# ---- one step in the phase variables (see `_general_kernel`) ----------------------


@numba.njit(cache=True, error_model="numpy")
def state(mode, qs, s, a, b):
    """(q, w) from a phase's (s, a, b); in mode 2, qs holds alpha."""
    if mode == 0:
        return a, b
    if mode == 2:
        return a, math.expm1(b) / qs
    return qs * s**KSUB, a


@numba.njit(cache=True, error_model="numpy")
def deriv(mode, qs, s, a, b, ks, ps, cs, es, sc):
    m = sc[0]
    if mode == 0:
        U, dU, d2U, C, dC = fc(a, False, ks, ps, cs, es, sc)
        return b, -(C * b + dU) / m
    if mode == 2:  # Hunt-Crossley in (q, l = log(1 + alpha w)); qs holds alpha
        U, dU, d2U, C, dC = fc(a, False, ks, ps, cs, es, sc)
        return math.expm1(b) / qs, -qs * dU / m
    s2 = s * s
    s4 = s2 * s2
    s7 = s4 * s2 * s
    q = qs * s7 * s
    dq = KSUB * qs * s7
    U, dU, d2U, C, dC = fc(q, False, ks, ps, cs, es, sc)
    return -(C + dU / a) / m * dq, dq / a


@numba.njit(cache=True, error_model="numpy")
def gbs(mode, qs, s, a, b, h, ks, ps, cs, es, sc, Ta, Tb):
    """One extrapolated step; returns (a, b, error of a, error of b)."""
    d0a, d0b = deriv(mode, qs, s, a, b, ks, ps, cs, es, sc)
    for j in range(KCOL):
        n = 2 * (j + 1)
        hh = h / n
        z0a, z0b = a, b
        z1a, z1b = a + hh * d0a, b + hh * d0b
        for i in range(1, n):
            da, db = deriv(mode, qs, s + i * hh, z1a, z1b, ks, ps, cs, es, sc)
            z2a, z2b = z0a + 2.0 * hh * da, z0b + 2.0 * hh * db
            z0a, z0b, z1a, z1b = z1a, z1b, z2a, z2b
        da, db = deriv(mode, qs, s + h, z1a, z1b, ks, ps, cs, es, sc)
        Ta[j, 0] = 0.5 * (z0a + z1a + hh * da)
        Tb[j, 0] = 0.5 * (z0b + z1b + hh * db)
        for k in range(1, j + 1):
            r = (n / (2.0 * (j - k + 1))) ** 2 - 1.0
            Ta[j, k] = Ta[j, k - 1] + (Ta[j, k - 1] - Ta[j - 1, k - 1]) / r
            Tb[j, k] = Tb[j, k - 1] + (Tb[j, k - 1] - Tb[j - 1, k - 1]) / r
    K = KCOL - 1
    return Ta[K, K], Tb[K, K], abs(Ta[K, K] - Ta[K, K - 1]), abs(Tb[K, K] - Tb[K, K - 1])
