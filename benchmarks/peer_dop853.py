"""A compiled DOP853 peer for the exact solvers (issue 27, goal 1): numba, no Python per step.

What a user could pick instead of the harmonic map, written here: the explicit
Dormand-Prince 8(5,3) pair with its 7th-order dense output (Hairer, Norsett &
Wanner, *Solving ODEs I*, section II.10; the published tableau, read from scipy's
`scipy.integrate._ivp.dop853_coefficients`, whose values are those of Hairer's
dop853.f; the integrator below is ours), the same error norm and step control as
Hairer's code, and events located on the dense output of the step that crosses
them (Illinois iteration to a few ulps of the step). One call solves one impact
in compiled code and returns every output the exact solvers report:

* the overlap end (q back to 0: time and restitution; the integration stops there),
* the zero-force end (U' + C q' falls through 0: time and restitution),
* q_max (q' falls through 0) and U'(q_max),
* the peak total force max_t (U' + C q') (dF/dt falls through 0, and F at contact onset),
  for the laws of the damping table (the universal law's rows report U'(q_max), as
  `solve_impact` does).

The model is two small tables, so that one compiled kernel serves every row of the
benchmark: elastic terms (a power term U' += a q^b, or a volumetric cap
U = Kn/(alpha+1) w^(alpha+1), w = c0 (a q^2 - q^3/3)), and damping terms
C += c q^e, plus the universal law C = 2 zeta sqrt(m) U' / sqrt(2 U) (K = M = m).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _tab

__all__ = ["OUT_FIELDS", "damping_table", "elastic_table", "solve_dop853"]

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
# Overlap at which the onset force is read (the limit q -> 0+ of every table term).
_Q_ONSET = 1e-300

# Output fields of `solve_dop853` (out[i]).
OUT_FIELDS = (
    "contact_time",
    "v_end",
    "contact_time_zero_force",
    "v_zero_force",
    "max_penetration",
    "max_force",
    "peak_force",
    "nfev",
    "status",  # 0 ok, 1 no end within t_bound or _MAX_STEPS, 2 step size underflow
)
_KIND_POWER, _KIND_CAP = 0.0, 1.0


def elastic_table(pot) -> np.ndarray:
    """Rows (kind, a, b, c, d) of ``pot``: a power law, a sum of them, a cap, or an
    expression that is a sum of powers (read through its sympy form)."""
    from reference_impl.exact._nodes import expression_sympy
    from reference_impl.potentials.power import PowerLaw

    if isinstance(pot, PowerLaw):
        return np.array([[_KIND_POWER, pot.k, pot.p, 0.0, 0.0]])
    if hasattr(pot, "terms"):
        return np.concatenate([elastic_table(t) for t in pot.terms])
    sym = expression_sympy(pot)
    if sym is not None:
        import sympy as sp

        _, dexpr, q = sym
        rows = []
        for term in sp.Add.make_args(sp.expand(dexpr)):
            coef, powr = term.as_coeff_exponent(q)
            if coef.free_symbols:
                raise ValueError(f"term {term} of U' is not c q^e")
            rows.append([_KIND_POWER, float(coef), float(powr), 0.0, 0.0])
        return np.array(rows)
    if hasattr(pot, "_bc") and hasattr(pot, "alpha"):
        a = pot._a
        return np.array([[_KIND_CAP, pot.Kn, pot.alpha, a, math.pi * pot._bc / a**2]])
    raise ValueError(f"no elastic table for {pot!r}")


def damping_table(pot, law) -> tuple[np.ndarray, float]:
    """Rows (c, e) of C(q) = sum c q^e for a law of `reference_impl.theory.laws` on a power
    law ``pot``, and the universal law's zeta (0 if none)."""
    from reference_impl.theory.laws import law_from_dict

    dl = law_from_dict(law)
    if dl.name in ("universal", "none"):
        return np.zeros((0, 2)), float(dl.zeta)
    rows = [[c, e] for c, e in dl.terms()]
    if dl.alpha:
        rows.append([dl.alpha * pot.k, pot.p])
    if dl.A:
        rows.append([dl.A * pot.k * pot.p, pot.p - 1.0])
    return np.array(rows, dtype=float).reshape(-1, 2), 0.0


