"""One step of the Taylor kernel after its series: events, scans, the exit (issue 38, goal 5).

Split from `reference_impl.exact._general_taylor.integrate` so that one impact's stepping
can run in two ways with the same float operations: one impact at a time
(`_general_taylor.integrate`), or several side by side, their series computed together
(`_taylor_lanes`, the batch of `solve_impacts`). The stepping keeps what it carries from
step to step in a small float array (`ST_*`: the step's start, the peak so far, the
phase, the summed estimates), the same numbers the locals of `integrate` held, so every
result is bit for bit what it was.

`before` is the head of a step (the step budget, the creeping-return test), `after` the
rest once the step's series (R, W, T) are known: the step size, the turning point, the
exit, the peak-force and zero-force scans. Each returns `GO_ON`, 0 (``out`` complete) or 1
(hand the impact to the GBS kernel: ``out`` void). The method, its constants and their
measurements are in `_general_taylor`'s docstring.
"""

from __future__ import annotations

import math

import numba

from reference_impl.exact._general_kernel import STOP_CREEP
from reference_impl.exact._taylor_force import dforce as _dforce
from reference_impl.exact._taylor_force import event as _event
from reference_impl.exact._taylor_force import fc as _fc
from reference_impl.exact._taylor_force import force as _force
from reference_impl.exact._taylor_force import root as _root
from reference_impl.exact._taylor_force import zero_force_root as _zf_root
from reference_impl.exact._taylor_poly import NS
from reference_impl.exact._taylor_poly import horner as _horner
from reference_impl.exact._taylor_poly import horner3 as _horner3
from reference_impl.exact._taylor_poly import inv_radius as _inv_radius
from reference_impl.exact._taylor_poly import samples as _samples
from reference_impl.exact._taylor_scan import force_stays_positive as _force_stays_positive

__all__ = [
    "GO_ON",
    "MAX_STEPS",
    "NPK",
    "PK_L",
    "NST",
    "ST_R",
    "ST_T",
    "ST_W",
    "after",
    "before",
    "constants",
    "start",
]

# A contact takes 8-14 steps (measured: calibrated Hertz laws 9-10, the universal law on
# Hertz 13). More steps mean a slow, creeping return (near-critical or overdamped), where
# an error in rho is integrated into T over a long stretch of s and the summed local
# estimates no longer bound it (measured: 5e-14 s against a bound of 4e-15 s after 39
# steps, near-critical linear dashpot on Hooke + Hertz): handed to the GBS kernel.
MAX_STEPS = 24
# A cap's creeping return (no return: `_taylor_cap`), after its zero-force end: steps
# until the no-return test, which only confirms that verdict (the outputs are all set by
# then; the bound sums every step). Measured on sphere-damped with a dashpot 26.75 N s/m:
# 21 steps at 1 m/s, 47 at 0.3, 125 at 0.1 (the GBS kernel: 130 and 303 at the first two).
_CREEP_STEPS = 400
# Overlap (fraction of q_max) at which a return is handed over (the GBS kernel's
# threshold of no return): rho decays without crossing 0 there, and a root found at
# round-off level would be no exit.
_NO_RETURN_Q = 1e-10
# Event brackets, relative: two ulps where the output moves with the root (the time of
# q_max, the zero-force end); 1e-9 where it is stationary there, so that a location error
# d moves it by ~d^2 (the peak force at dF/ds = 0; T and W at the exit rho = 0 for N > 1,
# where dT/ds = N rho^(N-1) and dW/ds = -N rho^(N-1) G vanish): 1e-18 of the step.
_ULPS = 4.5e-16
_STATIONARY = 1e-9
# What a step says: go on to the next step (0 and 1 as `integrate` returns them).
GO_ON = -1
# The stepping's carried numbers (a float array of NST): the step's start rho, W, T; the
# peak force so far; past the turning point (0/1); zero-force end found (0/1); the summed
# truncation estimates, and their value at the zero-force end; the step count; q at the top.
ST_R, ST_W, ST_T, _PEAK, _PAST, _ZF, _ERRSUM, _ERR_ZF, _STEP, _QTOP = range(10)
NST = 10
# An impact's constants (a float array of NPK, `constants`): its speed v0 (m/s), scale L
# (m), force unit m v0^2 / L (N), truncation per step and its theta, the exit's bracket,
# and three flags (0/1): f and c grow with rho, the law never pulls, it may creep.
_V0, _L, _FS, _TOL, _THETA, _EXIT_TOL, _MONO, _NOPULL, _CREEPS = range(9)
NPK = 9
PK_L = _L


