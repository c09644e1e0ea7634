"""The GBS kernel's force function on a potential's term table (issue 38: a general law on
a cap, e.g. a sphere with a linear dashpot, ran the kernel in plain Python, ~60 ms an
impact).

`reference_impl.exact._general_kernel` integrates m q'' + C(q) q' + U'(q) = 0 around a
force function ``fc(q, full, ks, ps, cs, es, sc)`` returning (U, U', U'', C, C') at one
overlap q. Its compiled form read sums of power laws only (``ks``, ``ps`` the 1-D arrays
of k and p); every other family ran the same algorithm in Python around the potential's
numpy methods (`reference_impl.exact.general_law._generic_fc`), ~2800 evaluations of
~25 us each per impact. Here is the force function of a term table
(`reference_impl.potentials._terms`: power and cap rows), so that the same compiled
algorithm runs on it: `_general_step.fc` dispatches on the type of ``ks`` (1-D: the sums
of power laws, unchanged; 2-D: the rows here, with ``ps`` holding `table_arrays`'s
limit). The formulas are the families' own (`reference_impl.potentials.volumetric`,
`reference_impl.potentials.power`) in the same order of operations, so the two paths
differ by round-off only; U''' (which only steers the search of the peak force) is the
exact derivative where the Python path takes a central difference.

A saturating row (U = F0 q_s (x - atan x)) is not handled: its U needs a series near 0
(cancellation) that lives in numpy; such a table stays on the Python path.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.potentials._terms import TERM_CAP, TERM_POWER, term_rows

__all__ = ["cap_derivs", "fc_rows", "table_arrays"]


def table_arrays(pot) -> tuple[np.ndarray, np.ndarray] | None:
    """The arrays ``(rows, lim)`` the compiled kernel reads for ``pot``, or None.

    Parameters
    ----------
    pot : Potential
        Any potential.

    Returns
    -------
    tuple of numpy.ndarray or None
        ``rows``: the term table, shape (n, 5) (layout of `reference_impl.potentials._terms`;
        U in J, q in m); ``lim``: one number, the limit of U'/sqrt(2U) at q = 0 (N / sqrt(J)),
        which the zeta law's C needs where U = 0. None when
        the potential has no table or a row other than power and cap rows.
    """
    rows = term_rows(pot)
    if rows is None or any(r[0] not in (TERM_POWER, TERM_CAP) for r in rows):
        return None
    # U ~ c q^n at contact: U'/sqrt(2U) -> sqrt(2c) for n = 2, 0 for n > 2, inf for n < 2
    # (as `general_law._generic_fc` takes it).
    n = float(pot.leading_exponent)
    c = float(pot.leading_coefficient)
    lim = math.sqrt(2.0 * c) if n == 2.0 and c else 0.0 if n > 2.0 else math.inf
    return np.array(rows, dtype=float), np.array([lim], dtype=float)


# error_model "numpy": as in `_general_step`, the kernel may run in a prange loop, where an
# exception cannot be carried out; inf/NaN is refused by the kernel's status tests.


@numba.njit(cache=True, error_model="numpy")
def cap_derivs(q, need_U, need_2, need_3, Kn, alpha, a, c0):
    """(U, U', U'', U''') of one cap row at q (J, N, N/m, N/m^2); U, U'' and U''' only
    where asked (``need_*``, else 0: each costs a pow, and a step's right-hand side needs
    U' alone for most laws).

    As `reference_impl.potentials.volumetric._VolumetricCap`: V = c0 (a q^2 - q^3 / 3),
    S = V' = c0 (2 a q - q^2), U = Kn V^(alpha+1) / (alpha+1), U' = Kn V^alpha S,
    U'' = Kn V^alpha (alpha S^2 / V + S') with S^2 / V = c0 (2a - q)^2 / (a - q/3).
    """
    V = c0 * (a * q**2 - q**3 / 3)
    S = c0 * (2 * a * q - q**2)
    U = 0.0
    if need_U:
        ap1 = alpha + 1
        U = Kn * V**ap1 / ap1
    # numpy's power takes sqrt for the exponent 0.5 (the paper's alpha): the same here.
    Va = math.sqrt(V) if alpha == 0.5 else V**alpha
    dU = Kn * Va * S
    s2v = c0 * (2 * a - q) ** 2 / (a - q / 3)
    dS = c0 * (2 * a - 2 * q)
    d2U = 0.0
    if need_2:
        d2U = Kn * Va * (alpha * s2v + dS)
    d3U = 0.0
    if need_3:
        # U''' = Kn [alpha V^(alpha-1) S ((alpha-1) S^2/V + 3 S') + V^alpha S''], S'' = -2 c0.
        # V^(alpha-1) S ~ q^(2 alpha - 1) at contact: where V underflows, its leading term
        # 2 (c0 a)^alpha q^(2 alpha - 1) (0, 1 or inf at q = 0, as alpha >, =, < 1/2).
        if V > 0.0:
            g = Va / V * S
        else:
            g = 2.0 * (c0 * a) ** alpha * q ** (2 * alpha - 1)
        d3U = Kn * (alpha * g * ((alpha - 1) * s2v + 3 * dS) - 2 * c0 * Va)
    return U, dU, d2U, d3U


@numba.njit(cache=True, error_model="numpy")
def _pow(q, p):
    """q^p, exactly as `_general_step.pw` for the exponents it specialises."""
    if p == 1.0:
        return q
    if p == 0.0:
        return 1.0
    if p == 2.0:
        return q * q
    if p == 1.5:
        return q * math.sqrt(q)
    if p == 0.5:
        return math.sqrt(q)
    return q**p


@numba.njit(cache=True, error_model="numpy")
def fc_rows(q, full, rows, lim, cs, es, sc):
    """(U, U', U'', C, C') at overlap q (m) of a term table (`table_arrays`) and the law's
    arrays (``cs``, ``es``: C = sum c q^e; ``sc``: m, alpha, A, zeta factor, ...; see
    `reference_impl.exact.general_law._law_arrays`). Units: J, N, N/m, N s/m, N s/m^2."""
    alpha, A, zf = sc[1], sc[2], sc[3]
    # What the law reads besides U' (as `_general_step._fc_powers`): U for the zeta law
    # and the full evaluation, U'' for A U'' and the full one, U''' for the full A U''.
    need_U = full or zf != 0.0
    need_2 = full or A != 0.0
    need_3 = full and A != 0.0
    U = 0.0
    dU = 0.0
    d2U = 0.0
    d3U = 0.0
    for i in range(rows.shape[0]):
        if rows[i, 0] == TERM_CAP:
            u, d1, d2, d3 = cap_derivs(
                q, need_U, need_2, need_3, rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4]
            )
        else:  # TERM_POWER: U = k q^n / n, U' = k q^p
            k, n, p = rows[i, 1], rows[i, 2], rows[i, 3]
            qp = _pow(q, p)
            u = k * qp * q / n
            d1 = k * qp
            d2 = k if p == 1.0 else k * p * _pow(q, p - 1.0)
            d3 = 0.0
            if need_3 and p != 1.0:
                d3 = 2.0 * k if p == 2.0 else k * p * (p - 1.0) * _pow(q, p - 2.0)
        U += u
        dU += d1
        d2U += d2
        d3U += d3
    C = 0.0
    dC = 0.0
    for j in range(cs.shape[0]):
        c, e = cs[j], es[j]
        if e == 0.0:
            C += c
        else:
            C += c * _pow(q, e)
            if full:
                dC += c * e * _pow(q, e - 1.0)
    if alpha != 0.0:
        C += alpha * dU
        dC += alpha * d2U
    if A != 0.0:
        C += A * d2U
        dC += A * d3U
    if zf != 0.0:
        if U > 0.0:
            r = math.sqrt(2.0 * U)
            C += zf * dU / r
            if full:
                dC += zf * (d2U / r - dU * dU / (r * r * r))
        else:  # q = 0: the limit of U'/sqrt(2U) (`table_arrays`)
            C += zf * lim[0]
    return U, dU, d2U, C, dC
