"""The two quadrature sums of the exact solver, each written once (issue 27, goal 7).

* `ts_compensated`, `ts_pairwise`: the tanh-sinh rows (`_ts_rows`): per row of node
  values g at distances L d_k from the singular end, the value L sum w_k g_k plus the
  analytic tail below the first node, and the bound |fine - coarse| + the first node's
  share + the round-off of the sum and of the node values;
* `gj_rows`: the Gauss-Jacobi rows (`_gj_rows`) of two rule sizes, their agreement
  test and bounds, around an integrand bound per use: the power law's closed form
  (`_power_kernel`) or the compiled node loop of a family (`_one_call`).

Both are plain, numba-compatible Python generic in a function they call (``_ROW``,
``_VALUES``), compiled per binding by `reference_impl._jit.specialise`, and called from
compiled kernels and from Python alike (node values from numpy for the potentials that
have no compiled form).

The tanh-sinh row is summed one of two ways, bound once each: compensated (Neumaier, the
fused kernels and the general path's common rows) or in numpy's pairwise order
(`_pairwise`, the general path's other rows, the split quadrature and the trajectory).
Both keep the numbers they gave as separate loops bit for bit
(verification/test_exact_frozen.py); one summation for all would move last bits of the
general path.
"""

from __future__ import annotations

import numba
import numpy as np

from reference_impl._jit import specialise

__all__ = ["gj_rows", "rows_positive", "ts_compensated", "ts_pairwise"]

_EPS = float(np.finfo(float).eps)
# numpy's pairwise summation (numpy/_core/src/umath/loops_utils.h.src): blocks of at
# most this many terms are summed by 8 interleaved accumulators.
_PW_BLOCK = 128
# Status of `gj_rows`: accepted, a node value not finite and > 0, the rules disagree.
GJ_OK, GJ_BAD_NODE, GJ_DISAGREE = 0, 1, 2
# Bound by `specialise`: the summation of one tanh-sinh row, and the Gauss-Jacobi integrand.
_ROW = _VALUES = None


