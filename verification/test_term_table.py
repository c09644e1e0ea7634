"""The one term table (`reference_impl.potentials._terms`) and its two adapters.

The exact solver's rows (`exact._nodes._term_rows`) and the Verlet lanes' arrays
(`integrators.verlet_kernel.kernel_terms`) were two parallel family tables, each
picking families by ``type(pot) is X``. Both are now adapters of the table each
family describes itself. The functions they replaced are frozen below: the arrays
for power laws, caps, the saturating force and sums must be bit-identical to theirs,
so every exact and Verlet result for those families is unchanged. (Tool tests, no
claim marks.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from reference_impl.errors import HCVInputError
from reference_impl.exact._nodes import _term_exponents
from reference_impl.exact._nodes import _term_rows as exact_rows
from reference_impl.integrators.verlet import (
    SCENE_IMPACT,
    SCENE_WALLS,
    LaneBatch,
    kernel_terms,
    run_lanes,
)
from reference_impl.potentials import (
    Ellipsoid,
    Expression,
    PowerLaw,
    SaturatingForce,
    Sphere,
    SumPotential,
)
from reference_impl.potentials._terms import TERM_POWER, power_row, term_rows
from verification.assertions import assert_true

# ----------------------------------------------------------------------------
# The functions the table replaced, frozen as they were (commit 2065532).
# ----------------------------------------------------------------------------
_OLD_HALF_POWER_MAX = 4
_OLD_NOT_HALF = 99


def _old_exact_rows(pot):
    if type(pot) is PowerLaw:
        return [_old_power_row(pot.k, pot.leading_exponent)]
    if type(pot) in (Ellipsoid, Sphere):
        c0 = math.pi * pot._bc / pot._a**2
        return [(1.0, pot.Kn, pot.alpha, pot._a, c0)]
    if type(pot) is SumPotential:
        rows = []
        for t in pot.terms:
            sub = _old_exact_rows(t)
            if sub is None:
                return None
            rows += sub
        return rows
    return _old_expression_power_rows(pot)


def _old_power_row(k, n):
    h2 = 2.0 * (n - 1.0)
    h = int(h2) if h2 == int(h2) and abs(h2) <= _OLD_HALF_POWER_MAX else _OLD_NOT_HALF
    return (0.0, k, n, float(h), 0.0)


def _old_expression_power_rows(pot):
    expr = getattr(pot, "sympy_U", None)
    if not isinstance(expr, sp.Expr) or not getattr(pot, "float_formula_accurate", True):
        return None
    (q,) = expr.free_symbols
    rows = []
    for term in sp.Add.make_args(sp.expand(expr)):
        coeff, e = term.as_coeff_exponent(q)
        if coeff.has(q) or not (coeff.is_number and e.is_number and e.is_positive):
            return None
        c, n = float(coeff), float(e)
        if not (math.isfinite(c) and math.isfinite(c * n) and c != 0.0):
            return None
        rows.append(_old_power_row(c * n, n))
    return rows or None


def _old_kernel_terms(pot):
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    fam = np.zeros(len(terms), dtype=np.int64)
    par = np.zeros((len(terms), 4))
    for i, t in enumerate(terms):
        if type(t) is PowerLaw:
            fam[i], par[i, :3] = 0, (t.k, t.p, 1.0 / (t.p + 1.0))
        elif type(t) in (Ellipsoid, Sphere):
            fam[i] = 1
            par[i] = (math.pi * t._bc / t._a**2, t._a, t.Kn, t.alpha)
        elif type(t) is SaturatingForce:
            fam[i], par[i, :2] = 2, (t.F0, t.q_s)
        else:
            return None
    return fam, par


def _old_term_exponents(pot):
    if type(pot) in (PowerLaw, Ellipsoid, Sphere):
        return [pot.leading_exponent]
    terms = getattr(pot, "terms", None)
    if terms is not None:
        out = []
        for t in terms:
            sub = _old_term_exponents(t)
            if sub is None:
                return None
            out += sub
        return out
    expr = getattr(pot, "sympy_U", None)
    if not isinstance(expr, sp.Expr):
        return None
    (q,) = expr.free_symbols
    out = []
    for term in expr.as_ordered_terms():
        coeff, e = term.as_coeff_exponent(q)
        if coeff.has(q) or not e.is_number:
            return None
        out.append(float(e))
    return out


# ----------------------------------------------------------------------------
class _Spy(PowerLaw):
    """Changes nothing but does not opt in: no table (it might change the law)."""

    def _dU(self, q):
        return super()._dU(q)


class _KeptLaw(PowerLaw):
    """Opts in: the law is PowerLaw's, so is the table."""

    _term_rows = PowerLaw._term_rows


