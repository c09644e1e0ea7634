"""One impact of a compiled family in one compiled call (issue 9).

`_branches` integrates through numpy-facing pieces: node positions, the node
function, the sums and the peak are separate calls, and for the ~150 nodes of
one impact their Python overhead cost as much as the nodes themselves. Here the
two fast paths of the compiled families (power-law sums, caps, expressions) run
whole inside numba, generic in the node loop of `_nodes`:

* Gauss-Jacobi in t = d^(1/b) (`gauss_jacobi`): near a singular end (distance d,
  unit length), dq/dx / d^beta is an analytic function of d and of the powers
  d^e_i that the potential's exponents bring in (`_nodes.substitution_order`);
  with d = t^b every e_i b is an integer, so int_0^1 g dd = b int_0^1
  t^(2b/n - 1) [g d^-beta] dt has an analytic bracket and a Gauss-Jacobi rule in
  t converges geometrically. Two rule sizes must agree to _GJ_RTOL on every row;
  the nodes of every row are inverted in one call of the node loop first (the rows'
  chains overlap), so a refusal costs every row's evaluations, repaid by the
  tanh-sinh rung that follows it running faster the same way;
* tanh-sinh (`tanh_sinh`) for the common rows of `_branches._tanh_sinh` (zeta = 0,
  or 0 < zeta < 1 with the zero-force instant close to s_end), level by level.

The sums are those of `_sums` (one source per loop: `gj_rows` around `_node_values`,
`ts_compensated`), the tanh-sinh node positions `_branches._ts_common_x`.
Both also return the peak (q_max and U'(q_max)). Anything else (zeta >= 1, the
rare stretches, a node outside float64 range) returns None and `solve_impact`
runs the general path of `_branches`, which also names a bad node.
"""

from __future__ import annotations

import math
import weakref
from functools import lru_cache
from typing import NamedTuple

import numba
import numpy as np

from reference_impl._jit import specialise
from reference_impl.exact._branches import (
    _EPS,
    _GJ_BETA_MIN,
    _GJ_RTOL,
    _GJ_ZETA_MAX,
    _NEGLIGIBLE_SHARE,
    _NODE_ULPS,
    _ROUND_ULPS,
    _SUM_ULPS_PER_NODE,
    Branches,
    _fill_rows,
    _jacobi_pair,
    _ts_common_x,
    level_up,
    per_potential,
)
from reference_impl.exact._nodes import (
    _TERM_CAP,
    _TERM_POWER,
    NodeKernel,
    _terms_eval,
    _terms_nodes,
    node_kernel,
    substitution_order,
)
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._quadrature import rule
from reference_impl.exact._sums import (
    GJ_BAD_NODE,
    GJ_OK,
    gj_rows,
    rows_positive,
    ts_compensated,
)
from reference_impl.potentials.base import Potential

__all__ = ["conditioning_at", "curvature", "fused_impact", "gauss_jacobi_impact"]

