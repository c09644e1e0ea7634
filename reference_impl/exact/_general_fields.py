"""One general-law impact's reported numbers from a kernel's row, compiled (issue 38, goal 4).

`general_law.solve_law_impact` turns the row of a kernel (`_general_kernel.OUT_FIELDS`, in
the kernel's scaled units) into the fields of `LawImpactSolution`: the ends, the
restitutions and the bounds (``ERROR_SAFETY`` times the summed local estimates, plus
round-off, 100 n_steps ulps of the longest time). In Python those dozen float operations,
the row's list and its reads were ~2 us of a ~19 us Hertz call at rtol 1e-8; here they
run in the same compiled call as the Taylor kernel (`solve_formed`), or after another
kernel (`form`). The float operations are Python's, in its order (IEEE double, no
contraction into fused multiply-adds without numba's fastmath), so every field is the
one the Python lines gave, bit for bit (`verification/test_exact_frozen.py`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.exact._general_kernel import OUT_FIELDS, STOP_NO_RETURN_Q
from reference_impl.exact._general_taylor import solve as _taylor_solve

__all__ = ["ERROR_SAFETY", "FAILED", "FORMED", "LOST", "OK", "form", "solve_formed"]

# The bound reported is this multiple of the summed local error estimates (each the
# difference of the order-16 and order-14 extrapolants, itself an over-estimate of the
# order-16 error taken), plus round-off: a few hundred operations per step at 1 ulp.
ERROR_SAFETY = 10.0
_EPS = float(np.finfo(float).eps)
# What `form` says of a row: fields formed; not finished within the step budget (or q_max
# not finite: nothing formed); no return, stopped on the overlap (`STOP_NO_RETURN_Q`:
# formed, kept only where `general_law._refuse_lost_return` lets it pass).
OK, FAILED, LOST = 0, 1, 2
# What `form` returns after its flag, by `LawImpactSolution`'s names and in its order (the
# solution's fields less its inputs v0, m and law; `verification/test_exact_law_batch.py`
# checks it): where its callers read the tuple by name.
FORMED = (
    "max_penetration",
    "max_force",
    "peak_force",
    "time_of_max_penetration",
    "contact_time",
    "restitution",
    "contact_time_zero_force",
    "restitution_zero_force",
    "returns_to_q0",
    "error_time",
    "error_restitution",
    "n_steps",
)

(
    _T_PEAK,
    _Q_MAX,
    _MAX_FORCE,
    _PEAK_FORCE,
    _T_ZF,
    _W_ZF,
    _T_END,
    _W_END,
    _RETURNS,
    _ERR_T,
    _ERR_W,
    _N_STEPS,
    _STATUS,
    _STOP,
    _ERR_ZF,
) = (
    OUT_FIELDS.index(f)
    for f in (
        "t_peak",
        "q_max",
        "max_force",
        "peak_force",
        "t_zf",
        "w_zf",
        "t_end",
        "w_end",
        "returns",
        "err_t",
        "err_w",
        "n_steps",
        "status",
        "stop",
        "err_zf",
    )
)


@numba.njit(cache=True, error_model="numpy")
def form(r, v0, q_e):  # pragma: no cover - compiled
    """The fields of one impact from the kernel row ``r`` (speed ``v0`` m/s, top ``q_e`` m).

    Returns
    -------
    tuple
        (flag, q_max [m], max_force [N], peak_force [N], t_peak [s], t_end [s],
        restitution, t_zf [s], restitution_zero_force, returns_to_q0, error_time [s],
        error_restitution, n_steps), after the flag the fields `FORMED` names: flag `OK`;
        `LOST` (no return, stopped on the overlap: the fields are formed, the caller
        refuses them unless the creep never ends); `FAILED` with the rest void.
    """
    nan = math.nan
    if r[_STATUS] != 0.0 or not math.isfinite(r[_Q_MAX]):
        return FAILED, nan, nan, nan, nan, nan, nan, nan, nan, False, nan, nan, 0
    returns = r[_RETURNS] == 1.0
    # stopped on the overlap: the caller refuses it unless the creep provably never ends
    flag = LOST if not returns and r[_STOP] == STOP_NO_RETURN_Q else OK
    nst = int(r[_N_STEPS])
    t_scale = q_e / v0
    t_end = r[_T_END] if returns else math.inf
    t_zf = r[_T_ZF]
    tail = t_end if returns else (t_zf if math.isfinite(t_zf) else t_scale)
    err_t = ERROR_SAFETY * r[_ERR_T] * t_scale + 100 * nst * _EPS * tail
    if r[_ERR_ZF] > 0.0:  # the zero-force instant's own sensitivity (_general_kernel)
        err_t += ERROR_SAFETY * r[_ERR_ZF]
    err_w = ERROR_SAFETY * r[_ERR_W] + 100 * nst * _EPS
    e = -r[_W_END] / v0 if returns else 0.0
    return (
        flag,
        r[_Q_MAX],
        r[_MAX_FORCE],
        r[_PEAK_FORCE],
        r[_T_PEAK],
        t_end,
        e,
        t_zf,
        -r[_W_ZF] / v0,
        returns,
        err_t,
        err_w,
        nst,
    )


@numba.njit(cache=True, error_model="numpy")
def solve_formed(v0, q_e, ks, ps, cs, es, sc):  # pragma: no cover - compiled
    """`form` of `_general_taylor.solve` (same arguments): one compiled call per impact."""
    return form(_taylor_solve(v0, q_e, ks, ps, cs, es, sc), v0, q_e)
