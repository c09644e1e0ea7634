"""The Taylor kernel's polynomials: its series order, its Horner evaluations (issue 38).

Split from `reference_impl.exact._general_taylor` (which was over the size limit) so
that the kernel's stepping stays in one module: the series order `K`, the samples per
step `NS`, the radius estimate of a step's series (`inv_radius`, the root test over the
last `WIN` coefficients), and the evaluations of a step's Taylor polynomials (`horner`,
the four-point `samples`, the even/odd `rw`) and of the law's polynomials in rho
(`poly`, `poly_d`). Moved unchanged: every result bit for bit.
"""

from __future__ import annotations

import numba

__all__ = ["K", "NS", "WIN", "horner", "horner3", "inv_radius", "poly", "poly_d", "rw", "samples"]

# Series order: work per step ~ K^2, steps ~ 1 / log(1 / theta) with theta = TOL^(1/(K+1));
# measured fewest operations near K = 30 (8-10 steps per Hertz impact).
K = 30
# Samples per step for the sign changes of the zero-force and peak-force functions.
NS = 8
# Coefficients (the last WIN of each series) in the root test of the radius: the series
# at the onset of an undamped Hertz contact has only every fifth coefficient nonzero
# (rho'' = -2 a rho^4), and a window of 12 sees two of them.
WIN = 12


@numba.njit(cache=True, error_model="numpy")
def poly(c, lo, hi, x):
    """sum_{j=lo}^{hi} c[j] x^(j - lo) (Horner)."""
    acc = 0.0
    for j in range(hi, lo - 1, -1):
        acc = acc * x + c[j]
    return acc


@numba.njit(cache=True, error_model="numpy")
def poly_d(c, hi, x):
    """(p(x), p'(x)) of sum_{j=0}^{hi} c[j] x^j."""
    p = 0.0
    dp = 0.0
    for j in range(hi, -1, -1):
        dp = dp * x + p
        p = p * x + c[j]
    return p, dp


@numba.njit(cache=True, error_model="numpy")
def horner(c, x):
    acc = c[K]
    for k in range(K - 1, -1, -1):
        acc = acc * x + c[k]
    return acc


@numba.njit(cache=True, error_model="numpy")
def horner3(R, W, T, x):
    """(`horner` of R, W and T at x): the three chains interleaved, each `horner`'s own
    operations in its order (bit for bit), at the latency of one (a chain of K dependent
    multiply-adds, ~80 ns: the step's ends were five such chains one after another)."""
    r = R[K]
    w = W[K]
    t = T[K]
    for k in range(K - 1, -1, -1):
        r = r * x + R[k]
        w = w * x + W[k]
        t = t * x + T[k]
    return r, w, t


@numba.njit(cache=True, error_model="numpy")
def samples(R, W, x_end, xs, rs, ws):
    """rho and W at the NS + 1 points x_end i / NS (Horner from c[K] down, as `horner`),
    four or five points at a time in registers (eight or ten independent chains; for
    NS = 8, points 4-8 together: the ninth point alone was two more chains' latency)."""
    for i in range(NS + 1):
        xs[i] = x_end * i / NS
    i = 0
    last = NS + 1
    if NS + 1 == 9:  # four points, then five (ten chains): no ninth point alone after them
        x0, x1, x2, x3, x4 = xs[4], xs[5], xs[6], xs[7], xs[8]
        r0 = r1 = r2 = r3 = r4 = R[K]
        w0 = w1 = w2 = w3 = w4 = W[K]
        for k in range(K - 1, -1, -1):
            rk = R[k]
            wk = W[k]
            r0 = r0 * x0 + rk
            r1 = r1 * x1 + rk
            r2 = r2 * x2 + rk
            r3 = r3 * x3 + rk
            r4 = r4 * x4 + rk
            w0 = w0 * x0 + wk
            w1 = w1 * x1 + wk
            w2 = w2 * x2 + wk
            w3 = w3 * x3 + wk
            w4 = w4 * x4 + wk
        rs[4], rs[5], rs[6], rs[7], rs[8] = r0, r1, r2, r3, r4
        ws[4], ws[5], ws[6], ws[7], ws[8] = w0, w1, w2, w3, w4
        last = 4  # points 0-3 below
    while i + 4 <= last:
        x0, x1, x2, x3 = xs[i], xs[i + 1], xs[i + 2], xs[i + 3]
        r0 = r1 = r2 = r3 = R[K]
        w0 = w1 = w2 = w3 = W[K]
        for k in range(K - 1, -1, -1):
            rk = R[k]
            wk = W[k]
            r0 = r0 * x0 + rk
            r1 = r1 * x1 + rk
            r2 = r2 * x2 + rk
            r3 = r3 * x3 + rk
            w0 = w0 * x0 + wk
            w1 = w1 * x1 + wk
            w2 = w2 * x2 + wk
            w3 = w3 * x3 + wk
        rs[i], rs[i + 1], rs[i + 2], rs[i + 3] = r0, r1, r2, r3
        ws[i], ws[i + 1], ws[i + 2], ws[i + 3] = w0, w1, w2, w3
        i += 4
    while i < last:
        rs[i] = horner(R, xs[i])
        ws[i] = horner(W, xs[i])
        i += 1


@numba.njit(cache=True, error_model="numpy")
def rw(R, W, x):
    """(rho, W) at x: even and odd coefficients as four Horner chains in x^2 (half the
    latency of one chain: the events evaluate the step's polynomials at ~100 points)."""
    x2 = x * x
    ke = K - (K % 2)  # highest even index
    ko = K - 1 + (K % 2)  # highest odd index
    re = R[ke]
    we = W[ke]
    ro = R[ko]
    wo = W[ko]
    for k in range(ke - 2, -1, -2):
        re = re * x2 + R[k]
        we = we * x2 + W[k]
    for k in range(ko - 2, 0, -2):
        ro = ro * x2 + R[k]
        wo = wo * x2 + W[k]
    return re + x * ro, we + x * wo


@numba.njit(cache=True, error_model="numpy")
def inv_radius(R, W, T, pw):
    """1 / r, r = min over the last WIN coefficients c_k of rho, W, T of (|c_0|+ / |c_k|)^(1/k),
    with |c_0|+ = max(1, |c_0|) (the root test; pow only where a coefficient beats the
    current estimate: pw[k] holds inv^k)."""
    inv = 0.0
    for k in range(K - WIN + 1, K + 1):
        pw[k] = 0.0
    for c in (R, W, T):
        sz = max(1.0, abs(c[0]))
        for k in range(K, K - WIN, -1):
            a = abs(c[k]) / sz
            if a > pw[k]:
                inv = a ** (1.0 / k)
                p = inv ** (K - WIN + 1)
                for kk in range(K - WIN + 1, K + 1):
                    pw[kk] = p
                    p *= inv
    return inv