# Rule sizes compared on the compiled families, and the largest substitution order
# b (d = t^b) tried; larger b pushes the rule's singularities in t toward [0, 1]
# and slows the convergence. The pair is accepted where the 20-node rule is within
# _GJ_RTOL (its difference from a finer rule is its error), and the finer rule is then
# within ~1e-15 already at 24 nodes (measured on every family scene, zeta 0-0.9: the
# 24-node rule's error is below the 20-node one's by 5-100x, and <= 4e-16 wherever the
# 20-node rule is within 1e-14), so 24 nodes accept what 32 did, at 8 nodes fewer a row.
_GJC_SIZES = (20, 24)
_GJC_MAX_ORDER = 6
# Round-off of a compiled Gauss-Jacobi row, relative to its (positive) value: the
# recursive sum of the fine rule's terms plus the node values' ulps.
_GJC_ROUND_ULPS = _SUM_ULPS_PER_NODE * _GJC_SIZES[1] + _NODE_ULPS
# Status codes of the kernels (out[8]).
_OK, _BAD_NODE, _DISAGREE, _EMPTY, _CROSSOVER = 0.0, 1.0, 2.0, 3.0, 4.0
# Gauss-Jacobi in t is not tried on a sum whose higher-exponent terms carry more than
# this multiple of the leading terms' energy at q_max: the term ratio, a power of t,
# puts a singularity of the bracket at t ~ -1/R, and the 20-node rule then cannot
# reach 1e-14 (needs R below ~6 by the convergence rate; measured: every sum of
# exponents 1.5-4 refused from R = 1.0-5.4). Only time is at stake: tanh-sinh runs.
_GJ_RATIO_MAX = 8.0
# Fields of the kernels' output: the six of `Branches`, q_max, U'(q_max), status.
_OUT = 9
# With ``rtol`` (`reference_impl.exact._rtol`) of at least _RELAXED_RTOL_MIN, a single cap
# whose Gauss-Jacobi pair disagrees beyond _GJ_RTOL is accepted when the pair agrees to
# rtol and each time's bound (the pair's difference plus round-off) is within
# _RELAXED_SHARE of rtol: the rest is left to the conditioning charge `solve_impact` adds
# after (16 eps |U U''| / U'^2, ~1e-14), so that its bound check never refuses what the
# general path would have answered. Measured on the sphere scene (60 impacts, zeta
# 0.55-0.85, v0 0.1-5 m/s, where the pair disagrees at 1e-14 and the general path ran,
# ~0.5 ms): bounds 4e-13 .. 5.2e-11, the fine rule's error against full accuracy 70-100
# times smaller (<= 7.4e-13). Other families keep full accuracy: the pair's difference
# bounds the fine rule only where the rule converges that fast.
_RELAXED_RTOL_MIN = 1e-12
_RELAXED_SHARE = 0.5


# Whole-impact kernels, written once and compiled per node loop by `_kernels_for`
# (`reference_impl._jit.specialise` binds _NODES, a `NodeKernel.nodes`, and _PEAK).
_NODES = _PEAK = None


def _peak(prm, P, out):  # pragma: no cover - compiled
    """q_max and U'(q_max) into out[6:8]: x(s_peak) = v0 exp(-zeta s_peak) exactly."""
    m, v0, zeta, sp = prm[0], prm[1], prm[2], prm[4]
    xa = np.empty((1, 1))
    g = np.empty((1, 1))
    qs = np.empty((1, 1))
    xa[0, 0] = v0 * math.exp(-zeta * sp)
    _NODES(xa, m, prm[7], prm[8], prm[9], prm[10], P, g, qs)
    out[6] = qs[0, 0]
    out[7] = m * xa[0, 0] / g[0, 0]


@numba.njit(cache=True)
def _node_values(rows, i, d, args, vals):  # pragma: no cover - compiled
    """dq/dx d^-beta at the nodes d = t^b of branch row i (`_sums.gj_rows`'s integrand),
    from args = (d^-beta, dq/dx at the nodes of every row); False when a node value is
    not finite and > 0."""
    fac, g = args
    for j in range(d.shape[0]):
        gj = g[i, j]
        if not (gj > 0.0 and gj < np.inf):
            return False
        vals[j] = gj * fac[j]
    return True


# `_sums.gj_rows` around the node values (the same for every family: the values are
# computed before, every branch in one call of the node loop).
_GJ_ROWS = gj_rows(_node_values, True)


def _gauss_jacobi(prm, P, d, fac, W, b, rtol, round_rel, out):  # pragma: no cover
    zeta = prm[2]
    rows = np.empty((3, 5))
    nr = _fill_rows(zeta, prm[4], prm[5], prm[6], rows)
    for i in range(nr):
        if not rows[i, 4] > 0.0:
            out[8] = _EMPTY
            return
    _PEAK(prm, P, out)
    if _term_ratio(P, prm[10], out[6]) > _GJ_RATIO_MAX:
        out[8] = _CROSSOVER
        return
    # dq/dx at the nodes of every branch, in one call of the node loop (`_nodes`: the
    # branches' chains overlap); `_GJ_ROWS` then sums them row by row.
    m, v0, wd = prm[0], prm[1], prm[3]
    nn = d.shape[0]
    xs = np.empty((nr, nn))
    for i in range(nr):
        s0, s1, p0, p1 = rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3]
        for j in range(nn):
            xs[i, j] = (
                v0 * math.exp(-zeta * (s0 + s1 * d[j])) * math.sin(wd * (p0 + p1 * d[j])) / wd
            )
    g = np.empty((nr, nn))
    _NODES(xs, m, prm[7], prm[8], prm[9], prm[10], P, g, np.empty((nr, nn)))
    args = (fac, g)
    fine = np.empty(3)
    err = np.empty(3)
    status = _GJ_ROWS(rows, nr, d, W, args, b, rtol, round_rel, fine, err)
    if status != GJ_OK:
        out[8] = _BAD_NODE if status == GJ_BAD_NODE else _DISAGREE
        return
    _store(fine, err, nr, out)
    out[8] = _OK


