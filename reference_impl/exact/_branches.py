"""The branch integrals of the exact impact solver, t = int (dq/dx)(x(s)) ds.

Three virtual-time integrals give every reported time:

* rise: from contact onset s = 0 to the peak s_peak (dq/dx ~ s^beta at s = 0);
* mid: from the peak to the zero-force instant 2 s_peak (smooth, x > 0);
* fall: from the peak to the theory's end of contact (q back to 0): s_end for
  zeta < 1 (dq/dx ~ (s_end - s)^beta there), infinity for zeta >= 1.

With beta = 2/n - 1 for U ~ q^n. The mid stretch is integrated directly when the
zero-force instant is far from s_end (zeta >= 1/2), and as fall minus the stretch
[2 s_peak, s_end] otherwise (that stretch is short then, so nothing cancels). Long
stretches (zeta near 1, where s_end = pi / sqrt(1 - zeta^2) grows without bound)
are cut into pieces of at most _PIECE units of virtual time, over which the
integrand, an analytic function of s with unit time scale, is resolved by a
fixed tanh-sinh rule.

Power laws first try Gauss-Jacobi rules (`_power_kernel`), and compiled families
(sums, caps, expressions) run their fast paths whole in compiled code (`_one_call`),
both before this module (`_strategies`); what reaches it is the general tanh-sinh
path. The Gauss-Jacobi rules' constants and branch rows are kept here.

Every error returned is the quadrature estimate |fine - coarse| plus a bound on
the round-off of the sum (pairwise or compensated for tanh-sinh, recursive summation
in the Gauss-Jacobi loops; relative to the sum of |w f|; `_sums`) and of the node
values (_NODE_ULPS ulps).
"""

from __future__ import annotations

import math
import weakref
from fractions import Fraction
from functools import lru_cache
from typing import NamedTuple

import numba
import numpy as np

from reference_impl._stored import stored_floats
from reference_impl.errors import HCVInputError
from reference_impl.exact._nodes import node_function
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._quadrature import DEFAULT_LEVEL, pairwise_ulps, rule
from reference_impl.exact._sums import rows_positive, ts_compensated, ts_pairwise
from reference_impl.exact._tail import overdamped_tail
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

__all__ = ["Branches", "branch_integrals", "compiled_nodes", "dq_dx", "power_law_scale"]

_EPS = float(np.finfo(float).eps)
# Round-off bound of a sum of N positive products w_k f_k summed one after the other
# (the compiled Gauss-Jacobi loops): N ulps of the sum of |w f| (recursive summation).
# The tanh-sinh sums charge the pairwise bound instead (`_quadrature.pairwise_ulps`).
_SUM_ULPS_PER_NODE = 1.0
# Relative round-off of one node value dq/dx(x(s)): exp, sin and the power or the
# inverse of U each contribute a few ulps, amplified by |beta| <= 1 in x^beta.
_NODE_ULPS = 16.0
# Tanh-sinh level of the compiled families (ellipsoid, sphere, sums, expressions):
# level 4 (h = 1/16) has half the nodes of level 5 and measured errors <= 1.4e-14
# against the mpmath truth on the benchmark scenes; the reported bound (fine minus
# level 3) stays honest either way, and the tests check it against the truth.
COMPILED_LEVEL = 4
# A compiled-family result whose bound exceeds this relative size is recomputed one
# level up (each level halves the step, roughly squaring the quadrature error), up
# to _MAX_LEVEL; the bound reported is the one of the last level. 5e-13 is ~10x the
# round-off part of the bound (~(N + 16) ulps per row, amplified where the zero-force
# time is a difference), so a level is added only when the quadrature part dominates.
_LEVEL_UP_RTOL = 5e-13
# Sums whose exponents differ by a non-integer converge slowest (measured: a bound of
# 1.2e-12 at level 6, below 1e-12 at level 7 for p = 3 + p = 3.97).
_MAX_LEVEL = 7
# Longest stretch (virtual time) integrated by one tanh-sinh rule: x(s) varies on a
# unit time scale (the rates are zeta and sqrt(1 - zeta^2) <= 1 for zeta < 1).
_PIECE = 1.0
# Gauss-Jacobi fast path for power laws: rule sizes compared, the agreement required
# (relative to the rising-branch time), and the range where the rules and the geometric
# convergence rate are good enough (measured with scipy's rules: round-off for p <= 3,
# zeta <= 0.9; with the correctly rounded rules of `_jacobi_rules` the pair agrees to
# round-off up to zeta ~0.85 for p = 1-3, issue 38).
_GJ_SIZES = (16, 24)
_GJ_RTOL = 1e-14
_GJ_BETA_MIN = -0.5
_GJ_ZETA_MAX = 0.9
# Branches shorter than this fraction of the contact (in virtual time) are empty.
_TINY_BRANCH = 1e-250
# A stretch [2 s_peak, s_end] whose share (lz/s_peak)^(1+beta) of the time is below this
# is dropped (a tenth of an ulp), its share (times _SHARE_SAFETY for the O(1) factor
# between the two ends' power-law coefficients) added to the error bound.
_NEGLIGIBLE_SHARE = 1e-17
_SHARE_SAFETY = 4.0


