"""The velocity-Verlet step, the compiled lane kernel and the term kinds they evaluate.

`_kdk` is the one source of the step (issue 27: one source per loop), numba-compatible
Python generic in its force ``_force_energy``: the lane kernel `_kernel` and the
recorder's loop `_record_kernel` (driven by `reference_impl.integrators.verlet_path`),
both here, call it compiled around the term table,
`reference_impl.integrators.verlet_expression` compiles it around an expression's force,
and the recorder runs it as Python around any `Potential`'s.
`_kernel` (numba) advances many lanes of one scene; the force of a potential with
a term table (`reference_impl.potentials._terms`: PowerLaw, Ellipsoid, Sphere,
`SaturatingForce`, expressions that are sums of powers, sums of them) is
`_force_energy`, selected by the family codes and parameter arrays of
`kernel_terms`, the adapter from that table. Conventions, statuses and the lane driver are in
`reference_impl.integrators.verlet`, which re-exports the public names.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.potentials._terms import TERM_CAP, TERM_POWER, TERM_SATURATING, term_rows
from reference_impl.potentials.base import Potential
from reference_impl.potentials.saturating import _SAT_SERIES_X, SaturatingForce, saturating_series

__all__ = ["SCENE_IMPACT", "SCENE_WALLS", "STATUS_NAMES", "SaturatingForce", "kernel_terms"]

SCENE_IMPACT = 0
SCENE_WALLS = 1

# Lane status codes (see STATUS_NAMES).
_ST_SKIPPED = 0  # not run: a smaller dt of its group already failed
_ST_COMPLETED = 1  # ran all its steps with E_n <= limit
_ST_SEPARATED = 2  # impact: left the wall (y <= 0 after contact)
_ST_OVER_LIMIT = 3  # E_n exceeded the lane's energy limit
_ST_BLOWN = 4  # q > q_sup or non-finite state
_ST_NO_SEPARATION = 5  # impact: still in contact after max_steps
_ST_END_GAIN = 6  # finished, but its last energy exceeds the lane's final limit
_ST_BOUNDED = 7  # crossed e_limit, then ran confirm_steps without exceeding e_confirm
STATUS_NAMES = (
    "skipped",
    "completed",
    "separated",
    "over-limit",
    "blown",
    "no-separation",
    "end-over-limit",
    "bounded",
)

# Kernel family codes and the row layout of the parameter array.
_FAM_POWER = 0  # (k, p, 1 / (p + 1), -)
_FAM_CAP = 1  # (c0 = pi b c / a^2, a, Kn, alpha)
_FAM_SATURATING = 2  # (F0, q_s, -, -)
_N_PAR = 4


def kernel_terms(pot: Potential) -> tuple[np.ndarray, np.ndarray] | None:
    """Family codes and parameter rows of ``pot`` for the numba kernel.

    An adapter of the potentials' one term table (`term_rows`): a power row
    (k, n, p) becomes (k, p, 1 / (p + 1)), a cap row (Kn, alpha, a, c0) becomes
    (c0, a, Kn, alpha), a saturating row (F0, q_s) stays (F0, q_s).

    Returns
    -------
    (fam, par) or None
        ``fam`` int64 (n_terms,), ``par`` float64 (n_terms, 4); None when the
        potential has no term table (the numpy fallback is then used).
    """
    rows = term_rows(pot)
    if rows is None:
        return None
    fam = np.zeros(len(rows), dtype=np.int64)
    par = np.zeros((len(rows), _N_PAR))
    for i, (code, c1, c2, c3, c4) in enumerate(rows):
        if code == TERM_POWER:
            fam[i], par[i, :3] = _FAM_POWER, (c1, c3, 1.0 / (c3 + 1.0))
        elif code == TERM_CAP:
            fam[i], par[i] = _FAM_CAP, (c4, c3, c1, c2)
        elif code == TERM_SATURATING:
            fam[i], par[i, :2] = _FAM_SATURATING, (c1, c2)
        else:  # a code this kernel does not know: the numpy fallback
            return None
    return fam, par


# ----------------------------------------------------------------------------
# numba kernel
# ----------------------------------------------------------------------------
# The saturating energy's series, the potential's own function compiled (one source: a
# change of the series there reaches the kernel; numba's cache is keyed by this file, so
# the potential's module is named here too: saturating.py).
_sat_series = numba.njit(cache=True, inline="always")(saturating_series)


@numba.njit(cache=True, inline="always")
def _force_energy(q, fam, par):
    """U'(q) (N) and U(q) (J) for q > 0, summed over the kernel terms."""
    F = 0.0
    U = 0.0
    for i in range(fam.shape[0]):
        f = fam[i]
        if f == _FAM_POWER:
            k = par[i, 0]
            p = par[i, 1]
            kqp = k * q**p
            F += kqp
            U += kqp * q * par[i, 2]
        elif f == _FAM_CAP:
            c0 = par[i, 0]
            a = par[i, 1]
            Kn = par[i, 2]
            al = par[i, 3]
            V = c0 * (a * q * q - q * q * q / 3.0)
            S = c0 * (2.0 * a * q - q * q)
            KVa = Kn * V**al
            F += KVa * S
            U += KVa * V / (al + 1.0)
        else:
            F0 = par[i, 0]
            qs = par[i, 1]
            x = q / qs
            x2 = x * x
            F += F0 * x2 / (1.0 + x2)
            if x < _SAT_SERIES_X:
                U += F0 * qs * _sat_series(x)
            else:
                U += F0 * qs * (x - math.atan(x))
    return F, U