def _tanh_sinh(prm, P, d, w, w_diff, beta, round_ulps, out):  # pragma: no cover
    m, v0, zeta, wd, sp, s_end, lz = prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6]
    nr = 1 if zeta == 0.0 else 3
    L = np.empty(nr)
    L[0] = sp
    if nr == 3:
        L[1] = s_end - sp
        L[2] = lz
    nn = d.shape[0]
    xs = _ts_common_x(L, d, zeta, wd, s_end, v0)
    g = np.empty((nr, nn))
    _NODES(xs, m, prm[7], prm[8], prm[9], prm[10], P, g, np.empty((nr, nn)))
    if not rows_positive(g, L):
        out[8] = _BAD_NODE
        return
    val = np.empty(nr)
    err = np.empty(nr)
    ts_compensated(g, L, w, w_diff, d[0], beta, round_ulps, val, err)
    if nr == 1:
        _store(val, err, 1, out)
    else:
        # Rise, fall, and the stretch [2 s_peak, s_end] taken off the fall.
        out[0], out[1] = val[0], err[0]
        out[2], out[3] = val[1] - val[2], err[1] + err[2]
        out[4], out[5] = val[1], err[1]
    _PEAK(prm, P, out)
    out[8] = _OK


def _kernels_for(nodes, cache: bool, entry: str | None = None):
    """(gauss_jacobi, tanh_sinh) compiled around the node loop ``nodes``; their disk-cache
    files are noted under the compile-cache ``entry`` when given (for its eviction)."""
    peak = specialise(_peak, cache, _NODES=nodes)
    gauss_jacobi = specialise(_gauss_jacobi, cache, _NODES=nodes, _PEAK=peak)
    tanh_sinh = specialise(_tanh_sinh, cache, _NODES=nodes, _PEAK=peak)
    if entry is not None:
        from reference_impl._expr_cache import record_files

        record_files(entry, [peak, gauss_jacobi, tanh_sinh])
    return gauss_jacobi, tanh_sinh


@numba.njit(cache=True, error_model="numpy")
def _term_ratio(P, n_lead, q):  # pragma: no cover - compiled
    """Energy at q of the terms beyond the leading exponent over the leading terms'
    (0 for a single term or an expression, whose terms are not tabled)."""
    lead = 0.0
    rest = 0.0
    for i in range(P.shape[0]):
        n = P[i, 2] if P[i, 0] == _TERM_POWER else 2.0 * (P[i, 2] + 1.0)
        u = _terms_eval(q, P[i : i + 1])[0]
        if n == n_lead:
            lead += u
        else:
            rest += u
    return rest / lead if lead > 0.0 else 0.0


@numba.njit(cache=True)
def _store(fine, err, nr, out):  # pragma: no cover - compiled
    """Branches fields from the rows of `_fill_rows` (rise, fall, zero-force stretch)."""
    out[0], out[1] = fine[0], err[0]
    if nr == 1:  # zeta = 0: the three stretches coincide
        out[2], out[3], out[4], out[5] = fine[0], err[0], fine[0], err[0]
    else:
        out[2], out[3] = fine[1] - fine[2], err[1] + err[2]
        out[4], out[5] = fine[1], err[1]