class _RoundUlps(dict):
    """pairwise_ulps(N) + _NODE_ULPS per rule size N (cached: called on every impact)."""

    def __missing__(self, n):
        v = pairwise_ulps(n) + _NODE_ULPS
        self[n] = v
        return v


_ROUND_ULPS = _RoundUlps()


class Branches(NamedTuple):
    """Physical times (s) of the three stretches and bounds on their absolute errors."""

    rise: float
    err_rise: float
    mid: float
    err_mid: float
    fall: float
    err_fall: float


@lru_cache(maxsize=256)
def _exponent_splits(p: float, n: float) -> tuple[float, float, float, float]:
    """-p/n and (2 - n)/n as exact sums hi + lo of two floats (from the float p, n)."""
    fp, fn = Fraction(p), Fraction(n)
    out = []
    for y in (-fp / fn, (2 - fn) / fn):
        hi = float(y)
        out += [hi, float(y - Fraction(hi))]
    return tuple(out)


def _pow_split(base: float, y_hi: float, y_lo: float) -> float:
    """base ** (y_hi + y_lo) with the exponent carried beyond float precision.

    A rounded exponent y costs a relative error |y_err log(base)|, 2.6e-14 for
    k = 1e300 (issue 12); the exact split y = y_hi + y_lo removes it.
    """
    return base**y_hi * math.exp(y_lo * math.log(base))


def power_law_scale(pot: PowerLaw, m: float, v0: float) -> tuple[float, float]:
    """(c, beta) with dq/dx = c (x / v0)^beta exactly for U = k q^n / n, n = p + 1.

    q = (n m x^2 / 2k)^(1/n) gives dq/dx = (m/k) (n m / 2k)^(-p/n) x^(2/n - 1).
    """
    n = pot.leading_exponent
    a_hi, a_lo, b_hi, b_lo = _exponent_splits(pot.p, n)
    c = (m / pot.k) * _pow_split(0.5 * n * m / pot.k, a_hi, a_lo) * _pow_split(v0, b_hi, b_lo)
    return c, 2.0 / n - 1.0


def dq_dx(pot: Potential, m: float, x, v0: float):
    """dq/dx = sqrt(2 K U) / U' = m x / U'(q) with K = m, at q = U^-1(m x^2/2) (s)."""
    x = np.asarray(x, dtype=float)
    if type(pot) is PowerLaw:
        # Closed form: one power instead of an inverse and a force evaluation.
        c, beta = power_law_scale(pot, m, v0)
        return c * (x / v0) ** beta
    q = pot._inverse((0.5 * m * x * x).ravel()).reshape(x.shape)
    return m * x / pot._dU(q)


def _checked(g: np.ndarray, x: np.ndarray, osc: VirtualOscillator, pot: Potential) -> np.ndarray:
    """Refuse when a node value is not finite and > 0 (x or q outside float64 range)."""
    bad = ~(np.isfinite(g) & (g > 0))
    if np.any(bad):
        i = np.argmax(bad.ravel())
        raise HCVInputError(
            f"dq/dx = {g.ravel()[i]!r} at virtual displacement x = {x.ravel()[i]:.3g} m "
            f"(zeta = {osc.zeta!r}, leading exponent n = {pot.leading_exponent:.6g}): the "
            "overlap leaves float64 range at this quadrature node, so the float solver cannot "
            "evaluate this impact (solve_impact_mp can)"
        )
    return g


def _sums(g, lengths, beta, r):
    """Values and error bounds (quadrature + round-off) of the rows of g (`_sums.ts_pairwise`)."""
    g = np.ascontiguousarray(g, dtype=float)
    L = np.asarray(lengths, dtype=float)
    val, err = np.empty(g.shape[0]), np.empty(g.shape[0])
    ts_pairwise(g, L, r.w, r.w_diff, r.d[0], float(beta), _ROUND_ULPS[r.d.size], val, err)
    return val, err