class _Harder(Ellipsoid):
    """Changes the cap's law and inherits the hook: must get no table."""

    def _dU(self, q):
        return 2.0 * super()._dU(q)


_POWERS = [
    PowerLaw(2.0, 1.5),
    PowerLaw(1e10, 1.5),
    PowerLaw(1.0, 1.0),
    PowerLaw(5e4, 0.5),
    PowerLaw(3.3, 1.37),
    PowerLaw(7.0, 2.0),
    PowerLaw(1e-12, 0.01),
    PowerLaw(1.0, 20.0),
]
_CAPS = [Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5), Ellipsoid(0.02, 0.01, 0.03, 3e9, 0.7)]
_CAPS += [Sphere(0.01, 1e9), Sphere(0.005, 2e8, 1.3)]
_SATS = [SaturatingForce(), SaturatingForce(2.0, 3e-3)]
_SUMS = [
    PowerLaw(1e3, 1.0) + PowerLaw(1e5, 2.5),
    PowerLaw(1e-12, 0.01) + PowerLaw(1.0, 20.0),
    PowerLaw(1.0, 1.5) + _CAPS[0],
    _CAPS[2] + _CAPS[1] + PowerLaw(2.0, 1.0),
    PowerLaw(1.0, 1.0) + SaturatingForce(),
    SaturatingForce(2.0, 3e-3) + _CAPS[3],
    SumPotential(PowerLaw(1.0, 1.0), SumPotential(PowerLaw(2.0, 2.0), PowerLaw(3.0, 3.0))),
]
_OTHERS = [_Spy(1.0, 1.5), _Harder(0.015, 0.008, 0.008, 1e8, 0.5), PowerLaw(1.0, 1.0) + _Spy(1, 2)]
FAMILY_POTENTIALS = _POWERS + _CAPS + _SATS + _SUMS + _OTHERS


def _expressions():
    return [
        Expression("q**2.5/2.5"),
        Expression("k*q**3/3 + q**2/2", k=2.0),
        Expression("pi*q**2 + 0.1*q**3.37"),
        Expression("sqrt(q)"),
        Expression("q**2*(1 + q)**3"),
        Expression("q**2 - q**3/10"),
        Expression("q - atan(q)"),  # cancels in float64: no table
        Expression("exp(q) - 1 - q"),  # cancels
        Expression("q**2*exp(q)"),  # not a sum of powers
    ]


def _same(a, b) -> bool:
    """Both None, or arrays equal bit for bit (dtype, shape, bytes)."""
    if a is None or b is None:
        return a is None and b is None
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("pot", FAMILY_POTENTIALS, ids=repr)
def test_adapters_are_bit_identical_to_the_old_tables(pot):
    """Power laws, caps, the saturating force, sums (nested too) and subclasses: both
    kernels get the arrays the old family checks gave, bit for bit."""
    old_e = _old_exact_rows(pot)
    new_e = exact_rows(pot)
    assert_true(
        _same(
            None if old_e is None else np.array(old_e, float),
            None if new_e is None else np.array(new_e, float),
        ),
        got=repr(new_e),
        should=repr(old_e),
        claim="tool",
        call=f"exact _term_rows({pot!r})",
    )
    old_v, new_v = _old_kernel_terms(pot), kernel_terms(pot)
    if isinstance(pot, SumPotential) and any(isinstance(t, SumPotential) for t in pot.terms):
        # A nested sum (built with SumPotential(...), `+` flattens) had no Verlet arrays
        # (one level only); the table concatenates recursively, as the exact side did.
        assert_true(
            old_v is None and new_v is not None,
            got=repr(new_v),
            should="arrays",
            claim="tool",
            call="nested sum",
        )
        flat = SumPotential(*pot.terms[:1], *pot.terms[1].terms)
        old_v = _old_kernel_terms(flat)
    ok = (old_v is None and new_v is None) or (
        old_v is not None
        and new_v is not None
        and _same(old_v[0], new_v[0])
        and _same(old_v[1], new_v[1])
    )
    assert_true(
        ok, got=repr(new_v), should=repr(old_v), claim="tool", call=f"kernel_terms({pot!r})"
    )


