"""The compiled DOP853 peers on the plain equations of motion (issues 27 and 38): numba.

What a user could pick instead of the harmonic map: DOP853 (`benchmarks._dop853_core`:
the published Dormand-Prince 8(5,3) tableau, Hairer's step control, events on the
dense output) on m q'' + C(q) q' + U'(q) = 0 in (q, q'). One call solves one impact in
compiled code and returns every output the exact solvers report:

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

Two kernels: `solve_dop853` (every power by ``q**b``: numba's pow) and
`solve_dop853_sqrt` (issue 38's specialised peer: every exponent that is a multiple of
1/4, Hertz's 1.5, 2.5, 0.5 and Tsuji's 0.25 among them, from q, sqrt(q) and
sqrt(sqrt(q)) by multiplications, and the universal law's U' / sqrt(2 U) of a single
power term in closed form, sqrt(a (b + 1) / 2) q^((b - 1) / 2); other exponents and
caps as `solve_dop853`).
"""

from __future__ import annotations

import math
import sys

import numba
import numpy as np

from ._dop853_core import OUT_FIELDS, integrate

__all__ = [
    "OUT_FIELDS",
    "damping_table",
    "elastic_table",
    "solve_dop853",
    "solve_dop853_sqrt",
]

# This module, through which the kernels name their model functions: a dispatcher named
# as a module's attribute is passed to `integrate` as a static type, while one named as a
# bare global becomes a run-time address numba cannot cache ("dynamic globals": each new
# process would recompile the kernel, ~1 min; measured with numba 0.68).
_M = sys.modules[__name__]
# Overlap at which the onset force is read (the limit q -> 0+ of every table term).
_Q_ONSET = 1e-300
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


# -- the plain model (every power by q**b) ------------------------------------------
# P = (m, zeta, EL, DA); the state y = (q [m], q' [m/s]), s = t [s].


@numba.njit(cache=True, error_model="numpy")
def _rhs(y, P, dy):  # pragma: no cover - compiled
    m, zeta, EL, DA = P
    f = _force(y[0], y[1], m, zeta, EL, DA)[0]
    dy[0] = y[1]
    dy[1] = -f / m


@numba.njit(cache=True, error_model="numpy")
def _events(y, P, g):  # pragma: no cover - compiled
    m, zeta, EL, DA = P
    f, df, du = _force(y[0], y[1], m, zeta, EL, DA)
    g[0], g[1] = y[0], y[1]
    # Zero force as F / U' = 1 + C q' / U': the same sign inside the contact, and not
    # driven to 0 by q -> 0 at its end (Hunt-Crossley's F = U' (1 + alpha q') is).
    g[2] = f / du
    # dF/dt is the table laws' only (the universal law's rows report U'(q_max), as
    # solve_impact does): -1 never falls through 0, so no event is sought there.
    g[3] = df if zeta == 0.0 else -1.0


@numba.njit(cache=True, error_model="numpy")
def _event(kind, y, P):  # pragma: no cover - compiled
    if kind == 0:
        return y[0]
    if kind == 1:
        return y[1]
    m, zeta, EL, DA = P
    if kind == 3 and zeta != 0.0:
        return -1.0
    f, df, du = _force(y[0], y[1], m, zeta, EL, DA)
    return f / du if kind == 2 else df


@numba.njit(cache=True, error_model="numpy")
def _observe(s, y, P):  # pragma: no cover - compiled
    m, zeta, EL, DA = P
    f, _df, du = _force(y[0], y[1], m, zeta, EL, DA)
    return s, y[0], y[1], f, du


@numba.njit(cache=True, error_model="numpy")
def _onset(y, P):  # pragma: no cover - compiled
    m, zeta, EL, DA = P
    f, df, _du = _force(_Q_ONSET, y[1], m, zeta, EL, DA)
    return f, (df if zeta == 0.0 else -1.0)


@numba.njit(cache=True, error_model="numpy")
def solve_dop853(m, v0, zeta, EL, DA, rtol, atol_q, atol_v, t_bound, h_first, out):
    """One impact from q = 0, q' = v0 until q falls back to 0 (see the module docstring).

    Parameters
    ----------
    m : float
        Mass (kg).
    v0 : float
        Impact speed (m/s).
    zeta : float
        The universal law's damping ratio (0 for the laws of ``DA``).
    EL, DA : ndarray
        `elastic_table` and `damping_table` rows.
    rtol : float
        Relative tolerance.
    atol_q, atol_v : float
        Absolute tolerances of q (m) and q' (m/s).
    t_bound : float
        Longest contact integrated (s).
    h_first : float
        First step (s); <= 0 selects it by Hairer's rule.
    out : ndarray
        Receives `OUT_FIELDS`; returned.
    """  # pragma: no cover - compiled
    y0 = np.array([0.0, v0])
    atol = np.array([atol_q, atol_v])
    P = (m, zeta, EL, DA)
    return integrate(
        _M._rhs, _M._events, _M._event, _M._observe, _M._onset, y0, P, rtol, atol, t_bound,
        h_first, out,
    )  # fmt: skip


# -- the q sqrt(q) model (issue 38): powers in quarters by square roots ---------------
# P = (m, zeta, EL, DA, cu, eu): cu q^eu is the universal law's C of a single power
# term (cu = 0: C from U' / sqrt(2 U) as `_force`).


