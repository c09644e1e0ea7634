"""The stepping core of the compiled DOP853 peers: one integrator, any right-hand side (issue 38).

The explicit Dormand-Prince 8(5,3) pair with its 7th-order dense output (Hairer,
Norsett & Wanner, *Solving ODEs I*, section II.10; the published tableau, read from
scipy's `scipy.integrate._ivp.dop853_coefficients`, whose values are those of Hairer's
dop853.f; the integrator is ours), Hairer's error norm, initial step and step control,
and four events located on the dense output of the step that crosses them (Illinois
iteration to a few ulps of the step). `integrate` runs one impact of a *model*: the
right-hand side and the event functions are numba functions passed as arguments, so
that numba compiles (and caches) one specialised kernel per model, with direct calls
and no Python per step. The models are `benchmarks.peer_dop853` (the plain equations
of motion in (q, q'), and the same with q^1.5 written q sqrt(q)) and
`benchmarks.peer_sundman` (the Sundman-regularised equations in (rho, W, T)).

A model is five compiled functions of the state ``y`` (an array of ``n`` components,
``y[0]`` the overlap-like coordinate whose fall through 0 ends the contact, ``y[1]``
the speed-like one whose fall through 0 is q_max) and a tuple ``P`` of its parameters:

* ``rhs(y, P, dy)``: writes dy/ds (s the independent variable: t, or the Sundman s);
* ``events(y, P, g)``: writes the four event functions g[0..3] (see `event`);
* ``event(kind, y, P)``: one of them: 0 the overlap, 1 the speed, 2 the total force
  over U' (the zero-force end), 3 a function with the sign of dF/dt (the peak force),
  or -1 where the model does not seek the peak (the universal law's rows);
* ``observe(s, y, P)``: (t [s], q [m], q' [m/s], F [N], U'(q) [N]) at the state y;
* ``onset(y, P)``: (F [N], event 3) just after contact onset (q = 0+).

The plain peer's arithmetic is the one of the former single-model kernel, operation for
operation (its outputs are bit for bit those before the refactoring; measured on 112
impacts, rungs 1e-6 to 1e-16).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _tab

__all__ = ["OUT_FIELDS", "integrate"]

_C = np.ascontiguousarray(_tab.C, dtype=float)  # 16 nodes (12 stages + 4 of dense output)
_A = np.ascontiguousarray(_tab.A, dtype=float)  # 16 x 16
_B = np.ascontiguousarray(_tab.B, dtype=float)  # 12 weights of the 8th-order solution
_E3 = np.ascontiguousarray(_tab.E3, dtype=float)  # 13: 3rd-order error estimator
_E5 = np.ascontiguousarray(_tab.E5, dtype=float)  # 13: 5th-order error estimator
_D = np.ascontiguousarray(_tab.D, dtype=float)  # 4 x 16: dense-output coefficients
_NS = 12  # stages of a step
_NX = 16  # with the dense output's extra stages
# Step-size control of Hairer's code: safety factor and bounds on the change per step.
_SAFETY, _FAC_MIN, _FAC_MAX = 0.9, 0.2, 10.0
# Illinois iterations on the dense output: each halves the bracket at least every other
# step; 200 is far beyond the 2 x 52 a float bracket can need.
_ROOT_ITER = 200
_MAX_STEPS = 100_000

# Output fields of `integrate` (out[i]), physical units (s, m/s, m, N).
OUT_FIELDS = (
    "contact_time",
    "v_end",
    "contact_time_zero_force",
    "v_zero_force",
    "max_penetration",
    "max_force",  # U'(q_max)
    "peak_force",
    "nfev",
    "status",  # 0 ok, 1 no end within s_bound or _MAX_STEPS, 2 step size underflow
)


@numba.njit(cache=True, error_model="numpy")
def _dense(F, y0, x, y):  # pragma: no cover - compiled
    """The 7th-degree dense output at fraction x of the step (Hairer's contd8), into y."""
    for c in range(y0.shape[0]):
        acc = 0.0
        for i in range(6, -1, -1):
            acc += F[i, c]
            if (6 - i) % 2 == 0:
                acc *= x
            else:
                acc *= 1.0 - x
        y[c] = y0[c] + acc


@numba.njit(cache=True, error_model="numpy")
def _locate(event, kind, g_lo, g_hi, x_hi, F, y0, P, y):  # pragma: no cover - compiled
    """Fraction x in (0, x_hi] of the step where event ``kind`` falls through 0 (Illinois)."""
    a, b, ga, gb = 0.0, x_hi, g_lo, g_hi
    side = 0
    for _ in range(_ROOT_ITER):
        x = (a * gb - b * ga) / (gb - ga)
        if not (a < x < b):
            x = 0.5 * (a + b)
        _dense(F, y0, x, y)
        g = event(kind, y, P)
        if g > 0.0:
            a, ga = x, g
            if side == 1:
                gb *= 0.5
            side = 1
        else:
            b, gb = x, g
            if side == -1:
                ga *= 0.5
            side = -1
        if b - a <= 4e-16 * b or g == 0.0:
            return b if g <= 0.0 else x
    return b


@numba.njit(cache=True, error_model="numpy")
def _stage(rhs, K, s, y, h, P, ys):  # pragma: no cover - compiled
    """Stage s: K[s] = rhs(y + h sum_j A[s, j] K[j])."""
    for c in range(y.shape[0]):
        d = 0.0
        for j in range(s):
            a = _A[s, j]
            if a != 0.0:
                d += a * K[j, c]
        ys[c] = y[c] + h * d
    rhs(ys, P, K[s])


@numba.njit(cache=True, error_model="numpy")
def _norm(u, sc):  # pragma: no cover - compiled
    """sum_c (u[c] / sc[c])^2."""
    acc = 0.0
    for c in range(u.shape[0]):
        acc += (u[c] / sc[c]) ** 2
    return acc


@numba.njit(cache=True, error_model="numpy")
def _first_step(rhs, y, f, P, rtol, atol, ys, g):  # pragma: no cover - compiled
    """Hairer's initial step for order 8 (hinit); returns (h, evaluations)."""
    n = y.shape[0]
    sc = np.empty(n)
    for c in range(n):
        sc[c] = atol[c] + abs(y[c]) * rtol
    d0 = math.sqrt(_norm(y, sc) / n)
    d1 = math.sqrt(_norm(f, sc) / n)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    for c in range(n):
        ys[c] = y[c] + h0 * f[c]
    rhs(ys, P, g)
    for c in range(n):
        g[c] -= f[c]
    d2 = math.sqrt(_norm(g, sc) / n) / h0
    big = max(d1, d2)
    h1 = max(1e-6, h0 * 1e-3) if big <= 1e-15 else (0.01 / big) ** (1.0 / 8.0)
    return min(100.0 * h0, h1), 1


@numba.njit(cache=True, error_model="numpy")
def _dense_coefficients(rhs, K, y, yn, h, P, ys, F):  # pragma: no cover - compiled
    """Three more stages, then the coefficients F (7 x n) of contd8."""
    for s in range(_NS + 1, _NX):
        _stage(rhs, K, s, y, h, P, ys)
    for c in range(y.shape[0]):
        F[0, c] = yn[c] - y[c]
        F[1, c] = h * K[0, c] - F[0, c]
        F[2, c] = 2.0 * F[0, c] - h * (K[_NS, c] + K[0, c])
        for r in range(4):
            acc = 0.0
            for j in range(_NX):
                acc += _D[r, j] * K[j, c]
            F[3 + r, c] = h * acc
    return _NX - _NS - 1


@numba.njit(cache=True, error_model="numpy")
def _error(K, y, yn, h, rtol, atol, sc, e5, e3):  # pragma: no cover - compiled
    """Hairer's dop853 error norm (5th- and 3rd-order estimators) of the step."""
    n = y.shape[0]
    for c in range(n):
        sc[c] = atol[c] + max(abs(y[c]), abs(yn[c])) * rtol
        a5 = 0.0
        a3 = 0.0
        for j in range(_NS + 1):
            a5 += _E5[j] * K[j, c]
            a3 += _E3[j] * K[j, c]
        e5[c], e3[c] = a5, a3
    n5 = _norm(e5, sc)
    den = n5 + 0.01 * _norm(e3, sc)
    return 0.0 if den == 0.0 else abs(h) * n5 / math.sqrt(float(n) * den)


@numba.njit(cache=True, error_model="numpy")
def integrate(
    rhs, events, event, observe, onset, y0, P, rtol, atol, s_bound, h_first, out
):  # pragma: no cover - compiled
    """One impact of a model from ``y0`` until y[0] falls back through 0.

    Parameters
    ----------
    rhs, events, event, observe, onset : numba functions
        The model (see the module docstring).
    y0 : ndarray, shape (n,)
        The state at contact onset (units of the model).
    P : tuple
        The model's parameters, passed to its functions.
    rtol : float
        Relative tolerance (-).
    atol : ndarray, shape (n,)
        Absolute tolerance of each component (units of the model).
    s_bound : float
        Largest independent variable; no end before it gives status 1.
    h_first : float
        First step; <= 0 selects it by Hairer's rule.
    out : ndarray, shape (len(OUT_FIELDS),)
        Receives `OUT_FIELDS` (physical units); returned.
    """
    n = y0.shape[0]
    K = np.empty((_NX, n))
    F = np.empty((7, n))
    y = y0.copy()
    yn = np.empty(n)
    ys = np.empty(n)
    yd = np.empty(n)
    sc = np.empty(n)
    e5 = np.empty(n)
    e3 = np.empty(n)
    s = 0.0
    rhs(y, P, K[0])
    nfev = 1
    if h_first > 0.0:
        h = h_first
    else:
        h, extra = _first_step(rhs, y, K[0], P, rtol, atol, ys, K[1])
        nfev += extra
    for i in range(7):
        out[i] = np.nan
    # The force just after onset (a dashpot's c v0, 0 for the universal law): the peak
    # when the force only falls, and the start of the event functions.
    f_old, g3_old = onset(y, P)
    out[6] = f_old
    # F / U' at onset: +inf (the force pushes from the start for every law here).
    g_old = np.array([y[0], y[1], np.inf, g3_old])
    g_new = np.empty(4)
    found_zf = False
    found_qmax = False
    rejected = False
    status = 1.0
    for _ in range(_MAX_STEPS):
        if s + h > s_bound:
            h = s_bound - s
        if h <= 4e-16 * max(s, 1e-300):
            status = 2.0
            break
        for st in range(1, _NS):
            _stage(rhs, K, st, y, h, P, ys)
        nfev += _NS - 1
        for c in range(n):
            acc = 0.0
            for j in range(_NS):
                acc += _B[j] * K[j, c]
            yn[c] = y[c] + h * acc
        rhs(yn, P, K[_NS])
        nfev += 1
        err = _error(K, y, yn, h, rtol, atol, sc, e5, e3)
        if err > 1.0:
            h *= max(_FAC_MIN, _SAFETY * err ** (-1.0 / 8.0))
            rejected = True
            continue
        fac = _FAC_MAX if err == 0.0 else min(_FAC_MAX, _SAFETY * err ** (-1.0 / 8.0))
        if rejected:
            fac = min(1.0, fac)
        rejected = False
        # Accepted: events on this step.
        events(yn, P, g_new)
        hit = False
        for kind in range(4):
            if g_old[kind] > 0.0 and g_new[kind] <= 0.0:
                if kind == 1 and found_qmax:
                    continue
                if kind == 2 and found_zf:
                    continue
                hit = True
        if hit:
            nfev += _dense_coefficients(rhs, K, y, yn, h, P, ys, F)
            x_hi = 1.0
            x_end = 1.0
            if g_new[0] <= 0.0:
                # The contact ends in this step: the other events are read up to just
                # before its end, where F / U' and dF/dt are still defined (an event
                # within 1e-8 of a step of the end counts as the end).
                x_end = _locate(event, 0, g_old[0], g_new[0], 1.0, F, y, P, yd)
                x_hi = x_end * (1.0 - 1e-8)
                _dense(F, y, x_hi, yd)
                if yd[0] > 0.0:
                    for kind in range(1, 4):
                        g_new[kind] = event(kind, yd, P)
                else:
                    g_new[1], g_new[2], g_new[3] = yd[1], 1.0, 1.0
            if g_old[1] > 0.0 and g_new[1] <= 0.0 and not found_qmax:
                x = _locate(event, 1, g_old[1], g_new[1], x_hi, F, y, P, yd)
                _dense(F, y, x, yd)
                _t, qm, _v, _f, du = observe(s + x * h, yd, P)
                out[4], out[5] = qm, du
                found_qmax = True
            if g_old[3] > 0.0 and g_new[3] <= 0.0:
                x = _locate(event, 3, g_old[3], g_new[3], x_hi, F, y, P, yd)
                _dense(F, y, x, yd)
                out[6] = max(out[6], observe(s + x * h, yd, P)[3])
            if g_old[2] > 0.0 and g_new[2] <= 0.0 and not found_zf:
                x = _locate(event, 2, g_old[2], g_new[2], x_hi, F, y, P, yd)
                _dense(F, y, x, yd)
                tz, _q, vz, _f, _du = observe(s + x * h, yd, P)
                out[2], out[3] = tz, vz
                found_zf = True
            if g_new[0] <= 0.0:
                _dense(F, y, x_end, yd)
                te, _q, ve, _f, _du = observe(s + x_end * h, yd, P)
                out[0], out[1] = te, ve
                if not found_zf:  # the force never pulled: the two ends coincide
                    out[2], out[3] = out[0], out[1]
                status = 0.0
                break
        s += h
        for c in range(n):
            y[c] = yn[c]
            K[0, c] = K[_NS, c]
        for kind in range(4):
            g_old[kind] = g_new[kind]
        if s >= s_bound:
            break
        h *= fac
    out[7] = nfev
    out[8] = status
    return out