@numba.njit(cache=True, error_model="numpy", inline="always")
def constants(pk, v0, L, N, F, C, CY, cp, D, sc, tol, theta):
    """``pk`` = the impact's constants (`NPK`; ``sc`` the law's scalars, ``tol`` and
    ``theta`` the truncation per step and its fraction of the radius)."""
    pk[_V0] = v0
    pk[_L] = L
    pk[_FS] = sc[0] * v0 * v0 / L  # force unit
    pk[_TOL] = tol
    pk[_THETA] = theta
    pk[_EXIT_TOL] = _STATIONARY if N > 1 else _ULPS
    pk[_MONO] = 1.0 if _monotone(F, C, CY, cp, D) else 0.0
    pk[_NOPULL] = 1.0 if sc[6] == 1.0 else 0.0
    pk[_CREEPS] = 1.0 if sc[4] == 1.0 else 0.0


@numba.njit(cache=True, error_model="numpy", inline="always")
def start(st, peak):
    """The carried numbers at the onset: rho 0, W 1, T 0, the force just after contact."""
    st[ST_R], st[ST_W], st[ST_T] = 0.0, 1.0, 0.0
    st[_PEAK] = peak
    st[_PAST] = 0.0
    st[_ZF] = 0.0
    st[_ERRSUM] = 0.0
    st[_ERR_ZF] = 0.0
    st[_STEP] = 0.0
    st[_QTOP] = 1.0


@numba.njit(cache=True, error_model="numpy", inline="always")
def before(st, pk, N, F, C, CY, cp, D, out):
    """The head of a step: counts it; returns 1 past the step budget or on a creeping
    return handed over, 0 on a cap's no-return (``out`` complete), else `GO_ON`."""
    capped = cp is not None
    creeps = pk[_CREEPS] == 1.0
    st[_STEP] += 1.0
    step = int(st[_STEP])
    zf_found = st[_ZF] == 1.0
    # A cap's creeping return, its zero-force end found, may take up to _CREEP_STEPS to
    # reach the no-return test (stiff: the step is limited by m / C); an exit after
    # MAX_STEPS is handed over (its bound is not the summed estimates: MAX_STEPS)
    if step > MAX_STEPS and not (capped and creeps and zf_found and step <= _CREEP_STEPS):
        return 1
    if st[_PAST] == 1.0 and creeps:
        # Creeping back along the slow manifold of an overdamped law (w ~ -U'/C, U' q >
        # m w^2, C q > 100 m |w|, as in the GBS kernel), where C ~ q^a with a <= n - 2
        # never lets it reach q = 0: rho only decays, and a root found at round-off
        # level would be no exit. The GBS kernel reports these cases (no return).
        r0, w0, q_top = st[ST_R], st[ST_W], st[_QTOP]
        q0 = r0**N
        if q0 <= _NO_RETURN_Q * q_top:
            return 1
        if q0 <= 0.1 * q_top:
            f0, c0 = _fc(F, C, CY, cp, N, D, r0)
            if f0 * q0 > w0 * w0 and c0 * q0 > 100.0 * abs(w0):
                if capped and zf_found:
                    # A cap reports the no-return itself, as the GBS kernel does
                    # (STOP_CREEP: the same test, its zero-force end already found);
                    # the sums of powers hand it over, as before (bit for bit).
                    out[3] = st[_PEAK] * pk[_FS]
                    out[6] = math.inf
                    out[7] = 0.0
                    out[8] = 0.0
                    # the bound of the outputs, all set by the zero-force end: the
                    # steps after it only confirm the verdict
                    out[9] = st[_ERR_ZF]
                    out[10] = st[_ERR_ZF]
                    out[11] = step - 1
                    out[12] = 0.0
                    out[13] = STOP_CREEP
                    return 0
                return 1
    return GO_ON


