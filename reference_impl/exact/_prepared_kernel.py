"""The compiled calls of a prepared solver (`reference_impl.exact.prepared`, issue 27, goal 2).

One Python call of ``prepare(potential, m)(v0, zeta)`` makes one compiled call:

* `power_call`: a power law, `_power_kernel.power_impact` with its per-potential
  constants read from one array (a numba call unboxes each argument: sixteen cost
  ~0.6 us, five ~0.3 us), its output returned as the result's fields;
* `family_call(plan)`: the other compiled families, the oscillator of
  `VirtualOscillator` (the same formulas), the parameters of `_one_call._params`,
  the Gauss-Jacobi kernel of the family's `_one_call` plan (the very call
  `solve_impact` makes first), and, when it answers, the restitutions, the
  curvature U''(q_max) (`_one_call.curvature`: the same compiled evaluator at the
  same q_max), the conditioning charge of `solve._conditioning_at` and the bound and
  range checks of `solve_impact`; its constants read from one array
  (`family_constants`), its output returned as the result's fields.

Each runs the compiled code `solve_impact` runs, in the same order, so its numbers
are that path's bit for bit (held by verification/test_exact_prepared.py).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np

from reference_impl._jit import specialise
from reference_impl.exact._one_call import _OK, _OUT
from reference_impl.exact._power_kernel import OUT_SIZE, power_impact

__all__ = ["family_call", "family_constants", "power_call"]

# The compiled functions a copy of `_family_impact` calls (bound by `specialise`): the
# family's Gauss-Jacobi kernel and its evaluator (U, U', U'', U''') at one overlap.
_GJ = _EV = None


@numba.njit(cache=True, error_model="numpy")
def power_call(v0, zeta, c, u, W):  # pragma: no cover - compiled
    """`power_impact` with the scalars after (v0, zeta) from ``c`` (see `power_constants`,
    then RTOL_STATED and the smallest normal float), returned as the fields of
    `ImpactSolution` in their order: q_max, U'(q_max), the contact time, restitution, the
    zero-force time and restitution, the two bounds; then the peak time, wd, s_peak,
    s_end and 1.0 (0.0 when a check refused; the rest is then meaningless). A tuple
    comes back to Python cheaper than an output array read by ``tolist``."""
    o = np.empty(OUT_SIZE)
    power_impact(
        v0, zeta, c[0], c[1], c[2], u, W, c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], o
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
# term table P (rows x 5), the Gauss-Jacobi distances d, d^-beta and the weights W (n x 2).
# One array instead of eleven arguments: numba unboxes each (~0.06 us apiece).
_K_M, _K_QS, _K_US, _K_NLEAD, _K_B, _K_RTOL, _K_ROUND = 0, 1, 2, 3, 4, 5, 6
_K_STATED, _K_TINY, _K_COND, _K_TWO, _K_ROWS, _K_NODES = 7, 8, 9, 10, 11, 12
_K_HEAD = 13


def family_constants(m, kernel, gj, rtol_stated, tiny, cond_ulps) -> np.ndarray:
    """The array `family_call`'s function reads: (m, q_s, u_s, n_lead) of the `NodeKernel`,
    b, rtol and round-off of the plan's Gauss-Jacobi tuple ``gj`` = (d, d^-beta, W, b, rtol,
    round_rel), `solve_impact`'s RTOL_STATED, smallest normal float and conditioning ulps
    (_NODE_ULPS_U eps), the exponent 2.0 of `solve._conditioning_at`, the table's rows and
    the nodes' count; then P, d, d^-beta and W, each contiguous."""
    d, fac, W, b, rtol, round_rel = gj
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
        cond_ulps,
        2.0,
        P.shape[0],
        d.shape[0],
    ]
    return np.concatenate([np.array(head, dtype=float), P.ravel(), d, fac, W.ravel()])


def _family_impact(v0, zeta, q_top, K):  # pragma: no cover
    """One impact of a compiled family by Gauss-Jacobi (0 <= zeta < 1); K from
    `family_constants`. Returns the fields of `ImpactSolution` as `power_call` does, with
    `solve._conditioning_at` charged (`solve._charged`) and `solve_impact`'s bound and range
    checks made, and last a status: 1.0 when it answered, 0.0 when the Gauss-Jacobi kernel
    refused (the caller runs the tanh-sinh ladder), -1.0 when a check refused (the caller
    hands over to `solve_impact`, which raises it)."""
    nr, nn = int(K[_K_ROWS]), int(K[_K_NODES])
    i = _K_HEAD + 5 * nr
    P = K[_K_HEAD:i].reshape((nr, 5))
    d, fac, W = K[i : i + nn], K[i + nn : i + 2 * nn], K[i + 2 * nn : i + 4 * nn].reshape((nn, 2))
    m = K[_K_M]
    # VirtualOscillator.__init__ and .zero_force_stretch, the same operations.
    wd = math.sqrt((1.0 - zeta) * (1.0 + zeta))
    sp = math.atan2(wd, zeta) / wd
    s_end = math.pi / wd
    prm = np.empty(11)
    prm[0], prm[1], prm[2], prm[3], prm[4], prm[5] = m, v0, zeta, wd, sp, s_end
    prm[6] = 2.0 * math.atan2(zeta, wd) / wd if zeta > 0.0 else 0.0
    prm[7], prm[8], prm[9], prm[10] = q_top, K[_K_QS], K[_K_US], K[_K_NLEAD]
    o = np.zeros(_OUT)
    _GJ(prm, P, d, fac, W, K[_K_B], K[_K_RTOL], K[_K_ROUND], o)
    rise, e_rise, mid, e_mid, fall, e_fall = o[0], o[1], o[2], o[3], o[4], o[5]
    q_max, f_max = o[6], o[7]
    if o[8] != _OK:
        return (q_max, f_max, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, rise, wd, sp, s_end, 0.0)
    # solve_impact's restitution and VirtualOscillator.restitution_zero_force.
    rest = math.exp(-math.pi * zeta / wd)
    rest_zf = math.exp(-2.0 * zeta * sp) if zeta > 0.0 else 1.0
    d2 = _EV(q_max, P)[2]
    # solve._conditioning_at: its ** 2 is Python's float power (libm pow), here too (a
    # literal 2 would compile to a product, which can round differently).
    u = 0.5 * m * math.pow(v0 * math.exp(-zeta * sp), K[_K_TWO])
    c = abs(u * d2) / (f_max * f_max) if f_max > 0 else np.inf
    if not math.isfinite(c):
        c = np.inf
    cond = K[_K_COND] * c
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
def _family_entry(gauss_jacobi, ev, entry: str | None, cache: bool):
    fn = specialise(_family_impact, cache, _GJ=gauss_jacobi, _EV=ev)
    if entry is not None:
        from reference_impl._cache import record_files

        record_files(entry, [fn])
    return fn


def family_call(plan):
    """The compiled whole-impact call of a `_one_call` plan with a Gauss-Jacobi rule, or
    None (no such rule, or no compiled evaluator). Disk-cached as the plan's kernels are:
    the table form always, an expression when its node loop came from the compile cache."""
    if plan.gj is None or plan.kernel.ev is None:
        return None
    if plan.kernel.terms:
        return _family_entry(plan.gauss_jacobi, plan.kernel.ev, None, True)
    entry = getattr(plan.kernel.nodes, "_hcv_entry", None)
    return _family_entry(plan.gauss_jacobi, plan.kernel.ev, entry, entry is not None)
