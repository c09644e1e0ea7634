"""The compiled velocity-Verlet lane kernel as it stood on main at commit 051ac30 (frozen).

Issue 27 goal 7 made the step of every Verlet loop one function
(`reference_impl.integrators.verlet_kernel._kdk`). `verification/test_verlet_one_step.py`
holds the lane engine to this copy bit for bit. Copied unchanged except: compiled without
a disk cache (never sharing an entry with the package's kernel) and the force passed in
by rebinding the global ``_force_energy`` (`frozen_kernel`), as the package did for
expressions.
"""

from __future__ import annotations

import math
import types

import numba
import numpy as np

from reference_impl.integrators.verlet_kernel import (
    _ST_BLOWN,
    _ST_BOUNDED,
    _ST_COMPLETED,
    _ST_END_GAIN,
    _ST_NO_SEPARATION,
    _ST_OVER_LIMIT,
    _ST_SEPARATED,
    _ST_SKIPPED,
    SCENE_IMPACT,
    _force_energy,
)

__all__ = ["frozen_kernel"]


@numba.njit(inline="always")
def _overlap(y, gap, scene):
    """Overlap q (m, > 0 in contact) and the sign of the contact force on y."""
    if scene == SCENE_IMPACT:
        return y, -1.0
    if y > gap:
        return y - gap, -1.0
    return -y, 1.0


# Columns of the per-lane state saved between kernel calls.
_FS_Y, _FS_V, _FS_F, _FS_E, _FS_E0, _FS_EM = range(6)
_IS_N, _IS_CP, _IS_TOUCHED, _IS_TRIPPED = range(4)
# Status of a lane not yet finished: not started, or started and saved.
_PENDING = -1
_RUNNING = -2


