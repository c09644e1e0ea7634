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
domain (0 <= q <= 2a, where h >= 1/3). The step's radius estimate reads the series of
rho, W and T, and W' carries f, so the branch point is seen by the root test like any
other singularity of the solution: the step stays a fraction theta of the estimated
radius, and the truncation estimate is the same geometric tail (the coefficients of an
algebraic branch point decay like k^(-alpha-1) r^-k, no slower than the geometric tail
assumes). To keep that point far from the contact, a turning point beyond ``_Q_CAP`` a
(q_E > a: past the hemisphere, h < 2/3) is handed to the GBS kernel: at q_E <= a, for
N = 1 the branch point is at rho = 3a / q_E >= 3, two units beyond the contact's rho <= 1
(for N = 2, ring of radius sqrt(3) >= 1.7). Realistic overlaps are far below that
(sphere-damped: q_max / R ~ 1e-3).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.exact._general_fields import form
from reference_impl.exact._general_kernel import OUT_FIELDS
from reference_impl.exact._general_kernel import solve as _gbs_solve
from reference_impl.exact._general_rows import cap_derivs
from reference_impl.exact._general_taylor import DEG_MAX, N_MAX, as_int, integrate
from reference_impl.potentials._terms import TERM_CAP

__all__ = ["solve", "solve_cap_taylor", "solve_formed"]

# Largest elastic turning point, in units of the cap's semi-axis a, run by the Taylor
# method (the branch point of h^alpha at q = 3a stays >= 3 q_E away; module notes).
_Q_CAP = 1.0


@numba.njit(cache=True, error_model="numpy")
def _cap_n(alpha, cs, es):
    """Smallest N <= N_MAX with 2 N alpha and every N e_j (c_j != 0) integers, or 0."""
    for N in range(1, N_MAX + 1):
        ok = as_int(2.0 * N * alpha) >= 0
        for j in range(cs.shape[0]):
            if cs[j] != 0.0 and as_int(N * es[j]) < 0:
                ok = False
        if ok:
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
    Kn, alpha, a, c0 = rows[0, 1], rows[0, 2], rows[0, 3], rows[0, 4]
    L = qE
    if not (0.0 < L <= _Q_CAP * a):
        return 1
    N = _cap_n(alpha, cs, es)
    if N == 0:
        return 1
    d1 = as_int(2.0 * N * alpha) + N
    if d1 + N > DEG_MAX:
        return 1
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
                return 1
            C[d] += cs[j] * L ** (es[j] + 1.0) / (m * v0)
    if sc[1] != 0.0:  # Hunt-Crossley: C = alpha_HC U', scaled alpha_HC v0 f
        for j in range(DEG_MAX + 1):
            CY[j] = sc[1] * v0 * F[j]
    cp = np.empty(2)
    cp[0] = L / (3.0 * a)
    cp[1] = alpha
    if integrate(v0, L, N, F, C, CY, cp, sc, out) != 0:
        return 1
    out[2] = cap_derivs(out[1], False, False, False, Kn, alpha, a, c0)[1]
    out[9] = out[9] * L / qE
    return 0


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