# The table form's kernels, shared by every power-law sum and cap (disk-cached);
# built after every helper they call exists (`specialise` copies the globals).
_TERMS_KERNELS = _kernels_for(_terms_nodes, cache=True)


@lru_cache(maxsize=64)
def _expression_kernels(nodes):
    # One expression's node loop (itself cached by the sympy form). Disk-cached when the
    # loop came from the compile cache's module (reference_impl._cache), whose name
    # `specialise` spells into these copies' names; else compiled in memory.
    entry = getattr(nodes, "_hcv_entry", None)
    return _kernels_for(nodes, cache=entry is not None, entry=entry)


class _Plan(NamedTuple):
    """What one potential's impacts need, computed once: its node kernel, the
    whole-impact kernels, the Gauss-Jacobi arguments (d, d^-beta, W, b, rtol,
    round-off; None when that path does not apply), beta, and the tanh-sinh
    arguments per level (filled on first use)."""

    kernel: NodeKernel
    gauss_jacobi: object
    tanh_sinh: object
    gj: tuple | None
    beta: float
    ts_rules: dict


_PLANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _plan(pot: Potential) -> _Plan | None:
    return per_potential(_PLANS, _build_plan, pot)


def _build_plan(pot: Potential) -> _Plan | None:
    k = node_kernel(pot)
    if k is None:
        return None
    gj_k, ts_k = _TERMS_KERNELS if k.terms else _expression_kernels(k.nodes)
    n = float(pot.leading_exponent)
    beta = 2.0 / n - 1.0
    b = substitution_order(pot, _GJC_MAX_ORDER)
    gj = None
    if b is not None and 2.0 * b / n - 1.0 >= _GJ_BETA_MIN:
        gj = (*_gjc_nodes(2.0 * b / n - 1.0, b, beta), b, _GJ_RTOL, _GJC_ROUND_ULPS * _EPS)
    return _Plan(k, gj_k, ts_k, gj, beta, {})


def _ts_args(plan: _Plan, level: int) -> tuple:
    """(d, w, w_diff, beta, round-off ulps) of the tanh-sinh rule of ``level`` (cached)."""
    try:
        return plan.ts_rules[level]
    except KeyError:
        r = rule(level, plan.beta)
        args = plan.ts_rules[level] = (r.d, r.w, r.w_diff, plan.beta, _ROUND_ULPS[r.d.size])
        return args


@lru_cache(maxsize=32)
def _gjc_nodes(alpha_w: float, b: int, beta: float):
    """Distances d = u^b of the two Gauss-Jacobi rules in t, d^-beta, and the weights."""
    u, W = _jacobi_pair(alpha_w, _GJC_SIZES)
    # Both rules' nodes in increasing order: the compiled inverse of U warm-starts
    # each node from the previous one along a branch.
    order = np.argsort(u)
    d = u[order] ** b
    return d, d ** (-beta), np.ascontiguousarray(W[order])


def _params(osc: VirtualOscillator, m: float, q_top: float, k: NodeKernel) -> np.ndarray:
    lz = osc.zero_force_stretch if osc.zeta > 0.0 else 0.0
    return np.array(
        [m, osc.v0, osc.zeta, osc.wd, osc.s_peak, osc.s_end, lz, q_top, k.q_s, k.u_s, k.n_lead]
    )


def _result(out: np.ndarray) -> tuple[Branches, float, float]:
    v = out.tolist()
    return Branches(*v[:6]), v[6], v[7]


def gauss_jacobi_impact(pot: Potential, m: float, osc: VirtualOscillator, q_top: float):
    """(Branches, q_max, U'(q_max)) by Gauss-Jacobi in t = d^(1/b), or None when that
    path does not apply or refuses (see the module docstring)."""
    plan = _plan(pot)
    if plan is None or plan.gj is None or osc.zeta >= _GJ_ZETA_MAX:
        return None
    out = np.empty(_OUT)
    plan.gauss_jacobi(_params(osc, m, q_top, plan.kernel), plan.kernel.P, *plan.gj, out)
    return _result(out) if out[8] == _OK else None


