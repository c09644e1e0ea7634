"""Issue 22, wrong numbers: the exact solver against truths that share none of its code.

Truths come from `verification._independent_truth` (the classical energy integral
in mpmath, no virtual time, no solver quadrature or inverse). Each result must be
within 1e-12 of the truth and within its own reported bound, or be refused in one
line (`UnsupportedError`, naming the bound). The damped cases (the split quadrature,
the overdamped tail) are checked against the project's mpmath solver instead, whose
quadratures and inverse run at 20-30 digits apart from the float code.
"""

from __future__ import annotations

import functools
import itertools

import mpmath
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from reference_impl import Expression, PowerLaw, SumPotential, UnsupportedError, solve_impact
from reference_impl.exact.solve import RTOL_STATED, solve_impact_mp
from verification._independent_truth import contact_time_undamped, power_sum, turning_point
from verification.strategies import far_apart_sum_terms, log_uniform, masses, speeds

# Digits of the truths: the energy integral is evaluated at twice this internally
# (see contact_time_undamped), which leaves ~1e-19 relative error at 20 digits,
# far below the 1e-12 asked and the solver's ~1e-14 bounds.
_TRUTH_DPS = 20
# Accuracy asked of every contact time by issue 22 (the solver's stated accuracy).
_RTOL = 1e-12

# The scan of issue 22: U' = c q^p1 + q^p2 (m = 1, zeta = 0); 3 x 3 x 4 x 4 = 144 cases.
_P1 = (0.01, 0.5, 1.5)
_P2 = (5.0, 12.0, 20.0)
_C = (1e-12, 1e-6, 1.0, 1e6)
_V0 = (0.01, 1.0, 10.0, 100.0)
SCAN = list(itertools.product(_P1, _P2, _C, _V0))


@functools.cache
def sum_truth(terms: tuple, m: float, v0: float) -> float:
    """Undamped contact time of U' = sum k q^p (terms ((k, p), ...)), independent mpmath."""
    with mpmath.workdps(_TRUTH_DPS):
        U, cross = power_sum(terms)
        E = mpmath.mpf(m) * mpmath.mpf(v0) ** 2 / 2
        # Each term alone reaches E at q_i; the sum reaches it first, below min q_i.
        q_hi = min((E * (p + 1) / mpmath.mpf(k)) ** (1 / mpmath.mpf(p + 1)) for k, p in terms)
        q_max = turning_point(U, E, q_hi * (1 + mpmath.mpf(10) ** -12))
        return float(contact_time_undamped(U, m, q_max, cross))


def _check(pot, m, v0, truth, label):
    try:
        sol = solve_impact(pot, m, v0)
    except UnsupportedError as exc:  # refused in one line, naming the bound
        msg = str(exc)
        assert "\n" not in msg and "error bound" in msg, (
            f"got refusal {msg!r}, should be one line naming the bound [{label}]"
        )
        return
    err = abs(sol.contact_time - truth)
    assert err <= _RTOL * truth, (
        f"got t_c = {sol.contact_time!r}, should be {truth!r} within {_RTOL:g} "
        f"(error {err / truth:.2e}) [issue 22, {label}]"
    )
    assert err <= sol.quadrature_error, (
        f"got error {err:.3g} s above its reported bound {sol.quadrature_error:.3g} s [issue 22, {label}]"
    )
    assert sol.quadrature_error <= RTOL_STATED * sol.contact_time


@pytest.mark.parametrize("p1,p2,c,v0", SCAN)
def test_sum_scan_contact_time(p1, p2, c, v0):
    """Issue 22 item 1: 144 sums whose exponents are far apart."""
    truth = sum_truth(((c, p1), (1.0, p2)), 1.0, v0)
    _check(
        PowerLaw(c, p1) + PowerLaw(1.0, p2), 1.0, v0, truth, f"sum c={c:g} p1={p1} p2={p2} v0={v0}"
    )


