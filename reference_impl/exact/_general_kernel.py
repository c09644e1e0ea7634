"""The integrator behind `reference_impl.exact.general_law`: one impact m q'' + C(q) q' + U'(q) = 0.

One algorithm around a force function ``fc(q, full, ks, ps, cs, es, sc)`` returning
(U, U', U'', C, C') at one overlap q: compiled with numba (cached on disk) for sums
of power laws, and the same functions' Python source re-bound by `python_solver`
to another ``fc`` for the other families. Three phases, each in a variable
in which the solution is smooth, integrated by the Gragg-Bulirsch-Stoer
extrapolation (modified midpoint rule with n_j = 2, 4, ..., 16, Aitken-Neville in
h^2; order 14, with the order-12 entry as the error estimate):

1. entry: q = q_in sigma^8, sigma from 0 to 1, unknowns (w = q', t) as functions of
   sigma. Every power of q in U' and C becomes a power of sigma at least 8 times
   larger, so q^1.5 (Hertz) is sigma^12 and q^0.25 (Tsuji) sigma^2: the square-root
   singularity of q(t) at contact (q ~ v0 t + c t^(n)) is gone and the high order is
   kept. The phase stops early if the damping has halved w (a turning point must
   not come near: dw/dq ~ 1/w).
2. middle: physical time, unknowns (q, w), smooth while q > 0 (pure Hunt-Crossley with
   alpha v0 > HC_LOG_X: (q, l = log(1 + alpha w)), since l' = -alpha U'(q)/m is not stiff
   where 1 + alpha w -> 0 on the return). Events (located by
   the Illinois method on re-integrated sub-steps): w = 0 (maximum penetration),
   total force F = U' + C w = 0 after it (the zero-force end), dF/dt = 0 with F
   falling (a peak of the contact force).
3. exit: once q <= q_max / 10 on the way out with the kinetic energy dominating
   (U'(q) q <= m w^2 / 2, so dw/dq ~ U'/(m w) is not stiff), q = q_s sigma^8 with
   sigma from 1 to 0, unknowns (w, t), to q = 0 exactly.

A return along the slow manifold of an overdamped law (w -> 0 with q: the kinetic
energy never dominates again) is reported as no return: see `_NO_RETURN_Q` (the field
"stop" says which test stopped it; the caller refuses where that cannot be right).

A pure Hunt-Crossley law (sc[6] = 1) has F = U'(q) (1 + alpha w) with
1 + alpha w = (1 + alpha v0) exp(-(alpha/m) int U' dt) > 0: the force never vanishes
before q = 0, so no zero-force event is searched (the round-off of U' + C w, ~1e-16 U',
exceeds U' (1 + alpha w) once alpha v0 >~ 30 and made spurious ones; issue 29).
"""

from __future__ import annotations

import math
import types

import numba
import numpy as np

# The step and the power-law force function live in `_general_step`; imported by name so
# that `python_solver` finds them (and the constants they read) in this module's namespace.
from reference_impl.exact._general_step import KCOL, KSUB, deriv, fc, gbs, state

__all__ = ["OUT_FIELDS", "STOP_CREEP", "STOP_NO_RETURN_Q", "solve", "python_solver"]

# Local error tolerance per step, relative to the scales (q_E, v0, t_E), and in phases 2
# (time, (q, w)) and 3 to the current state where that is smaller (a near-critical return
# decays by orders; see `solve`): the global error is the sum over ~20-100 steps, so 1e-14
# per step keeps the measured error at ~1e-14 (the estimate is the order-12 entry).
TOL = 1e-14
# Entry phase: up to this fraction of the elastic turning point q_E.
Q_IN_FRAC = 0.1
# Exit phase: from at most this fraction of q_max on the way out.
Q_OUT_FRAC = 0.1
# Overlap (fraction of q_max) below which a return whose potential energy still outweighs
# its kinetic energy (U' q > m w^2, the slow manifold of an overdamped law) is declared not
# to return: from there, at speed |w| <= sqrt(2 n U(q) / m), it needs at least
# (q/q_E)^(1 - n/2) elastic times t_E (1e4 t_E for Hertz) and leaves with e < 1e-13.
_NO_RETURN_Q = 1e-10
# Ratio C q / (m |w|) above which the return is quasi-static (see the creep test in `solve`).
_CREEP_RATIO = 100.0
# Hunt-Crossley impacts with alpha v0 above this take phase 2 in (q, log(1 + alpha w)) (see
# `solve`); below it the (q, w) form is not stiff and keeps the common path unchanged.
HC_LOG_X = 10.0
# Step budget of one impact (a smooth contact takes ~30-100 steps).
MAX_STEPS = 20000
# Illinois iterations of an event location (converges superlinearly: ~8 suffice).
MAX_EVENT_ITER = 60
# Longest phase-2 step on the way out, as a fraction of q / |w| (the time to q = 0, where
# q^p and q^a of U' and C are not analytic: a branch point of q(t), w(t)). The step's error
# estimate (the order-12 entry's difference) holds where the extrapolation is in its
# asymptotic regime, i.e. where the solution's radius of convergence at every point of the
# step exceeds the step: its end must stay at least h from the branch point, h <= d - h,
# so h <= d / 2. At 0.9 the end came within d / 10, a radius of 1/9 of the step: estimate
# 5e-15, true error of w 1.6e-12 (C = c q^1.5 on k q^2); at 0.5 the restitution is 2e-14
# off with the same bound (30 steps instead of 28).
_EXIT_REACH = 0.5