def branch_integrals(
    pot: Potential, m: float, osc: VirtualOscillator, level: int | None, q_hi: float
) -> Branches:
    """The three stretches of one impact (see the module docstring).

    ``level`` None picks COMPILED_LEVEL for compiled families, else DEFAULT_LEVEL.
    ``q_hi`` is the validated turning point of the impact energy: every overlap
    met lies in (0, q_hi], which brackets the compiled inverse of U.
    """
    beta = 2.0 / pot.leading_exponent - 1.0
    compiled = None if type(pot) is PowerLaw else compiled_nodes(pot)
    if compiled is None:
        lv = DEFAULT_LEVEL if level is None else level
        return _tanh_sinh(pot, m, osc, beta, lv, lambda x: dq_dx(pot, m, x, osc.v0))
    if level is not None:
        return _tanh_sinh(pot, m, osc, beta, level, lambda x: compiled(x, m, q_hi)[0])
    # The fast paths of compiled families (`_one_call`) have run before; here the
    # general tanh-sinh path, level by level.
    return level_up(
        lambda lv: (_tanh_sinh(pot, m, osc, beta, lv, lambda x: compiled(x, m, q_hi)[0]),)
    )[0]


def level_up(run):
    """Results of ``run(level)`` from COMPILED_LEVEL up, while the bound exceeds
    _LEVEL_UP_RTOL: the one with the smallest bound (None if ``run`` gives None).

    ``run`` returns a tuple whose first item is the level's `Branches`.
    """
    best = None
    for lv in range(COMPILED_LEVEL, _MAX_LEVEL + 1):
        res = run(lv)
        if res is None:
            return None
        bound = _relative_bound(res[0])
        if best is None or bound < _relative_bound(best[0]):
            best = res
        if bound <= _LEVEL_UP_RTOL:
            break
    return best


def _relative_bound(br: Branches) -> float:
    """Largest relative error bound of the finite reported times."""
    worst = (br.err_rise + br.err_mid) / (br.rise + br.mid)
    if math.isfinite(br.fall):
        worst = max(worst, (br.err_rise + br.err_fall) / (br.rise + br.fall))
    return worst


_COMPILED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def per_potential(cache: weakref.WeakKeyDictionary, build, pot: Potential):
    """``build(pot)``, kept in ``cache`` per potential object (immutable after
    construction, so an entry cannot go stale); built each time when ``pot`` is
    not weak-referenceable."""
    try:
        return cache[pot]
    except KeyError:
        pass
    except TypeError:
        return build(pot)
    value = cache[pot] = build(pot)
    return value


def compiled_nodes(pot: Potential):
    """The compiled node function of `_nodes` for ``pot`` (cached per object), or None."""
    return per_potential(_COMPILED, node_function, pot)