def test_expression_exact_rows_are_unchanged():
    """The exact side's reading of sums of powers (moved into Expression) gives the
    same rows as before, and none for cancelling or non-power forms."""
    for pot in _expressions():
        old, new = _old_exact_rows(pot), exact_rows(pot)
        assert_true(
            _same(
                None if old is None else np.array(old, float),
                None if new is None else np.array(new, float),
            ),
            got=repr(new),
            should=repr(old),
            claim="tool",
            call=f"exact _term_rows({pot!r})",
        )


def test_substitution_exponents_are_unchanged():
    """The exact solver's exponents for its Gauss-Jacobi substitution now come from the
    table for non-expression families: the same numbers as the old family checks."""
    pots = FAMILY_POTENTIALS + _expressions() + [PowerLaw(1.0, 1.5) + Expression("q**3")]
    for pot in pots:
        old, new = _old_term_exponents(pot), _term_exponents(pot)
        assert_true(
            _same(old, new),
            got=repr(new),
            should=repr(old),
            claim="tool",
            call=f"_term_exponents({pot!r})",
        )


@pytest.mark.parametrize(
    "source, params, law",
    [
        ("q**2.5/2.5", {}, PowerLaw(1.0, 1.5)),
        # (q**2.37 has no table: its float exponent is off the exact 237/100 by an ulp,
        # which |log q| amplifies past 1e-14 below q = 1e-40 m: float_formula_accurate
        # is False, as it is for its lambdified kernels.)
        ("k*q**2.25/2.25", {"k": 3.3}, PowerLaw(3.3, 1.25)),
        ("k*q**2/2", {"k": 1e6}, PowerLaw(1e6, 1.0)),
    ],
)
def test_power_expression_has_the_power_laws_verlet_arrays(source, params, law):
    """New: an expression that is a sum of powers has Verlet arrays, and for the law of
    a PowerLaw they are that PowerLaw's, bit for bit (p is rounded once from the exact
    exponent, as PowerLaw's p is the float the user wrote)."""
    expr = Expression(source, **params)
    got, want = kernel_terms(expr), kernel_terms(law)
    assert_true(
        got is not None and _same(got[0], want[0]) and _same(got[1], want[1]),
        got=repr(got),
        should=repr(want),
        claim="tool",
        call=f"kernel_terms({expr!r})",
    )


def test_cancelling_expression_has_no_table():
    """A formula that cancels in float64 must not be compiled from its terms."""
    for source in ("q - atan(q)", "exp(q) - 1 - q", "1 - cos(q)"):
        pot = Expression(source)
        assert_true(
            not pot.float_formula_accurate and term_rows(pot) is None and kernel_terms(pot) is None,
            got=repr(term_rows(pot)),
            should="None (float_formula_accurate is False)",
            claim="tool",
            call=f"term_rows({source})",
        )
    both = PowerLaw(1.0, 1.0) + Expression("q - atan(q)")
    assert_true(
        term_rows(both) is None,
        got=repr(term_rows(both)),
        should="None",
        claim="tool",
        call="sum with a cancelling term",
    )


