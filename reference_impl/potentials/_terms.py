"""The term table: one description of a potential as a sum of tabled terms.

The compiled kernels (the exact solver's node loops, `reference_impl.exact._nodes`, and
the velocity-Verlet lanes, `reference_impl.integrators.verlet_kernel`) evaluate U and its
derivatives from a small table of terms, one row per term, instead of calling the
potential. Each family describes its own rows (contract item 8 of `Potential`: the hook
``_term_rows()``); `term_rows` asks it and checks the answer. The kernels' layouts are
adapters of this one table (the exact side adds the half-power flag of a power term, the
Verlet side 1 / (p + 1)), so a family tabled here runs compiled in both (the exact solver
has kernels for power and cap rows; a saturating row sends it to its numpy path).

Row layout: five float64 numbers ``(code, c1, c2, c3, c4)``; U summed over the rows.

=================  ==========================  =============================================
code               U(q) of the term            columns c1, c2, c3, c4
=================  ==========================  =============================================
`TERM_POWER`       k q^n / n  (U' = k q^p)     k (N/m^p), n (> 0), p = n - 1, 0
`TERM_CAP`         Kn V^(alpha+1) / (alpha+1), Kn (J/m^(3(alpha+1))), alpha (> 0), a (m),
                   V = c0 (a q^2 - q^3 / 3)    c0 = pi b c / a^2 (dimensionless)
`TERM_SATURATING`  F0 q_s (x - atan x),        F0 (N), q_s (m), 0, 0
                   x = q / q_s
=================  ==========================  =============================================

A power term carries both exponents, n = p + 1 as the family computed it, so that
each kernel reads the exponent it uses without a rounding of its own (the exact
solver works with n, the Verlet force with p). Overlap q in metres, U in joules.

Which class's table counts: only a hook defined in the potential's own class body
(``type(pot).__dict__``). A subclass inherits no table, because it may change the law
(a spy that overrides ``_dU``, a modified cap): it runs on the numpy paths unless its
body opts in, e.g. ``_term_rows = PowerLaw._term_rows`` when the law is unchanged.
"""

from __future__ import annotations

import math
from typing import Any

from reference_impl.errors import HCVInputError

__all__ = [
    "TERM_CAP",
    "TERM_CODES",
    "TERM_POWER",
    "TERM_SATURATING",
    "cap_row",
    "power_row",
    "saturating_row",
    "sympy_power_rows",
    "term_rows",
]

TERM_POWER = 0.0
TERM_CAP = 1.0
TERM_SATURATING = 2.0
TERM_CODES = (TERM_POWER, TERM_CAP, TERM_SATURATING)
# Numbers in a row: the code and four parameters.
_ROW_LEN = 5

Row = tuple[float, float, float, float, float]


def power_row(k: float, n: float, p: float) -> Row:
    """The row of U = k q^n / n, U' = k q^p.

    Parameters
    ----------
    k : float
        Coefficient of the force, N / m^p.
    n : float
        Exponent of U (> 0, dimensionless).
    p : float
        Exponent of U', n - 1 as the family computes it (dimensionless).
    """
    return (TERM_POWER, float(k), float(n), float(p), 0.0)


def cap_row(Kn: float, alpha: float, a: float, c0: float) -> Row:
    """The row of the volumetric cap U = Kn V^(alpha+1) / (alpha+1), V = c0 (a q^2 - q^3/3).

    Parameters
    ----------
    Kn : float
        Volumetric stiffness, J / m^(3 (alpha + 1)).
    alpha : float
        Regularisation exponent (> 0, dimensionless).
    a : float
        Semi-axis along the impact, m.
    c0 : float
        pi b c / a^2 (dimensionless).
    """
    return (TERM_CAP, float(Kn), float(alpha), float(a), float(c0))


def saturating_row(F0: float, q_s: float) -> Row:
    """The row of U' = F0 x^2 / (1 + x^2), x = q / q_s (F0 in N, q_s in m)."""
    return (TERM_SATURATING, float(F0), float(q_s), 0.0, 0.0)


def term_rows(pot: Any) -> tuple[Row, ...] | None:
    """The term table of ``pot``, or None when its family has no table form.

    Asks the hook ``_term_rows()`` defined in the body of ``type(pot)`` itself (an
    inherited hook does not count: see the module notes), and checks its rows.

    Parameters
    ----------
    pot : Potential
        Any potential.

    Returns
    -------
    tuple of rows or None
        Rows ``(code, c1, c2, c3, c4)`` of float64 numbers (layout in the module
        notes), at least one; None for no table (the numpy paths are used then).

    Raises
    ------
    HCVInputError
        The family's hook returned something that is not a table of known terms with
        finite parameters (a bug of the family, reported instead of compiled).
    """
    hook = type(pot).__dict__.get("_term_rows")
    if hook is None:
        return None
    rows = hook(pot)
    if rows is None:
        return None
    out = tuple(_checked(pot, r) for r in rows)
    if not out:
        raise HCVInputError(f"{type(pot).__name__}._term_rows() returned no rows; return None")
    return out


def _checked(pot: Any, row) -> Row:
    """One row as floats, refused unless it has a known code and finite parameters."""
    try:
        vals = tuple(float(v) for v in row)
    except (TypeError, ValueError):
        vals = ()
    if len(vals) != _ROW_LEN or vals[0] not in TERM_CODES or not all(map(math.isfinite, vals)):
        raise HCVInputError(
            f"{type(pot).__name__}._term_rows(): {row!r} is not a term row "
            "(code in TERM_CODES and four finite numbers; reference_impl.potentials._terms)"
        )
    return vals  # type: ignore[return-value]


def sympy_power_rows(expr, q) -> list[Row] | None:
    """Power rows of a sympy U that is a sum of constants times q**e (e > 0), else None.

    Read exactly from the expanded form: the term c q^e is the table's k q^n / n with
    n = e, k = c n (float64 product) and p = e - 1 (rounded once, from the exact
    exponent). A term that is not a finite non-zero constant times a positive power
    of ``q`` (exp(q), q**2 log(q), a constant) gives None.

    The table evaluates the expanded sum, which is not the formula the caller checked
    in float64 (``float_formula_accurate`` vouches for U as written). Where expanding
    changed the sum and its terms have both signs, they can cancel: q**2 + q**2*(1-q)**40
    expands into terms of size 1e15 at q = 1.5 whose sum is 2.25, so its rows gave U =
    1.125 there. Such a form gets None (its sympy form is compiled as written instead);
    a sum of positive terms cannot cancel, and a sum the user wrote is the formula checked.

    Parameters
    ----------
    expr : sympy.Expr
        U(q) in joules, parameters substituted by exact numbers.
    q : sympy.Symbol
        The overlap (m) in ``expr``.
    """
    import sympy as sp  # only an expression's potential reaches here: sympy is loaded

    rows = []
    terms = sp.Add.make_args(sp.expand(expr))
    for term in terms:
        coeff, e = term.as_coeff_exponent(q)
        if coeff.has(q) or not (coeff.is_number and e.is_number and e.is_positive):
            return None
        c, n = float(coeff), float(e)
        if not (math.isfinite(c) and math.isfinite(c * n) and c != 0.0):
            return None
        rows.append(power_row(c * n, n, float(e - 1)))
    if any(r[1] < 0.0 for r in rows) and set(terms) != set(sp.Add.make_args(expr)):
        return None  # expanded, with terms of both signs: may cancel (see above)
    return rows or None
