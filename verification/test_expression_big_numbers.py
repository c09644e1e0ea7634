"""Expressions whose exact numbers leave int64 compile (numba's integer literals).

An expression's parameters are substituted as exact sympy numbers, and its derivatives
multiply them: k = 1e9 with exp(q / 1e-4) gives U''' a coefficient 1e21, which sympy
prints as the integer literal 1000000000000000000000 and numba refused to type ("Int
value is too large"): `solve_impact` raised numba's TypingError instead of solving, and
the Verlet lanes fell back to the numpy engine. Such numbers are now printed as floats
(`reference_impl._expr_cache.numba_numbers`).
"""

from __future__ import annotations

import sympy as sp

from reference_impl import Expression, prepare, solve_impact
from reference_impl._expr_cache import numba_numbers
from reference_impl.exact.solve import solve_impact_mp
from verification.assertions import assert_true

_Q = sp.Symbol("q", positive=True)


def test_numba_numbers_replaces_only_what_int64_cannot_hold():
    big, small = sp.Integer(10**21), sp.Integer(2**63 - 1)
    frac = sp.Rational(1, 3 * 10**20)
    expr = big * _Q**3 + small * _Q**2 + frac * _Q + sp.Rational(5, 2) * _Q ** sp.Rational(5, 2)
    got = numba_numbers(expr)
    rationals = got.atoms(sp.Rational)
    assert_true(
        big not in rationals and frac not in rationals and small in rationals,
        got=str(got),
        should="10**21 and 1/(3e20) as floats, 2**63 - 1, 5/2 kept exact",
        claim="tool",
        call="numba_numbers",
    )
    # The floats are the nearest doubles of the exact numbers (30 digits, then float()).
    assert_true(
        float(got.coeff(_Q, 3)) == 1e21 and float(got.coeff(_Q, 1)) == 1 / 3e20,
        got=f"{float(got.coeff(_Q, 3))!r}, {float(got.coeff(_Q, 1))!r}",
        should="1e21 and 1/3e20 to the last bit",
        claim="tool",
        call="numba_numbers",
    )
    pair = numba_numbers((expr, small * _Q))
    assert_true(
        isinstance(pair, tuple) and pair[1] == small * _Q and numba_numbers(small * _Q) is not None,
        got=repr(pair),
        should="a tuple, element by element",
        claim="tool",
        call="numba_numbers(tuple)",
    )


def test_exact_solver_solves_an_expression_with_a_derivative_beyond_int64():
    """Failed on main with numba's TypingError; now within its own bound of the truth."""
    pot = Expression("k*q**2.5*exp(q/a)", k=1e9, a=1e-4)
    m, v0, zeta = 0.0041, 1.0, 0.2
    sol = solve_impact(pot, m, v0, zeta)
    truth = solve_impact_mp(pot, m, v0, zeta, dps=30)
    err = abs(sol.contact_time - float(truth["contact_time"]))
    # The solver's stated bound on its contact time (quadrature plus round-off charge).
    assert_true(
        err <= sol.quadrature_error,
        got=f"|t - t_truth| = {err:.3g} s",
        should=f"<= its bound {sol.quadrature_error:.3g} s",
        claim="tool",
        call="solve_impact(k q^2.5 exp(q/a))",
    )
    assert_true(
        prepare(pot, m)(v0, zeta) == sol,
        got="a different prepared answer",
        should="solve_impact's, bit for bit",
        claim="tool",
        call="prepare(k q^2.5 exp(q/a))",
    )


def test_verlet_lanes_compile_an_expression_with_a_coefficient_beyond_int64():
    """Main printed 1e21 as an int literal: no compiled lane kernel (numpy engine)."""
    from reference_impl.integrators.verlet_expression import _expression_kernel

    pot = Expression("k*q**2.5/2.5 + c*q**2", k=1e21, c=1.0)
    assert_true(
        _expression_kernel(pot) is not None,
        got="no compiled kernel",
        should="the compiled lane kernel",
        claim="tool",
        call="_expression_kernel(1e21 q^2.5 / 2.5 + q^2)",
    )