def test_issue_example_and_its_expression_form():
    """U' = 1e-12 q^0.01 + q^20, m = 1, v0 = 100: t_c = 0.036922299686136 s (was 6.4 % off)."""
    truth = sum_truth(((1e-12, 0.01), (1.0, 20.0)), 1.0, 100.0)
    assert abs(truth - 0.036922299686136) < 1e-14, f"got truth {truth!r}, should be the issue's"
    _check(PowerLaw(1e-12, 0.01) + PowerLaw(1.0, 20.0), 1.0, 100.0, truth, "issue example")
    expr = Expression("c*q**1.01/1.01 + q**21/21", c=1e-12)
    _check(expr, 1.0, 100.0, truth, "issue example, expression form")


@pytest.mark.parametrize("p1,p2,c,v0", [(0.5, 12.0, 1e-6, 10.0), (1.5, 5.0, 1e-12, 100.0)])
def test_sum_scan_expression_form(p1, p2, c, v0):
    """The expression form of the scan's law gives the same answers."""
    truth = sum_truth(((c, p1), (1.0, p2)), 1.0, v0)
    expr = Expression("c*q**(a+1)/(a+1) + q**(b+1)/(b+1)", c=c, a=p1, b=p2)
    _check(expr, 1.0, v0, truth, f"expression c={c:g} p1={p1} p2={p2} v0={v0}")


@settings(deadline=None)
@given(far_apart_sum_terms())
def test_bound_covers_true_error_for_random_sums(case):
    """Issue 22: sums with exponents 0.01-20 and coefficients 1e-12-1e12; the reported
    bound covers the true error in every draw (or the case is refused in one line)."""
    terms, v0 = case
    pot = SumPotential(*(PowerLaw(k, p) for k, p in terms))
    truth = sum_truth(terms, 1.0, v0)
    _check(pot, 1.0, v0, truth, f"sum {terms}, v0={v0}")


# Potentials that rise from 0 up to a pole or a maximum (issue 22, items 2-3), with
# the turning point in closed form (E = m v0^2 / 2) and U in mpmath for the truth.
_POLES = {
    "tan(q)": (mpmath.tan, lambda E: mpmath.atan(E)),
    "q**2/(1-q)": (lambda q: q**2 / (1 - q), lambda E: (-E + mpmath.sqrt(E * E + 4 * E)) / 2),
    "-log(cos(q))": (lambda q: -mpmath.log(mpmath.cos(q)), lambda E: mpmath.acos(mpmath.exp(-E))),
    "1/cos(q) - 1": (lambda q: 1 / mpmath.cos(q) - 1, lambda E: mpmath.acos(1 / (1 + E))),
    "1 - cos(q)": (lambda q: 1 - mpmath.cos(q), lambda E: mpmath.acos(1 - E)),
}
POLE_CASES = [("tan(q)", v0) for v0 in (2.0, 3.0, 5.0, 10.0)] + [
    (src, 1.99) for src in _POLES if src != "tan(q)"
]


@functools.cache
def pole_truth(src: str, v0: float) -> tuple[float, float]:
    """(q_max, t_c) of U = src, m = 1, zeta = 0, from the closed-form turning point."""
    U, q_of_E = _POLES[src]
    with mpmath.workdps(_TRUTH_DPS):
        q_max = q_of_E(mpmath.mpf(v0) ** 2 / 2)
        return float(q_max), float(contact_time_undamped(U, 1.0, q_max))


@pytest.mark.parametrize("src,v0", POLE_CASES)
def test_turning_point_on_the_rising_interval(src, v0):
    """Issue 22 items 2-3: the turning point lies where U rises from 0 (tan(q), v0 = 3:
    q_max = atan(4.5), not the root 4.49 m on the next branch), and potentials that
    rise only up to a pole or a maximum past q_max are solved, not refused."""
    q_true, t_true = pole_truth(src, v0)
    pot = Expression(src)
    q_tp = pot.turning_point(0.5 * v0 * v0)
    # The inverse is a root finder to a few ulps of q (_INVERSE_XRTOL = 4 eps).
    assert abs(q_tp - q_true) <= 1e-14 * q_true, (
        f"got q_max = {q_tp!r}, should be {q_true!r} [issue 22, Expression({src!r}).turning_point]"
    )
    sol = solve_impact(pot, 1.0, v0)
    assert abs(sol.max_penetration - q_true) <= 1e-14 * q_true, (
        f"got q_max = {sol.max_penetration!r}, should be {q_true!r} [issue 22, solve_impact {src}]"
    )
    _check(pot, 1.0, v0, t_true, f"{src}, v0 = {v0}")


