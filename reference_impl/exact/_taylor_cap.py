"""The Taylor kernel on a volumetric cap (issue 38, goal 4: a sphere with a general law).

A general damping law on a single cap row of the term table (`potentials.volumetric`:
sphere, ellipsoid; row `potentials._terms.cap_row`) ran the GBS kernel
(`_general_kernel` on `_general_rows`: order-14 extrapolation, ~30 steps of ~57
evaluations, full accuracy whatever ``rtol`` asks), ~2x slower than the peer at 1e-8.
Here it runs the Taylor kernel of the sums of power laws (`_general_taylor.integrate`):

    U = Kn V^(alpha+1) / (alpha+1),  V = c0 q^2 (a - q/3),  U' = Kn V^alpha S,
    S = c0 q (2a - q).

With q = L rho^N (L = q_E, the elastic turning point) and 2 N alpha an integer,
V = c0 a L^2 rho^(2N) h(rho), h = 1 - beta rho^N, beta = L / (3a), so the scaled force is

    f(rho) = A0 rho^(2 N alpha + N) (2a - L rho^N) h(rho)^alpha,
    A0 = Kn (c0 a L^2)^alpha c0 L^2 / (m v0^2),

a polynomial times y = h^alpha, whose Taylor series comes from the power recurrence
k h_0 y_k = sum_{j=1..k} (alpha j - (k - j)) h_j y_(k-j) (O(K^2) a step, as the
products). The law's C = sum c_j q^e_j is a polynomial in rho (N e_j integers), and
Hunt-Crossley's alpha_HC U' carries the same factor (``CY`` of `integrate`). Laws with
A U'' (viscoelastic) or the zeta law (U'/sqrt(2U)) bring h^(alpha-1) or
h^((alpha+1)/2) and other factors: they stay on the GBS kernel, as does every table that
is not one cap row, an alpha with 2 N alpha not an integer for N <= `N_MAX`, and
everything `integrate` hands back (bit for bit what `general_law` ran before).

The singularity. y = h^alpha has a branch point at h = 0, q = 3a, outside the family's
domain (0 <= q <= 2a, where h >= 1/3: the potential refuses a turning point beyond 2a), so
q_max can never approach it: at q_E <= 2a the branch point lies at rho^N = 3a / q_E >= 1.5,
for N = 1 at least 0.5 beyond the contact's rho <= 1. The step's radius estimate reads
the series of rho, W and T, and W' carries f, so the branch point is seen by the root test
like any other singularity of the solution: the step stays a fraction theta of the
estimated radius, and the truncation estimate is the same geometric tail (an algebraic
branch point's coefficients decay like k^(-alpha-1) r^-k, no slower than the geometric
tail assumes). `_Q_CAP` keeps that guard explicit (a turning point beyond it goes to the
GBS kernel). Measured against the GBS kernel up to q_E = 1.6 a
(`verification/test_general_taylor_cap.py`); realistic overlaps are far below (the
workprecision panel's sphere: q_E / R = 0.02-0.9 at 0.1-3 m/s).

The exit. With N = 1 the bound of the exit carries 1 / |W| (dT/ds = 1 there: the exit
root's error moves T), large for a slow, heavily damped exit; such a run (restitution
below `_SLOW_EXIT`) is redone with the next N >= 2, where T and W are stationary at the
exit.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.exact._general_fields import form
from reference_impl.exact._general_kernel import OUT_FIELDS
from reference_impl.exact._general_kernel import solve as _gbs_solve
from reference_impl.exact._general_rows import cap_derivs
from reference_impl.exact._general_taylor import (
    DEG_MAX,
    N_MAX,
    K,
    as_int,
    integrate,
    law_exponents_fit,
)
from reference_impl.potentials._terms import TERM_CAP

__all__ = ["solve", "solve_cap_taylor", "solve_formed"]

# Largest elastic turning point, in units of the cap's semi-axis a, run by the Taylor
# method: the domain's end (the branch point of h^alpha at q = 3a stays >= 1.5 q_E away;
# module notes).
_Q_CAP = 2.0
# Restitution below which an N = 1 run is redone with N >= 2 (its exit bound, ~1 / e
# times the summed truncation, then exceeds 10x that sum).
_SLOW_EXIT = 0.1


@numba.njit(cache=True, error_model="numpy")
def _cap_n(alpha, cs, es, start):
    """Smallest N in [start, N_MAX] with 2 N alpha and every N e_j (c_j != 0) integers, or 0."""
    for N in range(start, N_MAX + 1):
        if as_int(2.0 * N * alpha) >= 0 and law_exponents_fit(N, cs, es):
            return N
    return 0


@numba.njit(cache=True, error_model="numpy")
def solve_cap_taylor(v0, qE, rows, cs, es, sc, out):
    """One impact on a cap row by the Taylor kernel into ``out`` (`OUT_FIELDS`); returns 0,
    or 1 when the case is not for this method (module notes): ``out`` is then void.

    Parameters as `_general_kernel.solve` on a term table: ``v0`` (m/s), ``qE`` the elastic
    turning point (m), ``rows`` the table (`_general_rows.table_arrays`), ``cs``, ``es``,
    ``sc`` the law's arrays (`_general_contact.law_arrays`, with an ``rtol``'s truncation).
    """
    if rows.shape[0] != 1 or rows[0, 0] != TERM_CAP or sc[2] != 0.0 or sc[3] != 0.0:
        return 1
    if not (0.0 < qE <= _Q_CAP * rows[0, 3]):
        return 1
    N = _cap_run(v0, qE, rows, cs, es, sc, out, 1)
    if N == 1 and out[8] == 1.0 and -out[7] < _SLOW_EXIT * v0:
        # A slow exit with N = 1: its bound carries 1 / |W| (`integrate`: dT/ds = 1 there,
        # the exit root's error moves T); N >= 2 makes T and W stationary at the exit.
        # (Measured on sphere-damped, rtol 1e-6: 9.7e-5 relative at N = 1, 2.4e-7 at N = 2,
        # where N = 2 takes ~1.7x the steps.)
        N = _cap_run(v0, qE, rows, cs, es, sc, out, 2)
    return 0 if N > 0 else 1


@numba.njit(cache=True, error_model="numpy")
def _cap_run(v0, qE, rows, cs, es, sc, out, start):
    """`solve_cap_taylor` with q = L rho^N, N the smallest fit >= ``start``: N, or 0 when
    the case is not for this method."""
    Kn, alpha, a, c0 = rows[0, 1], rows[0, 2], rows[0, 3], rows[0, 4]
    L = qE
    N = _cap_n(alpha, cs, es, start)
    if N == 0:
        return 0
    d1 = as_int(2.0 * N * alpha) + N
    if d1 + N > DEG_MAX:
        return 0
    m = sc[0]
    F = np.zeros(DEG_MAX + 1)
    C = np.zeros(DEG_MAX + 1)
    CY = np.zeros(DEG_MAX + 1)
    V1 = c0 * a * L * L  # V / h at rho = 1 (m^3)
    A0 = Kn * (math.sqrt(V1) if alpha == 0.5 else V1**alpha) * c0 * L * L / (m * v0 * v0)
    F[d1] = 2.0 * a * A0
    F[d1 + N] = -L * A0
    for j in range(cs.shape[0]):
        if cs[j] != 0.0:
            d = as_int(N * es[j])
            if d > DEG_MAX:
                return 0
            C[d] += cs[j] * L ** (es[j] + 1.0) / (m * v0)
    if sc[1] != 0.0:  # Hunt-Crossley: C = alpha_HC U', scaled alpha_HC v0 f
        for j in range(DEG_MAX + 1):
            CY[j] = sc[1] * v0 * F[j]
    cp = np.empty(2)
    cp[0] = L / (3.0 * a)
    cp[1] = alpha
    if integrate(v0, L, N, F, C, CY, cp, sc, out, np.zeros((4, K + 1))) != 0:
        return 0
    out[2] = cap_derivs(out[1], False, False, False, Kn, alpha, a, c0)[1]
    out[9] = out[9] * L / qE
    return N


@numba.njit(cache=True, error_model="numpy")
def solve(v0, qE, rows, lim, cs, es, sc):
    """One impact on a term table, as `_general_kernel.solve` (same arguments,
    `OUT_FIELDS`): by the Taylor method on a single cap row where it applies (module
    notes), else by the GBS kernel."""
    out = np.full(len(OUT_FIELDS), np.nan)
    if solve_cap_taylor(v0, qE, rows, cs, es, sc, out) == 0:
        return out
    return _gbs_solve(v0, qE, rows, lim, cs, es, sc)


@numba.njit(cache=True, error_model="numpy")
def solve_formed(v0, q_e, rows, lim, cs, es, sc):  # pragma: no cover - compiled
    """`_general_fields.form` of `solve` (same arguments): one compiled call per impact."""
    return form(solve(v0, q_e, rows, lim, cs, es, sc), v0, q_e)