# Lanes advanced in lockstep by the kernel: independent lanes interleaved in the
# inner loop hide the latency of pow(). Measured on the bench machine (CPU time,
# PowerLaw p = 1.37): 2.3e7 lane-steps/s one lane at a time, 3.5e7 with 8;
# 4 and 16 within 10 % of 8.
_BLOCK = 8


@numba.njit(cache=True, inline="always")
def _overlap(y, gap, scene):
    """Overlap q (m) and the sign of the contact force on y.

    q > 0 in contact; in flight minus the distance to the nearer wall (two walls) or y
    itself (impact), which the recorder reports.
    """
    if scene == SCENE_IMPACT:
        return y, -1.0
    # max() is the overlap with the nearer wall on either side (y - gap > 0 > -y beyond
    # the upper wall, -y > 0 > y - gap below the lower one), without a branch. Measured
    # interleaved against main's loops (CPU time, load 3-6 on 2 cores): the lane kernel
    # (eight lanes in lockstep; presumably mispredicted branches) 0.96 of its two-branch
    # form, the single-body recorder (max() on its latency chain) 1.04-1.08 of its
    # four-branch form on two walls. Branches everywhere instead: lanes 1.02, recorder
    # 0.96-0.99; the lanes are the hot loop (a search runs ~1e7 lane-steps).
    return max(y - gap, -y), -1.0 if y > gap else 1.0


@numba.njit(cache=True, inline="always")
def _coefficient(q, fam, par):
    """A damping coefficient C(q) (kg/s) given per step: none in the compiled bindings;
    the Python binding of `_kdk` (`reference_impl.integrators.verlet_path`) rebinds it."""
    return 0.0


# Contact state after one step (`_kdk`).
_FREE = 0  # no overlap: no force
_CONTACT = 1  # overlap in the potential's domain: force evaluated
_BEYOND = 2  # overlap beyond q_sup, or nan: the run has blown up


@numba.njit(cache=True, inline="always")
def _kdk(
    y, vel, F, half, dt, scene, gap, q_sup, c_damp, extra, c_pow, a_pow, c_fun, clip, fam, par
):
    """One velocity-Verlet step: half kick, drift, force at the new position, half kick.

    The one source of the step (issue 27): the lane kernel `_kernel` and the recorder
    (`reference_impl.integrators.verlet_path`) call it; it is bound to the term table's
    `_force_energy` here (compiled), to an expression's compiled force by
    `reference_impl._jit.specialise`, and to a Python potential's by
    `reference_impl._jit.rebind` (run as Python).

    Parameters
    ----------
    y, vel, F : float
        Position (m), velocity (m/s) and total force on y (N) at step n.
    half, dt : float
        dt / (2 m) (s/kg) and the step dt (s).
    scene, gap : int, float
        `SCENE_IMPACT` or `SCENE_WALLS` and its gap (m); see `_overlap`.
    q_sup : float
        Largest overlap of the potential's domain (m).
    c_damp : float
        2 zeta sqrt(m) of the universal damping C = c_damp U'/sqrt(2U) (kg^(1/2)).
    extra : bool
        Any of the three below in use (one test per step instead of three).
    c_pow, a_pow : float
        Power-law damping C = c_pow q^a_pow (kg/s/m^a), off at c_pow = 0.
    c_fun : bool
        Add the per-step coefficient ``_coefficient(q, fam, par)`` (kg/s).
    clip : bool
        Set a tensile total contact force to 0.
    fam, par
        The arguments of ``_force_energy`` (term table: family codes and parameters).

    Returns
    -------
    y, vh, vel, F, q, rep, U, state
        Position, half-step and new velocity, total force, overlap, repulsive contact
        force (N, the dashpot evaluated with vh), U(q) (J, 0 out of contact) and the
        contact state (`_FREE`, `_CONTACT`, `_BEYOND`; at `_BEYOND` vel and F are those
        of step n and rep is nan).
    """
    vh = vel + half * F
    y = y + dt * vh
    q, sgn = _overlap(y, gap, scene)
    rep = 0.0
    U = 0.0
    if q > 0.0:
        if not q <= q_sup:  # also catches nan
            return y, vh, vel, F, q, math.nan, U, _BEYOND
        fe, U = _force_energy(q, fam, par)
        # The dashpot opposes dq/dt = -sgn vh; written on the total force F, as the
        # lane kernel always was: F = sgn * rep bit for bit (sgn = +-1, negation is exact),
        # and two multiplications shorter than building rep first (4 % on damped lanes).
        F = sgn * fe
        if c_damp > 0.0 and U > 0.0:
            F -= c_damp * fe / math.sqrt(2.0 * U) * vh
        if extra:
            if c_pow > 0.0:
                F -= c_pow * q**a_pow * vh
            if c_fun:
                F -= _coefficient(q, fam, par) * vh
            if clip and sgn * F < 0.0:
                F = sgn * 0.0
        rep = sgn * F
        state = _CONTACT
    else:
        F = 0.0
        state = _FREE
    vel = vh + half * F
    return y, vh, vel, F, q, rep, U, state