@pytest.mark.parametrize("src,v0", [("1 - cos(q)", 2.01), ("sin(q)", 1.5), ("q**2*exp(-q)", 1.2)])
def test_no_turning_point_on_the_rising_interval_is_refused(src, v0):
    """U that stops rising (a maximum) below the energy is refused in one line naming
    where, never solved on a later branch."""
    from reference_impl import HCVInputError

    with pytest.raises(HCVInputError) as info:
        solve_impact(Expression(src), 1.0, v0)
    assert "\n" not in str(info.value) and "q =" in str(info.value), str(info.value)


@pytest.mark.parametrize("gap", [1e-2, 1e-3, 1e-11])
def test_cap_near_full_overlap_bound_includes_conditioning(gap):
    """Issue 22 item 4: a sphere cap driven to v0 = v_max (1 - gap) (U' -> 0 at full
    overlap) is ill-conditioned; the bound includes the condition number times U's
    rounding, so it covers the true error (gap = 1e-11: error 1.9e-6 against a bound
    of 1.4e-9 before), or the result is refused naming the bound."""
    from reference_impl import Sphere

    pot, m = Sphere(0.01, 1e8, 0.5), 0.05
    u_max = float(pot.U(pot.q_sup))
    v0 = (2.0 * u_max / m) ** 0.5 * (1.0 - gap)
    with mpmath.workdps(_TRUTH_DPS + 10):
        # The float v0 is the input: the truth is for exactly that number. U in mpmath
        # through the potential's own formula (the solver's quadrature is not used).
        E = mpmath.mpf(m) * mpmath.mpf(v0) ** 2 / 2
        q_max = turning_point(pot._U, E, mpmath.mpf(pot.q_sup))
        truth = float(contact_time_undamped(pot._U, m, q_max))
    try:
        sol = solve_impact(pot, m, v0)
    except UnsupportedError as exc:
        assert gap < 1e-2 and "error bound" in str(exc), str(exc)
        return
    err = abs(sol.contact_time - truth)
    assert err <= sol.quadrature_error, (
        f"got error {err:.3g} s above the bound {sol.quadrature_error:.3g} s [issue 22, cap gap {gap:g}]"
    )


@pytest.mark.parametrize(
    "c,p1,p2,v0,zeta",
    [(1e-6, 0.5, 12.0, 10.0, 0.5), (1.0, 0.5, 3.0, 10.0, 0.95), (1e-3, 1.0, 4.0, 3.0, 0.1)],
)
def test_damped_sums_split_quadrature(c, p1, p2, v0, zeta):
    """Damped sums whose terms hand over deep in the contact (the split path) against
    the project's separate mpmath solver (tanh-sinh at 20 digits, where it converges):
    both ends of contact within 1e-12 and within their bounds."""
    pot = PowerLaw(c, p1) + PowerLaw(1.0, p2)
    sol = solve_impact(pot, 1.0, v0, zeta)
    mp = solve_impact_mp(pot, 1.0, v0, zeta, dps=20)
    for key, bound in (
        ("contact_time", "quadrature_error"),
        ("contact_time_zero_force", "quadrature_error_zero_force"),
    ):
        got, truth = getattr(sol, key), float(mp[key])
        err = abs(got - truth)
        assert err <= min(_RTOL * truth, getattr(sol, bound)), (
            f"got {key} = {got!r}, should be {truth!r} (error {err:.2g}, bound "
            f"{getattr(sol, bound):.2g}) [issue 22, damped sum zeta = {zeta}]"
        )


def test_split_refuses_damping_beyond_its_checked_range():
    from reference_impl.exact._split import SPLIT_ZETA_MAX

    with pytest.raises(UnsupportedError, match="zeta"):
        solve_impact(PowerLaw(1e-12, 0.01) + PowerLaw(1.0, 20.0), 1.0, 100.0, SPLIT_ZETA_MAX + 0.01)


# -- the overdamped tail (zeta >= 1, n < 2): dq/dx ~ x^beta decays like exp(-beta s) --------

