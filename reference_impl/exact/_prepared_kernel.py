"""The compiled calls of a prepared solver (`reference_impl.exact.prepared`, issue 27, goal 2).

One Python call of ``prepare(potential, m)(v0, zeta)`` makes one compiled call:

* `power_call`: a power law, `_power_kernel.power_impact` with its per-potential
  constants read from one array (a numba call unboxes each argument: sixteen cost
  ~0.6 us, five ~0.3 us), its output returned as the result's fields;
* `family_call(plan)`: the other compiled families, the oscillator of
  `VirtualOscillator` (the same formulas), the parameters of `_one_call._params`,
  the Gauss-Jacobi kernel of the family's `_one_call` plan (the very call
  `solve_impact` makes first), and, when it answers, the restitutions and the
  curvature U''(q_max) that `solve._conditioning` charges (`_one_call.curvature`:
  the same compiled evaluator at the same q_max).

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

__all__ = ["family_call", "power_call"]

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


def _family_impact(v0, zeta, q_top, c, P, d, fac, W, b, rtol, round_rel):  # pragma: no cover
    """One impact of a compiled family by Gauss-Jacobi (0 <= zeta < 1); c = (m, q_s, u_s,
    n_lead) of the family's `NodeKernel`. Returns the kernel's status (`_one_call._OK`
    when it answered; the rest is then meaningless otherwise), the six `Branches`
    fields, q_max, U'(q_max), wd, s_peak, s_end, the two restitutions and U''(q_max)."""
    # VirtualOscillator.__init__ and .zero_force_stretch, the same operations.
    wd = math.sqrt((1.0 - zeta) * (1.0 + zeta))
    sp = math.atan2(wd, zeta) / wd
    s_end = math.pi / wd
    prm = np.empty(11)
    prm[0], prm[1], prm[2], prm[3], prm[4], prm[5] = c[0], v0, zeta, wd, sp, s_end
    prm[6] = 2.0 * math.atan2(zeta, wd) / wd if zeta > 0.0 else 0.0
    prm[7], prm[8], prm[9], prm[10] = q_top, c[1], c[2], c[3]
    o = np.zeros(_OUT)
    _GJ(prm, P, d, fac, W, b, rtol, round_rel, o)
    rest = rest_zf = d2 = 0.0
    if o[8] == _OK:
        # solve_impact's restitution and VirtualOscillator.restitution_zero_force.
        rest = math.exp(-math.pi * zeta / wd)
        rest_zf = math.exp(-2.0 * zeta * sp) if zeta > 0.0 else 1.0
        d2 = _EV(o[6], P)[2]
    return (o[8], o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7], wd, sp, s_end, rest, rest_zf, d2)


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