def fused_impact(
    pot: Potential, m: float, osc: VirtualOscillator, q_top: float, rtol: float | None = None
):
    """(Branches, q_max, U'(q_max)) of one impact in compiled code, or None.

    Gauss-Jacobi first, then tanh-sinh from `_branches.COMPILED_LEVEL` up while the
    bound exceeds `_branches._LEVEL_UP_RTOL` (`_branches.level_up`). None for a
    family without compiled nodes, for the stretches only the general path covers,
    and when a node value is not finite and > 0. With ``rtol`` (relative, None: full
    accuracy), a single cap's Gauss-Jacobi pair that disagrees at full accuracy is
    taken when it meets rtol (`_relaxed_cap`).
    """
    plan = _plan(pot)
    if plan is None:
        return None
    z = osc.zeta
    if z > 0.0:
        if z >= 1.0:
            return None
        lz, sp = osc.zero_force_stretch, osc.s_peak
        common = lz < sp and (lz / sp) ** (1.0 + plan.beta) >= _NEGLIGIBLE_SHARE
    else:
        common = True
    k = plan.kernel
    prm = _params(osc, m, q_top, k)
    out = np.empty(_OUT)
    if plan.gj is not None and z < _GJ_ZETA_MAX:
        plan.gauss_jacobi(prm, k.P, *plan.gj, out)
        if out[8] == _OK:
            return _result(out)
        if rtol is not None and rtol >= _RELAXED_RTOL_MIN and out[8] == _DISAGREE and _is_cap(k.P):
            if _relaxed_cap(plan, prm, rtol, out):
                return _result(out)
    if not common:
        return None

    def run(level):
        plan.tanh_sinh(prm, k.P, *_ts_args(plan, level), out)
        return _result(out) if out[8] == _OK else None

    return level_up(run)


def _is_cap(P: np.ndarray) -> bool:
    """True for the term table of a single volumetric cap (sphere, ellipsoid)."""
    return P.shape[0] == 1 and P[0, 0] == _TERM_CAP


def _relaxed_cap(plan: _Plan, prm: np.ndarray, rtol: float, out: np.ndarray) -> bool:
    """The Gauss-Jacobi pair with its rows' agreement at ``rtol`` instead of _GJ_RTOL,
    into ``out``; True when it answered and both times' bounds (their rows' summed)
    are within _RELAXED_SHARE of rtol of them (`solve._check_bound` checks rtol)."""
    d, fac, W, b, _, round_rel = plan.gj
    plan.gauss_jacobi(prm, plan.kernel.P, d, fac, W, b, rtol, round_rel, out)
    if out[8] != _OK:
        return False
    rise, e_rise, mid, e_mid, fall, e_fall = out[:6]
    share = _RELAXED_SHARE * rtol
    return e_rise + e_fall <= share * (rise + fall) and e_rise + e_mid <= share * (rise + mid)


# Relative accuracy of U in ulps assumed by the conditioning term of `solve._conditioning`
# (the potentials' contract: "a few ulps").
_NODE_ULPS_U = 16.0


@numba.njit(cache=True, error_model="numpy")
def conditioning_at(m, v0, zeta, s_peak, d2, f_max):  # pragma: no cover - compiled
    """`solve._conditioning` given U''(q_max) = d2: U(q_max) from the oscillator's peak,
    c = |U U''| / U'^2, times _NODE_ULPS_U ulps (inf when c is not finite). Compiled, so
    that `solve_impact` and the prepared call's kernel (`_prepared_kernel`) charge the
    very same number."""
    xp = v0 * math.exp(-zeta * s_peak)
    u = 0.5 * m * (xp * xp)
    c = abs(u * d2) / (f_max * f_max) if f_max > 0.0 else np.inf
    if not math.isfinite(c):
        c = np.inf
    return _NODE_ULPS_U * _EPS * c


def curvature(pot: Potential, q: float) -> float | None:
    """The second derivative of U at q by the potential's compiled evaluator (one call,
    ~1 us), or None when it has no compiled form."""
    plan = _plan(pot)
    if plan is None or plan.kernel.ev is None:
        return None
    return float(plan.kernel.ev(q, plan.kernel.P)[2])