# U' = 100 q + 100 q^p2, m = v0 = zeta = 1: (contact_time, contact_time_zero_force) from
# solve_impact_mp at 30 digits. p2 = 0.9375 was returned 3.2e-10 off under a bound of
# 2.8e-13 (the leading law below x = 1e-100 v0, uncharged, and scipy.quad's estimate).
_TAIL_TRUTHS = {
    0.875: (1.3635056875163323, 0.12482625963230168),
    0.9375: (2.8262925741622347, 0.13345313208042345),
    0.96875: (5.697026685178434, 0.13752009448237779),
    0.99: (17.764568856911204, 0.1401909886274177),
}
# Examples of the property below: each needs an mpmath truth of 1-4 s (measured, busy
# machine).
_TAIL_EXAMPLES = 6


def _tail_check(pot, m, v0, zeta, truths) -> bool:
    """Both times within their own bounds of the truths (a callable giving
    (contact_time, contact_time_zero_force)), or refused in one line naming the bound;
    True when returned."""
    call = f"solve_impact({pot!r}, {m!r}, {v0!r}, {zeta!r})"
    try:
        sol = solve_impact(pot, m, v0, zeta)
    except UnsupportedError as exc:
        msg = str(exc)
        assert "\n" not in msg and "error bound" in msg, f"got refusal {msg!r} [{call}]"
        return False
    for got, bound, truth in zip(
        (sol.contact_time, sol.contact_time_zero_force),
        (sol.quadrature_error, sol.quadrature_error_zero_force),
        truths(),
        strict=True,
    ):
        err = float(abs(mpmath.mpf(got) - truth))
        assert err <= bound, (
            f"got {got!r}, should be {mpmath.nstr(truth, 17)} within its bound {bound:.3g} "
            f"(error {err:.3g}) [{call}]"
        )
        assert bound <= RTOL_STATED * got, f"bound {bound:.3g} above the stated accuracy [{call}]"
    return True


@pytest.mark.parametrize("p2", sorted(_TAIL_TRUTHS))
def test_overdamped_tail_close_exponents(p2):
    """zeta = 1, n = 1 + p2 close to the next exponent 2. The power sum is solved
    within its bound (below float64's range its dq/dx is the leading law times its
    exact correction, in logarithms); the same law as an expression is within its
    bound or refused (there the leading law alone stands in, its deviation charged:
    0.96875 and 0.99 are refused)."""

    def truths():
        return _TAIL_TRUTHS[p2]

    pot = PowerLaw(100.0, 1.0) + PowerLaw(100.0, p2)
    assert _tail_check(pot, 1.0, 1.0, 1.0, truths), f"p2 = {p2}: refused, should be solved"
    n2 = p2 + 1.0
    expr = Expression(f"50*q**2 + 100*q**{n2!r}/{n2!r}")
    assert _tail_check(expr, 1.0, 1.0, 1.0, truths) or p2 > 0.95, f"{expr!r}: refused"


@st.composite
def close_power_sums(draw):
    """U' = k1 q^(n-1) + k2 q^(n2-1), 1 < n < n2 <= 2, the gap n2 - n a log-uniform
    fraction (1e-3 to 1) of 2 - n."""
    n = draw(st.floats(1.02, 1.98))
    n2 = min(2.0, n + (2.0 - n) * draw(log_uniform(1e-3, 1.0)))
    k1, k2 = draw(log_uniform(1e2, 1e8)), draw(log_uniform(1e2, 1e8))
    return PowerLaw(k1, n - 1.0) + PowerLaw(k2, n2 - 1.0)


@pytest.mark.mpmath
@settings(max_examples=_TAIL_EXAMPLES, deadline=None)
@given(
    pot=close_power_sums(),
    m=masses(),
    v0=speeds(),
    zeta=st.one_of(st.just(1.0), st.floats(1.0, 50.0)),
)
def test_overdamped_tail_within_bound_or_refused(pot, m, v0, zeta):
    """Sums of two powers with close exponents below 2, zeta >= 1: every returned
    contact time is within its own bound of the mpmath truth, or it is refused
    (in one line naming the bound)."""

    def truths():
        mp = solve_impact_mp(pot, m, v0, zeta, dps=20)
        return mp["contact_time"], mp["contact_time_zero_force"]

    _tail_check(pot, m, v0, zeta, truths)