@numba.njit(cache=True)
def _block(a, lo, n):  # pragma: no cover - compiled
    """numpy's sum of one block of n <= _PW_BLOCK terms a[lo:lo + n]."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    top = lo + n - n % 8
    i = lo + 8
    while i < top:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < lo + n:
        res += a[i]
        i += 1
    return res


@numba.njit(cache=True)
def _pairwise(a, n):  # pragma: no cover - compiled
    """sum(a[:n]) in the order of numpy's np.sum over a contiguous axis (bit for bit).

    numpy halves a longer run (the first half a multiple of 8 terms) and adds the
    halves' sums; that recursion is unrolled on an explicit stack (numba's recursive
    calls crashed when called from another compiled function).
    """
    if n <= _PW_BLOCK:
        return _block(a, 0, n)
    los = np.empty(64, np.int64)
    ns = np.empty(64, np.int64)
    phase = np.zeros(64, np.int64)  # 0: not split, 1: left half pending, 2: right half
    left = np.empty(64)
    top = 0
    los[0], ns[0] = 0, n
    while True:
        m = ns[top]
        if m > _PW_BLOCK:
            n2 = m // 2
            n2 -= n2 % 8
            phase[top] = 1
            top += 1
            los[top], ns[top], phase[top] = los[top - 1], n2, 0
            continue
        v = _block(a, los[top], m)
        top -= 1
        # Hand v up: a left half waits for its right half, a right half completes a sum.
        while True:
            if phase[top] == 1:
                left[top] = v
                phase[top] = 2
                n2 = ns[top] // 2
                n2 -= n2 % 8
                top += 1
                los[top], ns[top], phase[top] = los[top - 1] + n2, ns[top - 1] - n2, 0
                break
            v = left[top] + v
            top -= 1
            if top < 0:
                return v


@numba.njit(cache=True)
def _row_compensated(g, w, w_diff, L, round_ulps):  # pragma: no cover - compiled
    """(sum w g, sum w_diff g, round-off bound) of one row, the first compensated.

    Neumaier's sum errs by at most 2 ulps of the sum of |terms| plus O(N eps^2), below
    the pairwise bound ``round_ulps`` charged (the same charge as `_row_pairwise`).
    """
    s = 0.0
    c = 0.0
    sd = 0.0
    sa = 0.0
    for j in range(g.shape[0]):
        t = g[j] * w[j]
        u = s + t
        if abs(s) >= abs(t):
            c += (s - u) + t
        else:
            c += (t - u) + s
        s = u
        sd += g[j] * w_diff[j]
        sa += abs(t)
    return s + c, sd, round_ulps * _EPS * L * sa


@numba.njit(cache=True)
def _row_pairwise(g, w, w_diff, L, round_ulps):  # pragma: no cover - compiled
    """(sum w g, sum w_diff g, round-off bound) of one row, each sum in numpy's pairwise
    order (`_pairwise`; round-off <= `_quadrature.pairwise_ulps` ulps of sum |w g|)."""
    n = g.shape[0]
    a = np.empty(n)
    b = np.empty(n)
    c = np.empty(n)
    for j in range(n):
        a[j] = g[j] * w[j]
        b[j] = g[j] * w_diff[j]
        c[j] = abs(g[j]) * w[j]
    return _pairwise(a, n), _pairwise(b, n), (round_ulps * _EPS) * (_pairwise(c, n) * L)


def _ts_rows(g, L, w, w_diff, d0, beta, round_ulps, val, err):  # pragma: no cover - compiled
    """Tanh-sinh integrals int_0^L[i] f of the rows g[i] = f(L[i] d) and their bounds.

    The rule's nodes d (d0 the first, nearest the singular end, where f ~ d^beta), its
    weights w and the fine-minus-coarse weights w_diff; ``round_ulps`` the round-off
    charged, in ulps of L sum |w g| (the sum's and the node values'; 0 for none).
    An empty row (L <= 0) integrates to 0 whatever its values. Callers check the
    values first (`rows_positive`) where a bad one must be refused.
    """
    for i in range(g.shape[0]):
        li = L[i]
        if not li > 0.0:
            z = li * 0.0
            val[i] = z + 0.0 * (li * d0) / (1.0 + beta)
            err[i] = abs(z) + abs(z * w[0])
            continue
        s, sd, rnd = _ROW(g[i], w, w_diff, li, round_ulps)
        # Analytic tail on [0, d0]: f ~ f(d0) (d / d0)^beta there.
        tail = g[i, 0] * (li * d0) / (1.0 + beta)
        val[i] = li * s + tail
        # Fine minus coarse, plus the first node's share as a bound on the end
        # correction (it dominates only when beta is close to -1, n > ~30).
        err[i] = abs(li * sd) + abs(li * g[i, 0] * w[0]) + rnd


ts_compensated = specialise(_ts_rows, True, _ROW=_row_compensated)
ts_pairwise = specialise(_ts_rows, True, _ROW=_row_pairwise)


@numba.njit(cache=True)
def rows_positive(g, L):  # pragma: no cover - compiled
    """True when every value of the non-empty rows (L > 0) is finite and > 0."""
    for i in range(g.shape[0]):
        if L[i] > 0.0:
            for j in range(g.shape[1]):
                if not (g[i, j] > 0.0 and g[i, j] < np.inf):
                    return False
    return True


def _gj_rows(rows, nr, d, W, args, b, rtol, round_rel, fine, err):  # pragma: no cover
    """Gauss-Jacobi integrals of the branch rows of `_branches._fill_rows`, two rule sizes.

    ``_VALUES(rows, i, d, args, vals)`` writes the integrand of row i at the nodes d into
    vals (False: a node value is not finite and > 0); columns 0 and 1 of W are the
    coarse and fine rules' weights. With b > 0 the sums are scaled by L b after
    summing (the substitution d = t^b); b = 0 when the values carry their scale.
    Each row's rules must agree to ``rtol`` of it; its bound is their difference
    plus ``round_rel`` of it. Returns GJ_OK, GJ_BAD_NODE or GJ_DISAGREE (the first
    row refused stops the loop).
    """
    nn = d.shape[0]
    vals = np.empty(nn)
    for i in range(nr):
        if not _VALUES(rows, i, d, args, vals):
            return GJ_BAD_NODE
        c = 0.0
        f = 0.0
        for j in range(nn):
            c += W[j, 0] * vals[j]
            f += W[j, 1] * vals[j]
        if b > 0.0:
            scale = rows[i, 4] * b
            c *= scale
            f *= scale
        diff = abs(f - c)
        if not diff <= rtol * abs(f):
            return GJ_DISAGREE
        fine[i] = f
        err[i] = diff + round_rel * f
    return GJ_OK


def gj_rows(values, cache: bool):
    """`_gj_rows` compiled around the integrand ``values`` (a compiled function)."""
    return specialise(_gj_rows, cache, _VALUES=values)