def test_expanded_terms_of_both_signs_get_no_table():
    """The table sums the expanded terms, not the formula float_formula_accurate checked:
    an expansion with terms of both signs may cancel, so it gets no table; positive
    expanded terms, and mixed signs the user wrote as the sum, keep theirs."""
    pot = Expression("q**2 + q**2*(1-q)**40")
    assert _old_expression_power_rows(pot) is not None  # the exact side used to read rows
    # The cancellation, in exact rational arithmetic (independent of the order in which a
    # sympy version lists the terms, and of any float summation): at q = 3/2 the expanded
    # terms reach 2.25 x 2.5^40 = 1.9e16 in magnitude for a value U = 2.25, so one rounding
    # (unit 2^-53) of a partial sum of that size is already ~2, i.e. ~90 % of U.
    q = pot.sympy_symbol
    terms = [t.subs(q, sp.Rational(3, 2)) for t in sp.Add.make_args(sp.expand(pot.sympy_U))]
    magnitude, value = sum(abs(t) for t in terms), sum(terms)
    rounding = magnitude * sp.Rational(1, 2**53)
    assert_true(
        pot.float_formula_accurate and rounding > sp.Rational(1, 10) * abs(value),
        got=f"terms up to {float(magnitude):.3g} in sum, U(1.5) = {float(value)!r}",
        should="one rounding of the expanded sum > 10 % of U (else this test shows nothing)",
        claim="tool",
        call="expanded terms of q**2 + q**2*(1-q)**40 at q = 1.5",
    )
    for p in (pot, PowerLaw(1.0, 1.0) + pot):
        assert_true(
            term_rows(p) is None and kernel_terms(p) is None and exact_rows(p) is None,
            got=repr(term_rows(p)),
            should="None",
            claim="tool",
            call=f"term_rows({p!r})",
        )
    for source in ("q**2*(1 + q)**3", "q**2 - q**3/10"):
        assert_true(
            term_rows(Expression(source)) is not None,
            got="None",
            should="a table",
            claim="tool",
            call=f"term_rows({source})",
        )


def test_subclasses_inherit_no_table_unless_they_opt_in():
    """A table counts only from the class's own body (the old `type(t) is X` guard)."""
    for pot in (_Spy(1.0, 1.5), _Harder(0.015, 0.008, 0.008, 1e8, 0.5)):
        assert_true(
            term_rows(pot) is None,
            got=repr(term_rows(pot)),
            should="None",
            claim="tool",
            call=f"term_rows({type(pot).__name__})",
        )
    kept = term_rows(_KeptLaw(2.0, 1.5))
    assert_true(
        kept == term_rows(PowerLaw(2.0, 1.5)),
        got=repr(kept),
        should=repr(term_rows(PowerLaw(2.0, 1.5))),
        claim="tool",
        call="term_rows(opted-in subclass)",
    )


def test_a_bad_hook_is_reported():
    """A family whose hook returns something that is not a table is refused by name."""

    class _Bad(PowerLaw):
        def _term_rows(self):
            return [(TERM_POWER, self.k, math.nan, self.p, 0.0)]

    class _Short(PowerLaw):
        def _term_rows(self):
            return [(7.0, 1.0)]

    class _Empty(PowerLaw):
        def _term_rows(self):
            return []

    for cls in (_Bad, _Short, _Empty):
        with pytest.raises(HCVInputError, match=cls.__name__):
            term_rows(cls(1.0, 1.0))
    assert power_row(2, 2.5, 1.5) == (TERM_POWER, 2.0, 2.5, 1.5, 0.0)


@pytest.mark.parametrize("scene", [SCENE_WALLS, SCENE_IMPACT])
def test_power_expression_lanes_equal_the_power_law(scene):
    """q**2.5/2.5 runs in the compiled power-law lane kernel, lane for lane identical to
    PowerLaw(1, 1.5), even for a short batch (no compile of its own)."""
    dt = np.array([0.2, 0.6, 1.0, 1.2, 1.4, 2.5])
    b = LaneBatch(
        dt=dt,
        y0=0.0,
        v0=1.0,
        gap=0.0,
        e_limit=50.0,
        max_steps=2_000,
        e_confirm=5e5,
        confirm_steps=4_000,
    )
    a = run_lanes(PowerLaw(1.0, 1.5), 1.0, scene, b)
    n = run_lanes(Expression("q**2.5/2.5"), 1.0, scene, b)
    same = (
        n.engine == "numba"
        and list(a.status) == list(n.status)
        and list(a.steps) == list(n.steps)
        and _same(a.e_max, n.e_max)
        and _same(a.e_end, n.e_end)
    )
    assert_true(
        same,
        got=f"{n.engine} {n.e_max}",
        should=f"numba {a.e_max}",
        claim="tool",
        call="run_lanes(q**2.5/2.5)",
    )