@numba.njit(cache=True, error_model="numpy", inline="always")
def after(st, pk, R, W, T, pw, xs, rs, wsm, N, F, C, CY, cp, j0, D, CN, FN, CYN, out):
    """The rest of a step, its series R, W, T known: the step size from their radius, the
    turning point, the exit, the peak-force and zero-force scans; returns 1 where the
    radius is not finite (hand over), 0 at the exit (``out`` complete), else `GO_ON` with
    the next step's start in ``st``.

    ``work`` holds four rows of at least NS + 1 (K + 1 for the first): the radius'
    powers, the samples' points, their rho and W."""
    v0, L, Fs = pk[_V0], pk[_L], pk[_FS]
    tol, theta, exit_tol = pk[_TOL], pk[_THETA], pk[_EXIT_TOL]
    monotone = pk[_MONO] == 1.0
    nopull = pk[_NOPULL] == 1.0
    capped = cp is not None
    r0, w0, t0 = st[ST_R], st[ST_W], st[ST_T]
    peak = st[_PEAK]
    past = st[_PAST] == 1.0
    zf_found = st[_ZF] == 1.0
    step = int(st[_STEP])
    inv = _inv_radius(R, W, T, pw)
    if not (inv > 0.0 and inv < math.inf):
        return 1
    h = theta / inv
    rh, wh, th = _horner3(R, W, T, h)  # the step's end, read by the tests below
    st[_ERRSUM] += tol * max(1.0, abs(t0))
    errsum = st[_ERRSUM]
    x_end = h
    x_from = 0.0
    exiting = False
    was_past = past
    rm = 0.0
    if not past and wh < 0.0:
        x = _root(1, R, W, F, C, CY, cp, N, j0, D, 0.0, h, W[0], wh, _ULPS)
        rm, _, tm = _horner3(R, W, T, x)
        out[0] = tm * L / v0
        out[1] = L * rm**N
        # F at the turning point is U'(q_max): a value of F, so the peak is at least that
        # (where C(q_max) = 0 it is the peak, at a stationary point on the step's edge)
        peak = max(peak, _fc(F, C, CY, cp, N, D, rm)[0])
        past = True
        st[_PAST] = 1.0
        st[_QTOP] = rm**N
        x_from = x
    if past and rh <= 0.0:
        x_end = _root(0, R, W, F, C, CY, cp, N, j0, D, x_from, h, _horner(R, x_from), rh, exit_tol)
        exiting = True
    # peak force: dG/ds through 0 from above, on NS samples of [0, x_end], unless
    # G cannot exceed the peak so far on this step (f and c grow with rho >= 0):
    # before the turning point G <= f(rho_hi) + c(rho_hi) w0, after it G <= f(r0).
    if was_past:
        ub = _fc(F, C, CY, cp, N, D, r0)[0]
    else:
        r_hi = rm if past else rh  # x_end = h before the turning point
        f_hi, c_hi = _fc(F, C, CY, cp, N, D, r_hi)
        ub = f_hi + c_hi * w0
    scan_peak = not (monotone and ub <= peak)
    # no zero-force end where the law says the force never vanishes before q = 0
    # (Hunt-Crossley, sc[6], as the GBS kernel): its scan was ~1/6 of such an impact;
    # nor on a step where the force provably stays positive (nothing to find there)
    scan_zf = past and not zf_found and not nopull
    # (its interval bound reads F and C alone: a cap's step is always scanned)
    scan_zf = scan_zf and (capped or not _force_stays_positive(F, C, j0, D, R, W, x_end))
    if scan_peak or scan_zf:
        _samples(R, W, x_end, xs, rs, wsm)
    if scan_peak:  # dG/ds through 0 from above
        gp = _dforce(F, C, CY, cp, N, D, rs[0], wsm[0])
        for i in range(1, NS + 1):
            gi = _dforce(F, C, CY, cp, N, D, rs[i], wsm[i])
            if gp > 0.0 and gi <= 0.0:
                xr = _root(3, R, W, F, C, CY, cp, N, j0, D, xs[i - 1], xs[i], gp, gi, _STATIONARY)
                rx, wx = _horner(R, xr), _horner(W, xr)
                peak = max(peak, _force(F, C, CY, cp, N, j0, D, rx, wx)[0])
            gp = gi
    st[_PEAK] = peak
    if scan_zf:  # zero-force end: G / rho^j0 through 0 after the turning point
        gp = _event(2, R, W, F, C, CY, cp, N, j0, D, x_from)
        xp = x_from
        for i in range(1, NS + 1):
            if xs[i] <= x_from:
                continue
            gi = _force(F, C, CY, cp, N, j0, D, rs[i], wsm[i])[1]
            if exiting and i == NS and gi > 0.0:
                # The last sample is the exit, rho = 0 within its root's bracket (found:
                # rho = -5.6e-17). Where a negligible lowest term sets j0 (C = c0 + c1 q,
                # c0 = 1.3e-36 kg/s: C[0] W ~ 3e-39), that round-off times the next term
                # (~1e-18) outweighs it and reads the force at the exit > 0, hiding the
                # crossing before it: the sign is read at rho = 0 exactly, the exit, where
                # G / rho^j0 = F[j0] + C[j0] W. A sample read <= 0 is kept (bit for bit).
                gi = _force(F, C, CY, cp, N, j0, D, 0.0, wsm[i])[1]
            if gp > 0.0 and gi <= 0.0:
                ends = exiting and i == NS  # the bracket ends at the exit
                xr = _zf_root(R, W, F, C, CY, cp, N, j0, D, xp, xs[i], gp, gi, _ULPS, ends)
                out[4] = _horner(T, xr) * L / v0
                out[5] = _horner(W, xr) * v0
                st[_ZF] = 1.0
                zf_found = True
                st[_ERR_ZF] = errsum
                break
            gp, xp = gi, xs[i]
    if exiting:
        if step > MAX_STEPS:
            return 1
        t_end = _horner(T, x_end) * L / v0
        we = _horner(W, x_end)
        w_end = we * v0
        err_t = errsum
        err_w = errsum
        if N == 1:
            # dT/ds = 1 at the exit: an error e in rho moves it by e / |W| in s, so T by
            # as much and W by |dW/ds| e / |W| (for N > 1 both are stationary there)
            err_t += errsum / abs(we)
            dw = CN[0] * we + FN[0]
            if capped:  # y = 1 at rho = 0
                dw += CYN[0] * we
            err_w += abs(dw) * errsum / abs(we)
        if not zf_found:  # the force never pulls: the two ends coincide
            out[4] = t_end
            out[5] = w_end
        out[3] = peak * Fs
        out[6] = t_end
        out[7] = w_end
        out[8] = 1.0
        out[9] = err_t  # scaled; the caller's * L / qE: units of qE / v0, as the GBS kernel's
        out[10] = err_w
        out[11] = step
        out[12] = 0.0
        return 0
    st[ST_R], st[ST_W], st[ST_T] = rh, wh, th
    return GO_ON


@numba.njit(cache=True, error_model="numpy")
def _monotone(F, C, CY, cp, D):
    """f and c non-decreasing in rho >= 0 (every coefficient >= 0), where the peak-force
    scan can be skipped on a bound (a cap: see below)."""
    capped = cp is not None
    monotone = True
    for j in range(D + 1):
        if F[j] < 0.0 or C[j] < 0.0 or (CY[j] < 0.0 and not capped):
            monotone = False
    if cp is not None and cp[0] <= 1.0 / 3.0:
        # A cap's F has a negative coefficient, but f = U' grows with q up to q = a (V and
        # S = V' do), and the contact stays below q = L, i.e. rho <= 1, within q = a where
        # beta = L / (3a) <= 1/3 (`_taylor_cap`): monotone there where C's coefficients
        # are >= 0 (CY = alpha_HC F y grows as f does). Deeper, the peak is always scanned.
        monotone = True
        for j in range(D + 1):
            if C[j] < 0.0:
                monotone = False
    return monotone