# Lane-steps one call of the kernel may take before it returns to Python, where
# a pending SIGINT (Ctrl-C) is raised: ~0.1 s at the measured 3.5e7 lane-steps/s,
# while the cost of a call (~20 us) stays below 1e-3 of the work.
_CHUNK_LANE_STEPS = 1 << 22

# Columns of the per-lane state saved between kernel calls.
_FS_Y, _FS_V, _FS_F, _FS_E, _FS_E0, _FS_EM = range(6)
_IS_N, _IS_CP, _IS_TOUCHED, _IS_TRIPPED = range(4)
# Status of a lane not yet finished: not started, or started and saved.
_PENDING = -1
_RUNNING = -2


@numba.njit(cache=True)
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
                yy, vh, vv, f, q, rep, U, state = _kdk(
                    y[j], v[j], F[j], halfB[j], h, scene, gapB[j], q_sup, c_damp,
                    False, 0.0, 0.0, False, False, fam, par,
                )  # fmt: skip
                y[j] = yy
                status = -1
                if state == _BEYOND:
                    status = _ST_BLOWN
                else:
                    if state == _CONTACT:
                        touched[j] = True
                    F[j] = f
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


# ----------------------------------------------------------------------------
# the recorder's loop (`reference_impl.integrators.verlet_path`)
# ----------------------------------------------------------------------------
# The per-step coefficient C(q) of `_kdk` is on only in the Python binding given one: a
# global, so that the compiled recorder holds no trace of it (the dead test, a runtime
# flag, cost 5-8 % of a step: measured interleaved, 2e5 two-walls steps, load 5 on 2 cores).
_WITH_COEFFICIENT = False


# The recorder's loop lives here, beside `_kdk`, not in `verlet_path`: numba checks a
# cached function against its own source file only, so a loop in another file kept the
# step it had inlined after `_kdk` changed here (seen while measuring; issue 27).
@numba.njit(cache=True)
def _record_kernel(fam, par, q_sup, m, c_damp, c_pow, a_pow, clip, dt, v0, scene, gap, q, v, f):
    """Integrate one body for up to q.shape[0] - 1 steps of `_kdk`; fill q, v, f (repulsive force).

    Returns the status: n > 0 separated at step n (impact: first q <= 0 after
    contact), -n blown at step n (q > q_sup; q[n] and v[n] hold the overlap and the
    half-step velocity, f[n] is nan), 0 when it ran every step. Damping: the
    universal law with 2 zeta sqrt(m) = c_damp, plus c_pow q^a_pow, plus (where
    ``_WITH_COEFFICIENT``) the per-step coefficient of the binding; with ``clip`` a
    tensile total force is set to 0. Compiled as it stands (term table: ``fam``,
    ``par``); `verlet_path._record_python` is the same function run as Python around a
    `Potential`.
    """
    y = 0.0
    vel = v0 if scene == SCENE_IMPACT else -v0  # two-walls: at the lower wall, moving into it
    F = 0.0
    half = 0.5 * dt / m
    q[0] = 0.0
    v[0] = vel
    f[0] = 0.0
    touched = False
    # One loop-invariant test for the rarely used terms: written as two tests in the
    # loop, the unused pow() slowed an undamped-law impact by 10 % (measured, 1000 steps).
    extra = c_pow > 0.0 or clip or _WITH_COEFFICIENT
    for n in range(1, q.shape[0]):
        y, vh, vel, F, qq, rep, _, state = _kdk(
            y, vel, F, half, dt, scene, gap, q_sup, c_damp, extra, c_pow, a_pow,
            _WITH_COEFFICIENT, clip, fam, par,
        )  # fmt: skip
        if state == _BEYOND:
            q[n] = qq
            v[n] = vh
            f[n] = np.nan
            return -n
        if state == _CONTACT:
            touched = True
        q[n] = qq
        v[n] = vel
        f[n] = rep
        if scene == SCENE_IMPACT and touched and qq <= 0.0:
            return n
    return 0