@numba.njit(cache=True, error_model="numpy")
def _pow4(q, s2, b):  # pragma: no cover - compiled
    """q^b, q > 0, s2 = sqrt(q): by multiplications and square roots where 4 b is an
    integer in [0, 64] (q^(k/4) = q^(k // 4) s2^(k % 4 // 2) sqrt(s2)^(k % 2)), else pow."""
    k4 = 4.0 * b
    k = int(k4)
    if k != k4 or k < 0 or k > 64:
        return q**b
    r = q ** (k >> 2) if k >= 4 else 1.0
    if k & 2:
        r *= s2
    if k & 1:
        r *= math.sqrt(s2)
    return r


@numba.njit(cache=True, error_model="numpy")
def _elastic_sqrt(q, s2, EL):  # pragma: no cover - compiled
    """U, U', U'' at q > 0 (powers by `_pow4`; caps as `_elastic`)."""
    u = du = d2u = 0.0
    for i in range(EL.shape[0]):
        a, b = EL[i, 1], EL[i, 2]
        if EL[i, 0] == _KIND_POWER:
            qb = _pow4(q, s2, b)
            du += a * qb
            u += a * qb * q / (b + 1.0)
            d2u += a * b * qb / q
        else:
            cu, dcu, d2cu = _elastic(q, EL[i : i + 1])
            u += cu
            du += dcu
            d2u += d2cu
    return u, du, d2u


@numba.njit(cache=True, error_model="numpy")
def _force_sqrt(q, v, P):  # pragma: no cover - compiled
    """`_force` with the powers of `_pow4` and the closed-form universal C."""
    m, zeta, EL, DA, cu, eu = P
    if q <= 0.0:
        return 0.0, 0.0, 0.0
    s2 = math.sqrt(q)
    u, du, d2u = _elastic_sqrt(q, s2, EL)
    c = dc = 0.0
    for i in range(DA.shape[0]):
        qe = _pow4(q, s2, DA[i, 1])
        c += DA[i, 0] * qe
        dc += DA[i, 0] * DA[i, 1] * qe / q
    if zeta > 0.0:
        if cu != 0.0:
            c += cu * _pow4(q, s2, eu)
        elif u > 0.0:
            c += 2.0 * zeta * math.sqrt(m) * du / math.sqrt(2.0 * u)
    f = du + c * v
    return f, (d2u + dc * v) * v - c * f / m, du


@numba.njit(cache=True, error_model="numpy")
def _rhs_sqrt(y, P, dy):  # pragma: no cover - compiled
    dy[0] = y[1]
    dy[1] = -_force_sqrt(y[0], y[1], P)[0] / P[0]


@numba.njit(cache=True, error_model="numpy")
def _events_sqrt(y, P, g):  # pragma: no cover - compiled
    f, df, du = _force_sqrt(y[0], y[1], P)
    g[0], g[1], g[2] = y[0], y[1], f / du  # as `_events`
    g[3] = df if P[1] == 0.0 else -1.0


@numba.njit(cache=True, error_model="numpy")
def _event_sqrt(kind, y, P):  # pragma: no cover - compiled
    if kind == 0:
        return y[0]
    if kind == 1:
        return y[1]
    if kind == 3 and P[1] != 0.0:
        return -1.0
    f, df, du = _force_sqrt(y[0], y[1], P)
    return f / du if kind == 2 else df


@numba.njit(cache=True, error_model="numpy")
def _observe_sqrt(s, y, P):  # pragma: no cover - compiled
    f, _df, du = _force_sqrt(y[0], y[1], P)
    return s, y[0], y[1], f, du


@numba.njit(cache=True, error_model="numpy")
def _onset_sqrt(y, P):  # pragma: no cover - compiled
    f, df, _du = _force_sqrt(_Q_ONSET, y[1], P)
    return f, (df if P[1] == 0.0 else -1.0)


@numba.njit(cache=True, error_model="numpy")
def solve_dop853_sqrt(m, v0, zeta, EL, DA, rtol, atol_q, atol_v, t_bound, h_first, out):
    """`solve_dop853` with powers by square roots (see the module docstring); the same
    parameters and outputs."""  # pragma: no cover - compiled
    cu = eu = 0.0
    if zeta > 0.0 and EL.shape[0] == 1 and EL[0, 0] == _KIND_POWER:
        a, b = EL[0, 1], EL[0, 2]
        # C = 2 zeta sqrt(m) U' / sqrt(2 U), U = a q^(b+1) / (b+1): sqrt(a (b+1) / 2) q^((b-1)/2)
        cu = 2.0 * zeta * math.sqrt(m) * math.sqrt(0.5 * a * (b + 1.0))
        eu = 0.5 * (b - 1.0)
    y0 = np.array([0.0, v0])
    atol = np.array([atol_q, atol_v])
    P = (m, zeta, EL, DA, cu, eu)
    return integrate(
        _M._rhs_sqrt,
        _M._events_sqrt,
        _M._event_sqrt,
        _M._observe_sqrt,
        _M._onset_sqrt,
        y0,
        P,
        rtol,
        atol,
        t_bound,
        h_first,
        out,
    )
