"""The compiled calls of a prepared solver (`reference_impl.exact.prepared`, issue 27, goal 2).

One Python call of ``prepare(potential, m)(v0, zeta)`` makes one compiled call:

* `power_call`: a power law, `_power_kernel.power_impact` with its per-potential
  constants read from one array (a numba call unboxes each argument: sixteen cost
  ~0.6 us, five ~0.3 us), its output returned as the result's fields;
* `family_call(plan)`: the other compiled families, the oscillator of
  `VirtualOscillator` (the same formulas), the parameters of `_one_call._params`,
  the Gauss-Jacobi kernel of the family's `_one_call` plan (the very call
  `solve_impact` makes first); when it refuses (or the plan has no Gauss-Jacobi
  rule), the first rung of `_one_call.fused_impact`'s tanh-sinh ladder, the
  family's tanh-sinh kernel at `_branches.COMPILED_LEVEL`, kept when its bound is
  within `_branches._LEVEL_UP_RTOL` (`level_up` stops there too); and, when either
  answers, the restitutions, the curvature U''(q_max) (`_one_call.curvature`: the
  same compiled evaluator at the same q_max), the conditioning charge
  (`_one_call.conditioning_at`, the function `solve_impact` calls) and the bound and
  range checks of `solve_impact`; its constants read from one array
  (`family_constants`), its output returned as the result's fields. A rung that
  `level_up` would climb past, and every other refusal of the rules, is left to the
  Python path (`prepared.PreparedImpact._fused`), which starts the ladder again.

Each runs the compiled code `solve_impact` runs, in the same order, so its numbers
are that path's bit for bit (held by verification/test_exact_prepared.py).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np

from reference_impl._jit import specialise
from reference_impl.exact._branches import _LEVEL_UP_RTOL, _NEGLIGIBLE_SHARE, COMPILED_LEVEL
from reference_impl.exact._one_call import _OK, _OUT, _ts_args, conditioning_at
from reference_impl.exact._power_kernel import OUT_SIZE, power_impact

__all__ = ["family_call", "family_constants", "power_call"]

# The compiled functions a copy of `_family_impact` calls (bound by `specialise`): the
# family's Gauss-Jacobi and tanh-sinh kernels and its evaluator (U, U', U'', U''') at one
# overlap.
_GJ = _TS = _EV = None
# Status of the rules' output (out[8]) when the tanh-sinh rung run is not the answer
# `level_up` would keep (a bound above _LEVEL_UP_RTOL, or not a number), or when it was
# not run: Python climbs the ladder.
_LEVEL_UP = -1.0


@numba.njit(cache=True, error_model="numpy")
def power_call(v0, zeta, c, u, W):  # pragma: no cover - compiled
    """`power_impact` with the scalars after (v0, zeta) from ``c`` (see `power_constants`,
    then the stated accuracy and the smallest normal float), returned as the fields of
    `ImpactSolution` in their order: q_max, U'(q_max), the contact time, restitution, the
    zero-force time and restitution, the two bounds; then the peak time, wd, s_peak,
    s_end and 1.0 (0.0 when a check refused; the rest is then meaningless). A tuple
    comes back to Python cheaper than an output array read by ``tolist``."""
    o = np.empty(OUT_SIZE)
    power_impact(
        v0, zeta, c[0], c[1], c[2], u, W, c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], o
    )
    rise, e_rise, mid, e_mid, fall, e_fall = o[0], o[1], o[2], o[3], o[4], o[5]
    return (
        o[6],
        o[7],
        rise + fall,
        o[8],
        rise + mid,
        o[9],
        e_rise + e_fall,
        e_rise + e_mid,
        rise,
        o[10],
        o[11],
        o[12],
        o[13],
    )


# Layout of the one array a family call reads (`family_constants`): the scalars, then the
# term table P (rows x 5), the Gauss-Jacobi distances d, d^-beta and weights W (n x 2),
# and the tanh-sinh rule's d, w and w_diff. One array instead of sixteen arguments: numba
# unboxes each (~0.06 us apiece).
_K_M, _K_QS, _K_US, _K_NLEAD, _K_B, _K_RTOL, _K_ROUND = 0, 1, 2, 3, 4, 5, 6
_K_STATED, _K_TINY, _K_HAS_GJ, _K_BETA, _K_TS_ULPS = 7, 8, 9, 10, 11
_K_ROWS, _K_NODES, _K_TS_NODES = 12, 13, 14
_K_HEAD = 15


def family_constants(m, plan, rtol_stated, tiny) -> np.ndarray:
    """The array `family_call`'s function reads: (m, q_s, u_s, n_lead) of the plan's
    `NodeKernel`, b, rtol and round-off of its Gauss-Jacobi tuple (d, d^-beta, W, b, rtol,
    round_rel; placeholders without one), `solve_impact`'s RTOL_STATED and smallest normal
    float, whether the plan has a Gauss-Jacobi rule, beta and the round-off ulps of the
    tanh-sinh rule of `COMPILED_LEVEL` (`_one_call._ts_args`), the table's rows and both
    rules' node counts; then P, d, d^-beta, W and the tanh-sinh d, w, w_diff, each
    contiguous."""
    kernel = plan.kernel
    if plan.gj is not None:
        d, fac, W, b, rtol, round_rel = plan.gj
        has_gj = 1.0
    else:  # placeholders (has_gj = 0: the Gauss-Jacobi kernel is not called)
        d, fac, W, b, rtol, round_rel = _NO_NODES, _NO_NODES, _NO_WEIGHTS, 0.0, 0.0, 0.0
        has_gj = 0.0
    ts_d, ts_w, ts_wd, beta, ts_ulps = _ts_args(plan, COMPILED_LEVEL)
    P = kernel.P
    head = [
        m,
        kernel.q_s,
        kernel.u_s,
        kernel.n_lead,
        b,
        rtol,
        round_rel,
        rtol_stated,
        tiny,
        has_gj,
        beta,
        ts_ulps,
        P.shape[0],
        d.shape[0],
        ts_d.shape[0],
    ]
    parts = [np.array(head, dtype=float), P.ravel(), d, fac, W.ravel(), ts_d, ts_w, ts_wd]
    return np.concatenate(parts)


_NO_NODES = np.zeros(1)
_NO_WEIGHTS = np.zeros((1, 2))


def _family_impact(v0, zeta, q_top, K):  # pragma: no cover - compiled
    """One impact of a compiled family (0 <= zeta < `_branches._GJ_ZETA_MAX`); K from
    `family_constants`.

    Gauss-Jacobi first when the plan has its rule, then, as `_one_call.fused_impact`
    does, the tanh-sinh rule of `COMPILED_LEVEL` on the common rows; then what
    `solve_impact` does with the branches: the restitutions, the conditioning charge
    (`_one_call.conditioning_at` at U''(q_max) of the family's evaluator, `solve._charged`),
    the sums and the bound and range checks.

    Returns the fields of `ImpactSolution` as `power_call` does: q_max, U'(q_max), the
    contact time, restitution, the zero-force time and restitution, the two bounds, the
    peak time, wd, s_peak, s_end, and last a status: 1.0 when it answered, 0.0 when
    neither rule answered (the caller runs the tanh-sinh ladder; the rest is then
    meaningless), -1.0 when a check refused (the caller hands over to `solve_impact`,
    which raises it).
    """
    nr, nn, nt = int(K[_K_ROWS]), int(K[_K_NODES]), int(K[_K_TS_NODES])
    i = _K_HEAD + 5 * nr
    P = K[_K_HEAD:i].reshape((nr, 5))
    d, fac, W = K[i : i + nn], K[i + nn : i + 2 * nn], K[i + 2 * nn : i + 4 * nn].reshape((nn, 2))
    i += 4 * nn
    ts_d, ts_w, ts_wd = K[i : i + nt], K[i + nt : i + 2 * nt], K[i + 2 * nt : i + 3 * nt]
    m, beta = K[_K_M], K[_K_BETA]
    # VirtualOscillator.__init__ and .zero_force_stretch, the same operations.
    wd = math.sqrt((1.0 - zeta) * (1.0 + zeta))
    sp = math.atan2(wd, zeta) / wd
    s_end = math.pi / wd
    prm = np.empty(11)
    prm[0], prm[1], prm[2], prm[3], prm[4], prm[5] = m, v0, zeta, wd, sp, s_end
    lz = 2.0 * math.atan2(zeta, wd) / wd if zeta > 0.0 else 0.0
    prm[6] = lz
    prm[7], prm[8], prm[9], prm[10] = q_top, K[_K_QS], K[_K_US], K[_K_NLEAD]
    o = np.zeros(_OUT)
    o[8] = _LEVEL_UP
    if K[_K_HAS_GJ] == 1.0:
        _GJ(prm, P, d, fac, W, K[_K_B], K[_K_RTOL], K[_K_ROUND], o)
    if o[8] != _OK:
        # fused_impact: the tanh-sinh rows only where the zero-force stretch is common.
        common = True
        if zeta > 0.0:
            common = lz < sp and (lz / sp) ** (1.0 + beta) >= _NEGLIGIBLE_SHARE
        if common:
            _TS(prm, P, ts_d, ts_w, ts_wd, beta, K[_K_TS_ULPS], o)
            if o[8] == _OK:
                # level_up's `_relative_bound`: a rung above _LEVEL_UP_RTOL is climbed.
                worst = (o[1] + o[3]) / (o[0] + o[2])
                ok = worst <= _LEVEL_UP_RTOL
                if math.isfinite(o[4]):
                    ok = ok and (o[1] + o[5]) / (o[0] + o[4]) <= _LEVEL_UP_RTOL
                if not ok:
                    o[8] = _LEVEL_UP
        else:
            o[8] = _LEVEL_UP
    if o[8] != _OK:
        z = 0.0
        return (z, z, z, z, z, z, z, z, z, z, z, z, 0.0)
    # solve_impact's restitution and VirtualOscillator.restitution_zero_force.
    rest = math.exp(-math.pi * zeta / wd)
    rest_zf = math.exp(-2.0 * zeta * sp) if zeta > 0.0 else 1.0
    rise, e_rise, mid, e_mid, fall, e_fall = o[0], o[1], o[2], o[3], o[4], o[5]
    q_max, f_max = o[6], o[7]
    # solve._charge_conditioning: U''(q_max) by the same evaluator, the same charge.
    cond = conditioning_at(m, v0, zeta, sp, _EV(q_max, P)[2], f_max)
    if cond > 0.0:  # solve._charged
        e_rise, e_mid, e_fall = e_rise + cond * rise, e_mid + cond * mid, e_fall + cond * fall
    t, e, t_zf, e_zf = rise + fall, e_rise + e_fall, rise + mid, e_rise + e_mid
    # `_check_bound` (both times are finite below zeta = 1) and `_check_normal`.
    rtol_stated, tiny = K[_K_STATED], K[_K_TINY]
    ok = (
        e <= rtol_stated * t
        and e_zf <= rtol_stated * t_zf
        and t < np.inf
        and t_zf < np.inf
        and q_max >= tiny
        and f_max >= tiny
        and t >= tiny
    )
    return (q_max, f_max, t, rest, t_zf, rest_zf, e, e_zf, rise, wd, sp, s_end, 1.0 if ok else -1.0)


@lru_cache(maxsize=64)
def _family_entry(gauss_jacobi, tanh_sinh, ev, entry: str | None, cache: bool):
    fn = specialise(_family_impact, cache, _GJ=gauss_jacobi, _TS=tanh_sinh, _EV=ev)
    if entry is not None:
        from reference_impl._expr_cache import record_files

        record_files(entry, [fn])
    return fn


def family_call(plan):
    """The compiled whole-impact call of a `_one_call` plan, or None when the family has
    no compiled evaluator. Disk-cached as the plan's kernels are: the table form always,
    an expression when its node loop came from the compile cache."""
    k = plan.kernel
    if k.ev is None:
        return None
    if k.terms:
        return _family_entry(plan.gauss_jacobi, plan.tanh_sinh, k.ev, None, True)
    entry = getattr(k.nodes, "_hcv_entry", None)
    return _family_entry(plan.gauss_jacobi, plan.tanh_sinh, k.ev, entry, entry is not None)