def _tanh_sinh(pot, m, osc: VirtualOscillator, beta: float, level: int, dqdx) -> Branches:
    z, sp = osc.zeta, osc.s_peak
    r_s, r_0 = rule(level, beta), rule(level, 0.0)

    def g_of(x):
        with np.errstate(all="ignore"):
            g = dqdx(x)
        return _checked(g, x, osc, pot)

    if 0.0 < z < 1.0:
        lz = osc.zero_force_stretch
        if _NEGLIGIBLE_SHARE <= (lz / sp) ** (1.0 + beta) and lz < sp:
            # The common case, in one evaluation: rise, fall from the end, and the short
            # stretch [2 s_peak, s_end] subtracted from the fall for the zero-force time.
            # Nodes and sums are compiled (`_ts_common_x`, `_sums.ts_compensated`): numpy's
            # per-call overhead on ~300 nodes cost more than the node evaluations.
            L = np.array([sp, osc.s_end - sp, lz])
            xs = _ts_common_x(L, r_s.d, z, osc.wd, osc.s_end, osc.v0)
            with np.errstate(all="ignore"):
                g = dqdx(xs)
            if not rows_positive(g, L):
                _checked(g, xs, osc, pot)  # raises: a node value is not finite and > 0
            v, e = np.empty(3), np.empty(3)
            ts_compensated(g, L, r_s.w, r_s.w_diff, r_s.d[0], beta, _ROUND_ULPS[r_s.d.size], v, e)
            rise, fall, stretch = (float(t) for t in v)
            e_rise, e_fall, e_stretch = (float(t) for t in e)
            return Branches(rise, e_rise, fall - stretch, e_fall + e_stretch, fall, e_fall)
    # Singular rows (distance d from a singular end) and smooth rows (start + d).
    rise_x = osc.x(sp * r_s.d)
    rise, e_rise = _sums(g_of(rise_x)[None, :], np.array([sp]), beta, r_s)
    rise, e_rise = float(rise[0]), float(e_rise[0])
    if z == 0.0:
        return Branches(rise, e_rise, rise, e_rise, rise, e_rise)
    if z >= 1.0:
        mid, e_mid = _smooth(g_of, osc.x, sp, sp, r_0)
        fall, e_fall = _overdamped_tail(g_of, osc, beta, pot, m)
        return Branches(rise, e_rise, mid, e_mid, mid + fall, e_mid + e_fall)
    lz = osc.zero_force_stretch
    share = (lz / sp) ** (1.0 + beta)
    if share < _NEGLIGIBLE_SHARE:
        # zeta so small that [2 s_peak, s_end] carries less than round-off of the time
        # (dq/dx ~ d^beta near s_end as near s = 0, so its share is ~ (lz/s_peak)^(1+beta)).
        fall, e_fall = _sums(
            g_of(osc.x_from_end((osc.s_end - sp) * r_s.d))[None, :],
            np.array([osc.s_end - sp]),
            beta,
            r_s,
        )
        fall, e_fall = float(fall[0]), float(e_fall[0])
        bound = _SHARE_SAFETY * share * fall
        return Branches(rise, e_rise, fall, e_fall + bound, fall, e_fall)
    if lz < sp:
        # Zero-force instant close to s_end: fall from the end, minus the short stretch.
        L = np.array([osc.s_end - sp, lz])
        xs = osc.x_from_end(np.where(L > 0, L, 1.0)[:, None] * r_s.d)
        v, e = _sums(g_of(xs), L, beta, r_s)
        fall, e_fall = float(v[0]), float(e[0])
        return Branches(rise, e_rise, fall - float(v[1]), e_fall + float(e[1]), fall, e_fall)
    mid, e_mid = _smooth(g_of, osc.x, sp, sp, r_0)
    # [2 s_peak, s_end] back from s_end: a singular first piece, then smooth pieces.
    pieces = max(1, math.ceil(lz / _PIECE))
    h = lz / pieces
    v, e = _sums(g_of(osc.x_from_end(h * r_s.d))[None, :], np.array([h]), beta, r_s)
    tail, e_tail = float(v[0]), float(e[0])
    if pieces > 1:
        starts = h * np.arange(1, pieces)
        xs = osc.x_from_end(starts[:, None] + h * r_0.d)
        v, e = _sums(g_of(xs), np.full(pieces - 1, h), 0.0, r_0)
        tail += float(np.sum(v))
        e_tail += float(np.sum(e))
    return Branches(rise, e_rise, mid, e_mid, mid + tail, e_mid + e_tail)


@numba.njit(cache=True)
def _ts_common_x(L, d, zeta, wd, s_end, v0):  # pragma: no cover - compiled
    """x at the tanh-sinh nodes of the common-case rows: row 0 from contact onset, rows
    1 and 2 back from s_end (the formulas of `VirtualOscillator.x` and `x_from_end`);
    here and in the fused kernel (`_one_call`), for as many rows as L has."""
    n = d.shape[0]
    xs = np.empty((L.shape[0], n))
    for i in range(L.shape[0]):
        for j in range(n):
            dd = L[i] * d[j]
            s = dd if i == 0 else s_end - dd
            xs[i, j] = v0 * np.exp(-zeta * s) * (np.sin(wd * dd) / wd)
    return xs


def _smooth(g_of, x_of_s, start: float, length: float, r) -> tuple[float, float]:
    """int_start^{start+length} g(x(s)) ds for a smooth integrand, in pieces <= _PIECE."""
    pieces = max(1, math.ceil(length / _PIECE))
    h = length / pieces
    starts = start + h * np.arange(pieces)
    v, e = _sums(g_of(x_of_s(starts[:, None] + h * r.d)), np.full(pieces, h), 0.0, r)
    return float(np.sum(v)), float(np.sum(e))


def _overdamped_tail(g_of, osc: VirtualOscillator, beta: float, pot, m) -> tuple[float, float]:
    """Physical time from the zero-force instant to q = 0 when zeta >= 1 (`_tail`).

    x -> 0 only as s -> inf, exponentially, and dq/dx ~ x^beta: the time is finite
    only for beta > 0 (softening contacts, n < 2), infinite otherwise.
    """

    return overdamped_tail(g_of, osc, beta, pot, m, _NODE_ULPS)