OUT_FIELDS = (
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
# Why a run without return stopped (field "stop"): the overlap fell below _NO_RETURN_Q q_max,
# or the creep test held (see `solve`); 0 when the body returned.
STOP_NO_RETURN_Q = 1.0
STOP_CREEP = 2.0


# ---- the algorithm (module docstring) -------------------------------------------
# error_model "numpy" throughout (here and in `_general_step`): `_law_batch` runs this
# kernel in a prange loop, where an exception (a division by zero) cannot be carried out
# and poisoned every later call (issue 36); inf/NaN is refused by the status tests. The
# same bits for every nonzero divisor.


@numba.njit(cache=True, error_model="numpy")
def forces(q, w, ks, ps, cs, es, sc):
    """(F, dF/dt, U', U' q) at (q, w): F = U' + C w the total contact force."""
    m = sc[0]
    U, dU, d2U, C, dC = fc(q, True, ks, ps, cs, es, sc)
    F = dU + C * w
    wd = -F / m
    dF = d2U * w + dC * w * w + C * wd
    return F, dF, dU, dU * q


@numba.njit(cache=True, error_model="numpy")
def event_g(kind, q, w, ks, ps, cs, es, sc):
    if kind == 0:
        return w
    F, dF, dU, Uq = forces(q, w, ks, ps, cs, es, sc)
    if kind == 1:
        return F
    return dF


@numba.njit(cache=True, error_model="numpy")
def event_dg(kind, mode, qs, s, q, w, ks, ps, cs, es, sc):
    """d g / d(independent variable) for kinds 0 (w) and 1 (F); nan for kind 2."""
    if kind == 2:
        return np.nan
    F, dF, dU, Uq = forces(q, w, ks, ps, cs, es, sc)
    d = -F / sc[0] if kind == 0 else dF
    if mode == 1:  # per unit sigma: dt/dsigma = (dq/dsigma) / w
        d *= KSUB * qs * s ** (KSUB - 1.0) / w
    return d


@numba.njit(cache=True, error_model="numpy")
def locate(kind, mode, qs, s, a, b, h, g0, g1, ea, eb, ks, ps, cs, es, sc, Ta, Tb):
    """Sub-step tau in (0, h) where event ``kind`` changes sign; state there.

    Kinds 0 (w) and 1 (F), whose derivative is known: a cubic Hermite first
    guess, then Newton on the re-integrated sub-step (kept inside the bracket),
    the last correction delta < 1e-8 h applied to the state to first order
    (its error delta^2 is below round-off). Kind 2 (dF/dt, the peak force, whose
    value is stationary there): Illinois to 1e-7 h, enough for F to round-off.
    """
    lo, hi = 0.0, h
    glo, ghi = g0, g1
    side = 0
    tau = (lo * ghi - hi * glo) / (ghi - glo)
    if kind != 2:
        q0, w0 = state(mode, qs, s, a, b)
        q1, w1 = state(mode, qs, s + h, ea, eb)
        d0 = event_dg(kind, mode, qs, s, q0, w0, ks, ps, cs, es, sc) * h
        d1 = event_dg(kind, mode, qs, s + h, q1, w1, ks, ps, cs, es, sc) * h
        # Hermite cubic in x = tau/h: bisect its sign change a few times (cheap, no ODE).
        xl, xh, gl = 0.0, 1.0, g0
        for _ in range(30):
            x = 0.5 * (xl + xh)
            h00 = (1 + 2 * x) * (1 - x) ** 2
            h10 = x * (1 - x) ** 2
            h01 = x * x * (3 - 2 * x)
            h11 = x * x * (x - 1)
            gx = h00 * g0 + h10 * d0 + h01 * g1 + h11 * d1
            if (gx > 0) == (gl > 0):
                xl, gl = x, gx
            else:
                xh = x
        tau = 0.5 * (xl + xh) * h
    ra, rb = a, b
    tol = 1e-7 * abs(h) if kind == 2 else 4e-16 * abs(h)
    for _ in range(MAX_EVENT_ITER):
        if not (min(lo, hi) < tau < max(lo, hi)):
            tau = 0.5 * (lo + hi)
        ra, rb, _e1, _e2 = gbs(mode, qs, s, a, b, tau, ks, ps, cs, es, sc, Ta, Tb)
        q, w = state(mode, qs, s + tau, ra, rb)
        g = event_g(kind, q, w, ks, ps, cs, es, sc)
        if g == 0.0:
            break
        if (g > 0) == (glo > 0):
            lo, glo = tau, g
            if side == -1:
                ghi *= 0.5
            side = -1
        else:
            hi, ghi = tau, g
            if side == 1:
                glo *= 0.5
            side = 1
        # Converged: stop before a new tau, so that (tau, ra, rb) stay one state (the
        # old order returned the next tau with this state: in sigma, q(tau) then missed
        # w, and the peak force was 2e-12 off for viscoelastic A = 30 s on Hertz).
        if abs(hi - lo) <= tol:
            break
        dg = event_dg(kind, mode, qs, s + tau, q, w, ks, ps, cs, es, sc)
        if dg == dg and dg != 0.0:
            step = -g / dg
            if abs(step) <= 1e-8 * abs(h) and min(lo, hi) <= tau + step <= max(lo, hi):
                da, db = deriv(mode, qs, s + tau, ra, rb, ks, ps, cs, es, sc)
                tau += step
                ra += step * da
                rb += step * db
                break
            tau += step
        else:
            tau = (lo * ghi - hi * glo) / (ghi - glo)
    return tau, ra, rb


@numba.njit(cache=True, error_model="numpy")
def solve(v0, qE, ks, ps, cs, es, sc):
    """One impact; returns an array of OUT_FIELDS (see module docstring)."""
    m = sc[0]
    tE = qE / v0
    Ta = np.empty((KCOL, KCOL))
    Tb = np.empty((KCOL, KCOL))
    out = np.full(len(OUT_FIELDS), np.nan)
    errsum = 0.0  # local error estimates, relative to v0 and q_E (-> the restitution bound)
    errsum_t = 0.0  # the same in units of t_E (-> the time bound)
    sw1 = 0.0  # summed local errors of w in phase 1 (m/s; see the Hunt-Crossley mode)
    nsteps = 0
    # ---- phase 1: entry in sigma, (w, t) ------------------------------------
    qs = Q_IN_FRAC * qE
    F0, dF0, dU0, Uq0 = forces(0.0, v0, ks, ps, cs, es, sc)
    peak = F0  # the force just after contact (C(0) v0; 0 unless C(0) > 0)
    dF_prev = dF0
    s, a, b = 0.0, v0, 0.0
    h = 0.25
    while s < 1.0:
        nsteps += 1
        if nsteps > MAX_STEPS:
            out[12] = 1.0
            return out
        hs = min(h, 1.0 - s)
        na, nb, ea, eb = gbs(1, qs, s, a, b, hs, ks, ps, cs, es, sc, Ta, Tb)
        err = max(ea / v0, eb / tE)
        if not (err <= TOL) or not (na >= 0.4 * v0):
            h = hs * (
                0.25
                if not (err == err) or not (na >= 0.4 * v0)
                else max(0.2, 0.9 * (TOL / err) ** (1.0 / (2 * KCOL - 3)))
            )
            continue
        qn = qs * (s + hs) ** KSUB
        F, dF, dU, Uq = forces(qn, na, ks, ps, cs, es, sc)
        if dF_prev > 0 and dF < 0:
            tau, ra, rb = locate(
                2, 1, qs, s, a, b, hs, dF_prev, dF, na, nb, ks, ps, cs, es, sc, Ta, Tb
            )
            Fp, _, _, _ = forces(qs * (s + tau) ** KSUB, ra, ks, ps, cs, es, sc)
            peak = max(peak, Fp)
        dF_prev = dF
        errsum += err
        errsum_t += err
        sw1 += ea
        s, a, b = s + hs, na, nb
        h = hs * min(4.0, 0.9 * (TOL / max(err, 1e-300)) ** (1.0 / (2 * KCOL - 3)))
        if a < 0.7 * v0:
            break
    # ---- phase 2: physical time, (q, w), or (q, l) for Hunt-Crossley ---------
    t = b
    q, w = qs * s**KSUB, a
    h = 0.05 * q / w
    # Pure Hunt-Crossley with alpha v0 > HC_LOG_X: mode 2, unknown l = log(1 + alpha w), whose
    # rate -alpha U'/m does not depend on w (in (q, w) the return is stiff at rate
    # alpha U'/m ~ alpha v0 / t_E, with 1 + alpha w -> 0: 16500 steps at alpha v0 = 1e5).
    mode2, al = 0, 0.0
    b2 = w
    sq, sw = 0.0, sw1  # mode 2: summed local errors of q (m) and w (m/s)
    mq, mw = 0.0, 0.0  # recent local errors of q and w (see the zero-force event)
    srel = 0.0  # summed local errors relative to the current state (see phase 3's end)
    if sc[6] == 1.0 and sc[1] * v0 > HC_LOG_X:
        mode2, al = 2, sc[1]
        b2 = math.log1p(al * w)
    past_peak = False
    zf_found = False
    q_max = np.nan
    F, dF, dU, Uq = forces(q, w, ks, ps, cs, es, sc)
    exit_now = False
    while True:
        nsteps += 1
        if nsteps > MAX_STEPS:
            out[12] = 1.0
            return out
        nq, nb2, eq, ew = gbs(mode2, al, t, q, b2, h, ks, ps, cs, es, sc, Ta, Tb)
        nw = nb2
        el = 0.0
        if mode2 == 2:  # dw = (1 + alpha w) dl / alpha
            nw = math.expm1(nb2) / al
            el = ew * min(1.0, math.exp(nb2))
            ew *= math.exp(nb2) / al
        # In mode 2 also l itself, weighted by 1 + alpha w where that is below 1: near q_max
        # an l error of 1e-8 is only 1e-14 of v0 in w at alpha v0 = 1e6, yet the
        # extrapolation is then far from its asymptotic regime and the error estimates of
        # the step no longer hold (q_max was 1.2e-11 off, counted 1e-13).
        if mode2 == 0:
            # Relative to the current state, not to (q_E, v0): on a near-critical return the
            # state decays by orders (e = 2.7e-10 at zeta = 0.99 on Hertz) and errors fixed
            # in q_E and v0 were 1e-4 of the speed there (t_end 5e-9 off, bound 1.8e-12).
            err = max(eq / min(qE, q), ew / min(v0, max(abs(w), math.sqrt(max(Uq, 0.0) / m))), el)
        else:
            err = max(eq / qE, ew / v0, el)
        if err <= TOL and nq > 0.0:
            sq += eq
            sw += ew
        if not (err <= TOL) or not (nq > 0.0):
            if err == err and nq > 0.0:
                h *= max(0.2, 0.9 * (TOL / err) ** (1.0 / (2 * KCOL - 3)))
            else:
                h *= 0.25
            continue
        nF, ndF, ndU, nUq = forces(nq, nw, ks, ps, cs, es, sc)
        # events in time order: peak of w = 0, peak force, zero force
        if not past_peak and nw < 0.0:
            tau, ra, rb = locate(
                0, mode2, al, t, q, b2, h, w, nw, nq, nb2, ks, ps, cs, es, sc, Ta, Tb
            )
            out[0] = t + tau
            q_max = ra
            out[1] = ra
            _, _, dUm, _ = forces(ra, 0.0, ks, ps, cs, es, sc)
            out[2] = dUm
            past_peak = True
        if dF > 0 and ndF < 0:
            tau, ra, rb = locate(
                2, mode2, al, t, q, b2, h, dF, ndF, nq, nb2, ks, ps, cs, es, sc, Ta, Tb
            )
            qa, wa = state(mode2, al, t + tau, ra, rb)
            Fp, _, _, _ = forces(qa, wa, ks, ps, cs, es, sc)
            peak = max(peak, Fp)
        if past_peak and not zf_found and sc[6] == 0.0 and F > 0 and nF <= 0:
            tau, ra, rb = locate(1, 0, 0.0, t, q, w, h, F, nF, nq, nw, ks, ps, cs, es, sc, Ta, Tb)
            out[4] = t + tau
            out[5] = rb
            zf_found = True
            # The zero-force time moves by dF / |dF/dt| with dF = |C| dw + |dF/dq| dq for
            # state errors (dq, dw): heavily damped, |C| / |dF/dt| is large (a constant
            # dashpot 50 on Hertz: 1.5 times the step-error bound). Damping makes the state
            # forget old errors at rate C/m, so the recent local errors (mq, mw, halved per
            # step) stand for (dq, dw); the caller adds this in seconds.
            Fz, dFz, dUz, _u = forces(ra, rb, ks, ps, cs, es, sc)
            if rb != 0.0 and dFz != 0.0:
                Cz = (Fz - dUz) / rb
                Fqz = (dFz + Cz * Fz / m) / rb
                out[14] = (abs(Cz) * max(mw, ew) + abs(Fqz) * max(mq, eq)) / abs(dFz)
        errsum += err
        errsum_t += err
        if mode2 == 0:
            srel += err
        mq, mw = max(eq, 0.5 * mq), max(ew, 0.5 * mw)
        t, q, w, b2 = t + h, nq, nw, nb2
        F, dF, Uq = nF, ndF, nUq
        h *= min(4.0, 0.9 * (TOL / max(err, 1e-300)) ** (1.0 / (2 * KCOL - 3)))
        if past_peak and w < 0.0:
            if q <= Q_OUT_FRAC * q_max and nUq <= 0.5 * m * w * w:
                exit_now = True
                break
            if q <= _NO_RETURN_Q * q_max:
                out[13] = STOP_NO_RETURN_Q
                break
            # Creeping on the slow manifold w ~ -U'/C (inertia negligible: the drag stops the
            # body within m |w| / C << q, and U' q > m w^2), where the time to reach q = 0,
            # int C / U' dq, diverges when C ~ q^a with a <= n - 2, and inertia stays
            # negligible down to q = 0 when a < (n-2)/2 or a = (n-2)/2 at damping ratio >= 1
            # (sc[4] = 1, set by the caller): no return. (Hertz with a constant dashpot, a
            # linear dashpot when overdamped, the universal law for zeta >= 1.) Integrating
            # on would be stiff (rate C / m).
            Cq = (nF - ndU) / w * q
            if sc[4] == 1.0 and zf_found and q <= Q_OUT_FRAC * q_max:
                if nUq > m * w * w and Cq > _CREEP_RATIO * m * abs(w):
                    out[13] = STOP_CREEP
                    break
            # the next step must not jump past q = 0 (and be refused as NaN forever), nor
            # end so near it that its error estimate no longer holds (`_EXIT_REACH`)
            h = min(h, _EXIT_REACH * q / abs(w))
    if mode2 == 2:
        # In time, a position error dq moves the return by dq / |w| (|w| ~ 1/alpha on the
        # return, v0 / (alpha v0)), and a speed error dw the peak by dw m / U'(q_max)
        # (up to alpha t_E): the sums of the local errors count at those rates, not at
        # q_E / v0 (measured 1.2e-11 relative at alpha v0 = 1e6 against 1e-12 so counted).
        if out[2] > 0.0:
            errsum_t += (sq / abs(w) + sw * m / out[2]) / tE
    out[6] = np.nan
    if not exit_now:
        out[8] = 0.0
        out[6] = np.inf
        out[7] = 0.0
        if not zf_found:
            out[4] = np.inf
            out[5] = 0.0
        out[9] = errsum_t
        out[10] = errsum
        out[11] = nsteps
        out[12] = 0.0
        out[3] = peak
        return out
    # ---- phase 3: exit in sigma from 1 to 0, (w, t) --------------------------
    qs = q
    s, a, b = 1.0, w, t
    h = -0.25
    t3, tail_q = t, q / abs(w)  # where the exit starts, and its time scale q / |w|
    while s > 0.0:
        nsteps += 1
        if nsteps > MAX_STEPS:
            out[12] = 1.0
            return out
        hs = max(h, -s)
        na, nb, ea, eb = gbs(1, qs, s, a, b, hs, ks, ps, cs, es, sc, Ta, Tb)
        # w relative to itself: the exit's duration ~ q_s / |w| carries w's relative error
        err = max(ea / min(v0, abs(a)), eb / tE)
        if not (err <= TOL) or not (na < 0.0):
            if err == err and na < 0.0:
                h = hs * max(0.2, 0.9 * (TOL / err) ** (1.0 / (2 * KCOL - 3)))
            else:
                h = hs * 0.25
            continue
        qn = qs * (s + hs) ** KSUB
        nF, ndF, ndU, nUq = forces(qn, na, ks, ps, cs, es, sc)
        if dF > 0 and ndF < 0:
            tau, ra, rb = locate(2, 1, qs, s, a, b, hs, dF, ndF, na, nb, ks, ps, cs, es, sc, Ta, Tb)
            Fp, _, _, _ = forces(qs * (s + tau) ** KSUB, ra, ks, ps, cs, es, sc)
            peak = max(peak, Fp)
        if not zf_found and sc[6] == 0.0 and F > 0 and nF < 0:
            tau, ra, rb = locate(1, 1, qs, s, a, b, hs, F, nF, na, nb, ks, ps, cs, es, sc, Ta, Tb)
            out[4] = rb
            out[5] = ra
            zf_found = True
        if not zf_found and F > 0 and s + hs == 0.0 and sc[5] == 1.0:
            # C q' outweighs U' as q -> 0 (sc[5]): the force pulls in the last instants
            # before q = 0, where F(0) = 0 hides the crossing from the step ends (weak
            # damping: measured 7.6e-13 s before the exit at zeta = 1e-14). Find a
            # sigma with F < 0 by halving towards 0, then locate the root as usual.
            sig = s
            for _ in range(200):
                sig *= 0.5
                ta, tb, _e1, _e2 = gbs(1, qs, s, a, b, sig - s, ks, ps, cs, es, sc, Ta, Tb)
                qt = qs * sig**KSUB
                if not qt > 0.0:
                    break
                Ft, _d, _u, _uq = forces(qt, ta, ks, ps, cs, es, sc)
                if Ft < 0.0:
                    tau, ra, rb = locate(
                        1, 1, qs, s, a, b, sig - s, F, Ft, ta, tb, ks, ps, cs, es, sc, Ta, Tb
                    )
                    out[4] = rb
                    out[5] = ra
                    zf_found = True
                    break
        errsum += err
        errsum_t += err
        srel += err
        s, a, b = s + hs, na, nb
        F, dF = nF, ndF
        h = hs * min(4.0, 0.9 * (TOL / max(err, 1e-300)) ** (1.0 / (2 * KCOL - 3)))
        # The drag can still catch the body after the exit began (a constant dashpot on
        # U' ~ q^3: it then crept in sigma until the step budget ran out): the creep test
        # of phase 2, where the creep never ends (sc[4] = 1), stops it here too.
        if sc[4] == 1.0 and zf_found and na < 0.0:
            if nUq > m * na * na and (nF - ndU) / na * qn > _CREEP_RATIO * m * abs(na):
                out[8] = 0.0
                out[6] = np.inf
                out[7] = 0.0
                out[9] = errsum_t
                out[10] = errsum
                out[11] = nsteps
                out[12] = 0.0
                out[3] = peak
                out[13] = STOP_CREEP
                return out
    if not zf_found:  # the force never pulls: the two ends coincide
        out[4] = b
        out[5] = a
    # A state error relative to the state (the sum srel of the relative local errors,
    # which the damped flow carries along as it decays, as the absolute ones in errsum)
    # reaches the exit start as (dq/q, dw/|w|) and moves the end by dq/|w| + T3 dw/|w|,
    # T3 the exit's duration: on a near-critical return q / |w| and T3 are many t_E
    # (285 t_E in all at zeta = 0.99 on Hertz), where errsum_t alone, in t_E, fell short.
    errsum_t += srel * (tail_q + (b - t3)) / tE
    out[3] = peak
    out[6] = b
    out[7] = a
    out[8] = 1.0
    out[9] = errsum_t
    out[10] = errsum
    out[11] = nsteps
    out[12] = 0.0
    out[13] = 0.0
    return out


_ALGORITHM = ("state", "deriv", "gbs", "forces", "event_g", "event_dg", "locate", "solve")


def python_solver(fc_py):
    """The same algorithm in plain Python around another force function (any family).

    Each compiled function's Python source is re-bound to a namespace in which ``fc``
    is ``fc_py`` (one algorithm, two evaluators; the compiled one is cached on disk).
    """
    ns = dict(globals())
    ns["fc"] = fc_py
    for name in _ALGORITHM:
        f = globals()[name].py_func
        ns[name] = types.FunctionType(f.__code__, ns, name, f.__defaults__, f.__closure__)
    return ns["solve"]
