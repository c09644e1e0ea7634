"""Fixed tanh-sinh (double-exponential) rules for integrals with an endpoint singularity.

The exact solver integrates dt = (dq/dx) d tau, whose integrand behaves like
d^beta (beta > -1, any real) at one end of each branch. Double-exponential
rules converge exponentially for any such algebraic endpoint behaviour, which a
Gauss rule does only when the exponent and the expansion are known. The nodes
are kept as distances from the singular end, so that no precision is lost
where the integrand is large.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from reference_impl.exact._sums import ts_pairwise

__all__ = [
    "TanhSinhRule",
    "rule",
    "integrate_left_singular",
    "pairwise_ulps",
]


def pairwise_ulps(n: int) -> float:
    """Round-off bound, in ulps of the sum of |terms|, of numpy's pairwise sum of n terms.

    numpy sums blocks of 8 with an unrolled loop and combines blocks pairwise:
    at most 8 + log2(n/8) additions lie on any term's path (Higham, 2002, 4.2).
    """
    return 8.0 + max(0.0, math.log2(max(n, 1) / 8.0)) + 1.0


# The rule stops at a distance d_min from the singular end; below it the integrand
# ~ d^beta is integrated analytically. d_min is chosen per beta so that this tail
# is at most _TAIL_FRACTION of the integral (its own error is far smaller still),
# within [_D_MIN_FLOOR, _D_MIN_CEIL] (the floor keeps x^2 ~ d^2 from underflowing).
_TAIL_FRACTION = 1e-13
_D_MIN_FLOOR_EXP = -140
_D_MIN_CEIL_EXP = -16
# Default level: step h = 2**-level. Level 5 reaches round-off for every case in
# the test suite; its even nodes form the level-4 rule used for the error estimate.
DEFAULT_LEVEL = 5


class TanhSinhRule:
    """Nodes d_k in (0, 1) and weights w_k with sum w_k f(d_k) ~ int_0^1 f(d) dd.

    Attributes
    ----------
    d : numpy.ndarray
        Distances from the left end, accurate even when tiny.
    w : numpy.ndarray
        Weights.
    coarse : numpy.ndarray
        Boolean mask of the nodes of the rule of half the level (step 2h), for an
        error estimate from the same evaluations.
    """

    def __init__(self, level: int, dmin_exp: int):
        h = 2.0**-level
        d_min = 10.0**dmin_exp
        # t_max such that the left-most node lies at d_min.
        t_max = math.asinh(math.log(1.0 / d_min) / math.pi)
        k_max = int(math.ceil(t_max / h))
        k_max += k_max % 2  # keep the coarse (even-k) rule symmetric
        k = np.arange(-k_max, k_max + 1)
        t = k * h
        u = 0.5 * math.pi * np.sinh(t)
        # (1 + tanh u) / 2 = 1 / (1 + exp(-2u)), written so tiny distances keep precision.
        with np.errstate(over="ignore"):
            d = 1.0 / (1.0 + np.exp(-2.0 * u))
            w = 0.25 * math.pi * h * np.cosh(t) / np.cosh(u) ** 2
        keep = (d >= 0.5 * d_min) & (w > 0) & (d < 1.0)
        self.d = d[keep]
        self.w = w[keep].copy()
        self.coarse = (k[keep] % 2) == 0
        # The sum is a trapezoid rule in t truncated at the first node: that node
        # carries half a weight (the other half belongs to the analytic tail's side).
        self.w[0] *= 0.5
        # Weights of the half-level rule on the same nodes, and the difference used
        # for the error estimate, so both sums are one matrix-vector product each.
        self.w_coarse = np.where(self.coarse, 2.0 * self.w, 0.0)
        self.w_diff = self.w - self.w_coarse
        self.level = level


@lru_cache(maxsize=64)
def _rule(level: int, dmin_exp: int) -> TanhSinhRule:
    return TanhSinhRule(level, dmin_exp)


def rule(level: int = DEFAULT_LEVEL, beta: float = 0.0) -> TanhSinhRule:
    """Cached tanh-sinh rule for an endpoint behaviour d^beta (beta > -1)."""
    # d_min^(1 + beta) <= _TAIL_FRACTION, rounded to a whole decade for caching.
    exp = math.floor(math.log10(_TAIL_FRACTION) / (1.0 + max(beta, -0.999)))
    return _rule(level, int(min(max(exp, _D_MIN_FLOOR_EXP), _D_MIN_CEIL_EXP)))


def integrate_left_singular(f, length, beta: float, level: int = DEFAULT_LEVEL):
    """Integrate f over [0, length] where f(d) ~ c d^beta as d -> 0+.

    Parameters
    ----------
    f : callable
        Vectorised integrand of the distance d from the singular end. May be
        called with a 2-D array (one row per interval) when ``length`` is an array.
    length : float or numpy.ndarray
        Interval length(s), > 0.
    beta : float
        Exponent of the endpoint behaviour (> -1); used only for the analytic
        tail below the smallest node.
    level : int
        Rule level.

    Returns
    -------
    value : float or numpy.ndarray
        The integral(s).
    error : float or numpy.ndarray
        |fine - coarse| estimate of the absolute error of the coarse rule, an upper
        estimate for the returned (fine) value (no round-off term).
    """
    r = rule(level, beta)
    L = np.asarray(length, dtype=float)
    # Zero-length intervals integrate to 0; evaluate them on a dummy unit interval.
    d = np.where(L <= 0, 1.0, L)[..., None] * r.d
    fd = np.asarray(f(d), dtype=float)
    rows = np.ascontiguousarray(fd.reshape(-1, fd.shape[-1]))
    lengths = np.ascontiguousarray(np.broadcast_to(L, fd.shape[:-1]).reshape(-1))
    value, err = np.empty(rows.shape[0]), np.empty(rows.shape[0])
    ts_pairwise(rows, lengths, r.w, r.w_diff, r.d[0], float(beta), 0.0, value, err)
    if L.ndim == 0:
        return float(value[0]), float(err[0])
    return value.reshape(fd.shape[:-1]), err.reshape(fd.shape[:-1])