# error_model "numpy": called inside `batch._gj_batch`'s prange loop (no exception there).
@numba.njit(cache=True, error_model="numpy")
def _fill_rows(zeta, sp, s_end, lz, rows):  # pragma: no cover - compiled
    """Branches (S0, S1, Phi0, Phi1, length) with x = A exp(-zeta S) sin(wd Phi), S and
    Phi affine in the distance d from the branch's singular end, into ``rows`` (3 x 5);
    returns how many are used.

    The rising branch (from s = 0), the falling branch (back from s_end) and the
    stretch from the zero-force instant (lz = s_end - 2 s_peak before it) to s_end
    (back from s_end). Underdamped only; the falling rows are omitted for zeta = 0
    (symmetric).
    """
    rows[0, 0], rows[0, 1], rows[0, 2], rows[0, 3], rows[0, 4] = 0.0, sp, 0.0, sp, sp
    if zeta == 0.0:
        return 1
    lf = s_end - sp
    rows[1, 0], rows[1, 1], rows[1, 2], rows[1, 3], rows[1, 4] = s_end, -lf, 0.0, lf, lf
    if lz < _TINY_BRANCH * s_end:
        lz = 0.0
    rows[2, 0], rows[2, 1], rows[2, 2], rows[2, 3], rows[2, 4] = s_end, -lz, 0.0, lz, lz
    return 3


# Working precision of the rules' computation (decimal digits): the nodes and weights are
# then rounded once to float64, each correctly rounded (the eigenvalue problem of
# Golub-Welsch at 40 digits loses far less than the 24 digits it has to spare).
_RULE_DPS = 40


def _jacobi_rules(beta: float, sizes: tuple[int, ...]) -> list[float]:
    """Nodes u in (0, 1) of the Gauss-Jacobi rules of each size for int_0^1 f(u) u^beta du,
    then their weights, as one flat list (what `stored_floats` keeps), nodes ascending.

    Computed in mpmath at `_RULE_DPS` digits (Golub-Welsch, ``mp.gauss_quadrature``) and
    rounded once, so that every node and weight is correctly rounded. scipy's
    ``roots_jacobi``, used before, gave nodes with relative errors up to 1.1e-14 and
    weights up to 1.8e-13 (beta = -1/3, -1/2: p = 2, 3; also through u = (1 + y)/2 in
    float, which cancels near y = -1): the 16- and 24-node rules then differed by
    1e-15 - 3e-14 of a smooth integral on their own (moments of u^k, k <= 20, wrong by
    up to 4e-14), which failed the pair's 1e-14 agreement for part of the damping range
    and sent those impacts to the tanh-sinh rules (issue 38: p = 2 at 14-30 us, Hertz 5).
    The correctly rounded rules integrate those moments to 1e-16 - 5e-16. Once per
    machine: the store keeps them (`reference_impl._stored`), so a float solve does not
    import mpmath after the first.
    """
    import mpmath  # here: the rules are stored, a float solve never imports it again

    # Plain loops, no comprehension: `stored_floats` keys on this function's constants,
    # and a nested code object's repr carries its address, a new key in every process.
    us, ws = [], []
    with mpmath.workdps(_RULE_DPS):
        b = mpmath.mpf(beta)  # the float's exact value: the weight the kernel's values assume
        scale = mpmath.power(2, b + 1)
        for size in sizes:
            y, w = mpmath.mp.gauss_quadrature(int(size), "jacobi", 0, b)
            u, wk = np.empty(len(y)), np.empty(len(y))
            for i in range(len(y)):
                u[i], wk[i] = float((1 + y[i]) / 2), float(w[i] / scale)
            order = np.argsort(u, kind="stable")  # nodes ascending, as scipy's were
            us.append(u[order])
            ws.append(wk[order])
    return [*np.concatenate(us), *np.concatenate(ws)]


@lru_cache(maxsize=32)
def _jacobi_pair(beta: float, sizes: tuple[int, int] = _GJ_SIZES):
    """Nodes u in (0, 1) of the Gauss-Jacobi rules of two sizes (default _GJ_SIZES) for
    int_0^1 f(u) u^beta du, concatenated, and a (nodes, 2) weight matrix whose
    columns give the two rules (zeros on the other rule's nodes).

    Computed in mpmath (`_jacobi_rules`) once per machine and read back from the table store
    (`reference_impl._stored`, bit for bit) in later processes.
    """
    n = sum(sizes)
    flat = np.array(
        stored_floats(
            "gauss-jacobi",
            (float(beta), tuple(int(s) for s in sizes)),
            _jacobi_rules,
            2 * n,
            files=(("mpmath", "matrices/eigen_symmetric.py"),),
        )
    )
    u, w = flat[:n], flat[n:]
    W = np.zeros((n, len(sizes)))
    W[: sizes[0], 0] = w[: sizes[0]]
    W[sizes[0] :, 1] = w[sizes[0] :]
    return u, W