@numba.njit(cache=True, error_model="numpy")
def _elastic(q, EL):  # pragma: no cover - compiled
    """U, U', U'' at q > 0."""
    u = du = d2u = 0.0
    for i in range(EL.shape[0]):
        a, b = EL[i, 1], EL[i, 2]
        if EL[i, 0] == _KIND_POWER:
            qb = q**b
            du += a * qb
            u += a * qb * q / (b + 1.0)
            d2u += a * b * qb / q
        else:
            aa, c0 = EL[i, 3], EL[i, 4]
            w = c0 * (aa * q * q - q * q * q / 3.0)
            w1 = c0 * (2.0 * aa * q - q * q)
            w2 = c0 * (2.0 * aa - 2.0 * q)
            wa = w**b
            u += a / (b + 1.0) * wa * w
            du += a * wa * w1
            d2u += a * (b * wa / w * w1 * w1 + wa * w2)
    return u, du, d2u


@numba.njit(cache=True, error_model="numpy")
def _force(q, v, m, zeta, EL, DA):  # pragma: no cover - compiled
    """Total force F = U' + C q', dF/dt (laws of DA only; not the universal law's), U'."""
    if q <= 0.0:
        return 0.0, 0.0, 0.0
    u, du, d2u = _elastic(q, EL)
    c = dc = 0.0
    for i in range(DA.shape[0]):
        qe = q ** DA[i, 1]
        c += DA[i, 0] * qe
        dc += DA[i, 0] * DA[i, 1] * qe / q
    if zeta > 0.0 and u > 0.0:
        c += 2.0 * zeta * math.sqrt(m) * du / math.sqrt(2.0 * u)
    f = du + c * v
    return f, (d2u + dc * v) * v - c * f / m, du


@numba.njit(cache=True, error_model="numpy")
def _rhs(q, v, m, zeta, EL, DA):  # pragma: no cover - compiled
    f = _force(q, v, m, zeta, EL, DA)[0]
    return v, -f / m


@numba.njit(cache=True, error_model="numpy")
def _dense(Fq, Fv, q0, v0, x):  # pragma: no cover - compiled
    """The 7th-degree dense output at fraction x of the step (Hairer's contd8)."""
    q = 0.0
    v = 0.0
    for i in range(6, -1, -1):
        q += Fq[i]
        v += Fv[i]
        if (6 - i) % 2 == 0:
            q *= x
            v *= x
        else:
            q *= 1.0 - x
            v *= 1.0 - x
    return q0 + q, v0 + v


@numba.njit(cache=True, error_model="numpy")
def _event_value(kind, q, v, m, zeta, EL, DA):  # pragma: no cover - compiled
    if kind == 0:
        return q
    if kind == 1:
        return v
    f, df, du = _force(q, v, m, zeta, EL, DA)
    # Zero force as F / U' = 1 + C q' / U': the same sign inside the contact, and not
    # driven to 0 by q -> 0 at its end (Hunt-Crossley's F = U' (1 + alpha q') is).
    return f / du if kind == 2 else df