def _kernel(
    fam,
    par,
    q_sup,
    m,
    scene,
    c_damp,
    dt,
    y0,
    v0,
    gaps,
    e_limit,
    e_confirm,
    confirm_steps,
    e_final,
    max_steps,
    group,
    order,
    skip_after_fail,
    checkpoints,
    block,
    b_start,
    budget,
    fail_dt,
    fs,
    istate,
    st,
    steps,
    emax,
    eend,
    hist,
):
    """Integrate lanes from block ``b_start`` on for about ``budget`` lane-steps.

    Lanes are taken in ``order`` in blocks of ``block`` advanced in lockstep. With
    ``skip_after_fail`` a lane whose dt is >= the smallest failing dt already
    seen in its group (``fail_dt``) is skipped, or stopped (status skipped) if
    running. The state of unfinished lanes is kept in ``fs``/``istate`` so that
    the caller can resume; returns the index (into ``order``) of the first block
    not yet finished, ``order.shape[0]`` when every lane has finished.
    """
    n_cp = checkpoints.shape[0]
    B = block
    lane = np.zeros(B, dtype=np.int64)
    act = np.zeros(B, dtype=np.bool_)
    touched = np.zeros(B, dtype=np.bool_)
    tripped = np.zeros(B, dtype=np.bool_)
    cp = np.zeros(B, dtype=np.int64)
    nB = np.zeros(B, dtype=np.int64)
    y = np.zeros(B)
    v = np.zeros(B)
    F = np.zeros(B)
    E = np.zeros(B)
    E0 = np.zeros(B)
    em = np.zeros(B)
    hB = np.zeros(B)  # per-lane constants copied next to the state
    halfB = np.zeros(B)
    gapB = np.zeros(B)
    limB = np.zeros(B)
    nmaxB = np.zeros(B, dtype=np.int64)
    work = 0
    b0 = b_start
    while b0 < order.shape[0]:
        nb = min(B, order.shape[0] - b0)
        n_act = 0
        for j in range(nb):
            ln = order[b0 + j]
            lane[j] = ln
            act[j] = False
            if st[ln] == _PENDING:
                if skip_after_fail and dt[ln] >= fail_dt[group[ln]]:
                    st[ln] = _ST_SKIPPED
                    continue
                q, sgn = _overlap(y0[ln], gaps[ln], scene)
                f0 = 0.0
                U = 0.0
                if q > 0.0:  # a lane may start in contact
                    fe, U = _force_energy(q, fam, par)
                    f0 = sgn * fe
                e0 = 0.5 * m * v0[ln] * v0[ln] + U
                fs[ln, _FS_Y] = y0[ln]
                fs[ln, _FS_V] = v0[ln]
                fs[ln, _FS_F] = f0
                fs[ln, _FS_E] = e0
                fs[ln, _FS_E0] = e0
                fs[ln, _FS_EM] = e0
                istate[ln, _IS_N] = 0
                istate[ln, _IS_CP] = 0
                istate[ln, _IS_TOUCHED] = 1 if q > 0.0 else 0
                istate[ln, _IS_TRIPPED] = 0
                st[ln] = _RUNNING
            if st[ln] != _RUNNING:
                continue
            y[j] = fs[ln, _FS_Y]
            v[j] = fs[ln, _FS_V]
            F[j] = fs[ln, _FS_F]
            E[j] = fs[ln, _FS_E]
            E0[j] = fs[ln, _FS_E0]
            em[j] = fs[ln, _FS_EM]
            nB[j] = istate[ln, _IS_N]
            cp[j] = istate[ln, _IS_CP]
            touched[j] = istate[ln, _IS_TOUCHED] != 0
            tripped[j] = istate[ln, _IS_TRIPPED] != 0
            hB[j] = dt[ln]
            halfB[j] = 0.5 * dt[ln] / m
            gapB[j] = gaps[ln]
            limB[j] = e_confirm[ln] if tripped[j] else e_limit[ln]
            nmaxB[j] = confirm_steps[ln] if tripped[j] else max_steps[ln]
            act[j] = True
            n_act += 1
        while n_act > 0 and work < budget:
            for j in range(nb):
                if not act[j]:
                    continue
                work += 1
                nB[j] += 1
                n = nB[j]
                h = hB[j]
                half = halfB[j]
                vh = v[j] + half * F[j]
                yy = y[j] + h * vh
                y[j] = yy
                q, sgn = _overlap(yy, gapB[j], scene)
                status = -1
                U = 0.0
                f = 0.0
                if q > 0.0:
                    if not q <= q_sup:  # also catches NaN
                        status = _ST_BLOWN
                    else:
                        fe, U = _force_energy(q, fam, par)
                        f = sgn * fe
                        if c_damp > 0.0 and U > 0.0:
                            f -= c_damp * fe / math.sqrt(2.0 * U) * vh
                        touched[j] = True
                if status < 0:
                    F[j] = f
                    vv = vh + half * f
                    v[j] = vv
                    e = 0.5 * m * vv * vv + U
                    if not e < math.inf:  # non-finite velocity or energy
                        status = _ST_BLOWN
                    else:
                        E[j] = e
                        if e > em[j]:
                            em[j] = e
                        while cp[j] < n_cp and checkpoints[cp[j]] <= n:
                            hist[lane[j], cp[j]] = em[j] / E0[j]
                            cp[j] += 1
                        if e > limB[j]:
                            ln = lane[j]
                            if not tripped[j] and e_confirm[ln] > e_limit[ln]:
                                # First crossing: follow the lane on to the confirmation.
                                tripped[j] = True
                                limB[j] = e_confirm[ln]
                                nmaxB[j] = confirm_steps[ln]
                                if e > limB[j]:
                                    status = _ST_OVER_LIMIT
                            else:
                                status = _ST_OVER_LIMIT
                        if status >= 0:
                            pass
                        elif scene == SCENE_IMPACT and touched[j] and yy <= 0.0:
                            status = _ST_SEPARATED
                        elif n >= nmaxB[j]:
                            if tripped[j]:
                                status = _ST_BOUNDED
                            elif scene == SCENE_IMPACT:
                                status = _ST_NO_SEPARATION
                            else:
                                status = _ST_COMPLETED
                if status < 0:
                    continue
                # The lane has finished.
                ln = lane[j]
                if (
                    status != _ST_OVER_LIMIT
                    and status != _ST_BLOWN
                    and status != _ST_BOUNDED
                    and E[j] > e_final[ln]
                ):
                    status = _ST_END_GAIN
                st[ln] = status
                steps[ln] = n
                emax[ln] = em[j]
                eend[ln] = np.nan if status == _ST_BLOWN else E[j]
                act[j] = False
                n_act -= 1
                if status == _ST_OVER_LIMIT or status == _ST_BLOWN or status == _ST_END_GAIN:
                    g = group[ln]
                    if h < fail_dt[g]:
                        fail_dt[g] = h
                    if skip_after_fail:  # stop block-mates that can no longer matter
                        for i in range(nb):
                            li = lane[i]
                            if act[i] and group[li] == g and dt[li] >= h:
                                st[li] = _ST_SKIPPED
                                steps[li] = nB[i]
                                act[i] = False
                                n_act -= 1
        if n_act > 0:  # out of budget: save the running lanes and return
            for j in range(nb):
                if act[j]:
                    ln = lane[j]
                    fs[ln, _FS_Y] = y[j]
                    fs[ln, _FS_V] = v[j]
                    fs[ln, _FS_F] = F[j]
                    fs[ln, _FS_E] = E[j]
                    fs[ln, _FS_EM] = em[j]
                    istate[ln, _IS_N] = nB[j]
                    istate[ln, _IS_CP] = cp[j]
                    istate[ln, _IS_TOUCHED] = 1 if touched[j] else 0
                    istate[ln, _IS_TRIPPED] = 1 if tripped[j] else 0
            return b0
        b0 += B
    return b0


_FROZEN: dict = {}


def frozen_kernel(force_energy=None):
    """The frozen `_kernel` compiled around ``force_energy`` (default: the term table)."""
    fe = _force_energy if force_energy is None else force_energy
    if fe not in _FROZEN:
        env = dict(_kernel.__globals__, _force_energy=fe)
        fn = types.FunctionType(_kernel.__code__, env, "_frozen_kernel")
        _FROZEN[fe] = numba.njit(error_model="python")(fn)
    return _FROZEN[fe]