@numba.njit(cache=True, error_model="numpy")
def _locate(kind, g_lo, g_hi, x_hi, Fq, Fv, q0, v0, m, zeta, EL, DA):  # pragma: no cover
    """Fraction x in (0, x_hi] of the step where event ``kind`` falls through 0 (Illinois)."""
    a, b, ga, gb = 0.0, x_hi, g_lo, g_hi
    side = 0
    for _ in range(_ROOT_ITER):
        x = (a * gb - b * ga) / (gb - ga)
        if not (a < x < b):
            x = 0.5 * (a + b)
        q, v = _dense(Fq, Fv, q0, v0, x)
        g = _event_value(kind, q, v, m, zeta, EL, DA)
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
def solve_dop853(m, v0, zeta, EL, DA, rtol, atol_q, atol_v, t_bound, h_first, out):
    """One impact from q = 0, q' = v0 until q falls back to 0 (see the module docstring).

    ``h_first`` <= 0 selects the first step by Hairer's rule; ``out`` receives `OUT_FIELDS`.
    """  # pragma: no cover - compiled
    K = np.empty((_NX, 2))
    Fq = np.empty(7)
    Fv = np.empty(7)
    t, q, v = 0.0, 0.0, v0
    fq, fv = _rhs(q, v, m, zeta, EL, DA)
    nfev = 1
    if h_first > 0.0:
        h = h_first
    else:  # Hairer's initial step for order 8 (hinit)
        sq, sv = atol_q + abs(q) * rtol, atol_v + abs(v) * rtol
        d0 = math.sqrt(0.5 * ((q / sq) ** 2 + (v / sv) ** 2))
        d1 = math.sqrt(0.5 * ((fq / sq) ** 2 + (fv / sv) ** 2))
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        gq, gv = _rhs(q + h0 * fq, v + h0 * fv, m, zeta, EL, DA)
        nfev += 1
        d2 = math.sqrt(0.5 * (((gq - fq) / sq) ** 2 + ((gv - fv) / sv) ** 2)) / h0
        big = max(d1, d2)
        h1 = max(1e-6, h0 * 1e-3) if big <= 1e-15 else (0.01 / big) ** (1.0 / 8.0)
        h = min(100.0 * h0, h1)
    for i in range(7):
        out[i] = np.nan
    # The force just after onset (q = 0+: a dashpot's c v0, 0 for the universal law):
    # the peak when the force only falls, and the start of the event functions.
    f_old, df_old, _du = _force(_Q_ONSET, v, m, zeta, EL, DA)
    out[6] = f_old
    # F / U' at onset: +inf (the force pushes from the start for every law here).
    g_old = np.array([q, v, np.inf, df_old if zeta == 0.0 else -1.0])
    g_new = np.empty(4)
    found_zf = False
    found_qmax = False
    rejected = False
    status = 1.0
    for _ in range(_MAX_STEPS):
        if t + h > t_bound:
            h = t_bound - t
        if h <= 4e-16 * max(t, 1e-300):
            status = 2.0
            break
        K[0, 0], K[0, 1] = fq, fv
        for s in range(1, _NS):
            dq = 0.0
            dv = 0.0
            for j in range(s):
                a = _A[s, j]
                if a != 0.0:
                    dq += a * K[j, 0]
                    dv += a * K[j, 1]
            K[s, 0], K[s, 1] = _rhs(q + h * dq, v + h * dv, m, zeta, EL, DA)
        nfev += _NS - 1
        bq = 0.0
        bv = 0.0
        for j in range(_NS):
            bq += _B[j] * K[j, 0]
            bv += _B[j] * K[j, 1]
        qn, vn = q + h * bq, v + h * bv
        K[_NS, 0], K[_NS, 1] = _rhs(qn, vn, m, zeta, EL, DA)
        nfev += 1
        # Error norm of Hairer's dop853 (5th- and 3rd-order estimators).
        sq = atol_q + max(abs(q), abs(qn)) * rtol
        sv = atol_v + max(abs(v), abs(vn)) * rtol
        e5q = e5v = e3q = e3v = 0.0
        for j in range(_NS + 1):
            e5q += _E5[j] * K[j, 0]
            e5v += _E5[j] * K[j, 1]
            e3q += _E3[j] * K[j, 0]
            e3v += _E3[j] * K[j, 1]
        n5 = (e5q / sq) ** 2 + (e5v / sv) ** 2
        n3 = (e3q / sq) ** 2 + (e3v / sv) ** 2
        den = n5 + 0.01 * n3
        err = 0.0 if den == 0.0 else abs(h) * n5 / math.sqrt(2.0 * den)
        if err > 1.0:
            h *= max(_FAC_MIN, _SAFETY * err ** (-1.0 / 8.0))
            rejected = True
            continue
        fac = _FAC_MAX if err == 0.0 else min(_FAC_MAX, _SAFETY * err ** (-1.0 / 8.0))
        if rejected:
            fac = min(1.0, fac)
        rejected = False
        # Accepted: events on this step.
        f_new, df_new, du_new = _force(qn, vn, m, zeta, EL, DA)
        g_new[0], g_new[1], g_new[2] = qn, vn, f_new / du_new
        # dF/dt is the table laws' only (the universal law's rows report U'(q_max), as
        # solve_impact does): -1 never falls through 0, so no event is sought there.
        g_new[3] = df_new if zeta == 0.0 else -1.0
        hit = False
        for kind in range(4):
            if g_old[kind] > 0.0 and g_new[kind] <= 0.0:
                if kind == 1 and found_qmax:
                    continue
                if kind == 2 and found_zf:
                    continue
                hit = True
        if hit:
            # Dense output: three more stages, then the coefficients of contd8.
            for s in range(_NS + 1, _NX):
                dq = 0.0
                dv = 0.0
                for j in range(s):
                    a = _A[s, j]
                    if a != 0.0:
                        dq += a * K[j, 0]
                        dv += a * K[j, 1]
                K[s, 0], K[s, 1] = _rhs(q + h * dq, v + h * dv, m, zeta, EL, DA)
            nfev += _NX - _NS - 1
            Fq[0], Fv[0] = qn - q, vn - v
            Fq[1], Fv[1] = h * K[0, 0] - Fq[0], h * K[0, 1] - Fv[0]
            Fq[2] = 2.0 * Fq[0] - h * (K[_NS, 0] + K[0, 0])
            Fv[2] = 2.0 * Fv[0] - h * (K[_NS, 1] + K[0, 1])
            for r in range(4):
                sq_ = 0.0
                sv_ = 0.0
                for j in range(_NX):
                    sq_ += _D[r, j] * K[j, 0]
                    sv_ += _D[r, j] * K[j, 1]
                Fq[3 + r], Fv[3 + r] = h * sq_, h * sv_
            x_hi = 1.0
            if g_new[0] <= 0.0:
                # The contact ends in this step: the other events are read up to just
                # before its end, where F / U' and dF/dt are still defined (an event
                # within 1e-8 of a step of the end counts as the end).
                x_end = _locate(0, g_old[0], g_new[0], 1.0, Fq, Fv, q, v, m, zeta, EL, DA)
                x_hi = x_end * (1.0 - 1e-8)
                qe, ve = _dense(Fq, Fv, q, v, x_hi)
                if qe > 0.0:
                    for kind in range(1, 4 if zeta == 0.0 else 3):
                        g_new[kind] = _event_value(kind, qe, ve, m, zeta, EL, DA)
                else:
                    g_new[1], g_new[2], g_new[3] = ve, 1.0, 1.0
            if g_old[1] > 0.0 and g_new[1] <= 0.0 and not found_qmax:
                x = _locate(1, g_old[1], g_new[1], x_hi, Fq, Fv, q, v, m, zeta, EL, DA)
                qm, _vm = _dense(Fq, Fv, q, v, x)
                out[4] = qm
                out[5] = _elastic(qm, EL)[1]
                found_qmax = True
            if g_old[3] > 0.0 and g_new[3] <= 0.0:
                x = _locate(3, g_old[3], g_new[3], x_hi, Fq, Fv, q, v, m, zeta, EL, DA)
                qp, vp = _dense(Fq, Fv, q, v, x)
                out[6] = max(out[6], _force(qp, vp, m, zeta, EL, DA)[0])
            if g_old[2] > 0.0 and g_new[2] <= 0.0 and not found_zf:
                x = _locate(2, g_old[2], g_new[2], x_hi, Fq, Fv, q, v, m, zeta, EL, DA)
                _qz, vz = _dense(Fq, Fv, q, v, x)
                out[2], out[3] = t + x * h, vz
                found_zf = True
            if g_new[0] <= 0.0:
                _qe, ve = _dense(Fq, Fv, q, v, x_end)
                out[0], out[1] = t + x_end * h, ve
                if not found_zf:  # the force never pulled: the two ends coincide
                    out[2], out[3] = out[0], out[1]
                status = 0.0
                break
        t, q, v = t + h, qn, vn
        fq, fv = K[_NS, 0], K[_NS, 1]
        for kind in range(4):
            g_old[kind] = g_new[kind]
        if t >= t_bound:
            break
        h *= fac
    out[7] = nfev
    out[8] = status
    return out
