"""Tool tests of the section 4 machinery: quadrature routes against closed forms and mpmath,
the Taylor ODE solver against closed forms and DOP853, input checks.

Not evidence for a claim (no claim marks): these validate the instruments that
the claim tests in test_sec4_action.py and reference_impl.claims.thm1_period use.
"""

from __future__ import annotations

import mpmath
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from reference_impl.errors import HCVInputError
from reference_impl.integrators.taylor import taylor_impact
from reference_impl.potentials import PowerLaw, Sphere, SumPotential
from reference_impl.theory import action as act
from reference_impl.theory import action_closed as closed
from verification._action_checks import (
    _CHECK_DPS,
    _DOP853_CMP_RTOL,
    _FLOAT_RTOL,
    _MP_DPS,
    _MP_RTOL,
    _PAPER_ELLIPSOID,
    _REF_DPS,
    _TAYLOR_DPS,
    _TAYLOR_RTOL,
    CLAIM,
    _assert_mp_close,
    _dop853_impact,
    _reference_overlap,
)
from verification.assertions import assert_close
from verification.strategies import (
    ellipsoids,
    log_uniform,
    masses,
    power_laws,
    spheres,
    sums,
)


@given(pot=power_laws(), m=masses(), E=log_uniform(1e-6, 1e3))
def test_float_routes_match_powerlaw_closed_forms(pot, m, E):
    pairs = [
        ("action", act.action, closed.powerlaw_action_closed),
        ("period", act.period, closed.powerlaw_period_closed),
        ("contact_duration", act.contact_duration, closed.powerlaw_contact_duration_closed),
        ("dJ_dE", act.dJ_dE, closed.powerlaw_dJ_dE_closed),
    ]
    for name, quad_fn, closed_fn in pairs:
        ref = float(closed_fn(pot, m, E, mp=True, dps=_CHECK_DPS))
        call = f"{name}({pot!r}, m={m!r}, E={E!r})"
        assert_close(quad_fn(pot, m, E), ref, rtol=_FLOAT_RTOL, claim=CLAIM, call=call)
        # The float closed form (scipy Beta) is a few ulps accurate as well.
        assert_close(
            closed_fn(pot, m, E),
            ref,
            rtol=_FLOAT_RTOL,
            claim=CLAIM,
            call=f"powerlaw_{name}_closed({pot!r}, m={m!r}, E={E!r})",
        )


@pytest.mark.mpmath
@settings(max_examples=8)  # each example runs four 25-digit quadratures (~0.3 s)
@given(pot=st.one_of(sums(), ellipsoids(), spheres()), m=masses(), frac=st.floats(0.05, 1.0))
def test_float_routes_match_mpmath_for_general_potentials(pot, m, frac):
    E = float(pot.U(frac * _reference_overlap(pot)))
    for name, fn, fn_mp in [
        ("action", act.action, act.action_mp),
        ("period", act.period, act.period_mp),
    ]:
        ref = float(fn_mp(pot, m, E, dps=_CHECK_DPS))
        assert_close(
            fn(pot, m, E),
            ref,
            rtol=_FLOAT_RTOL,
            claim=CLAIM,
            call=f"{name}({pot!r}, m={m!r}, E={E!r})",
        )


@pytest.mark.mpmath
@pytest.mark.parametrize("p", [1.0, 1.5, 2.37, 4.0])
def test_mpmath_routes_match_powerlaw_closed_forms(p):
    pot, m, E = PowerLaw(2.5e7, p), 0.03, 0.0417
    for name, fn_mp, closed_fn in [
        ("action_mp", act.action_mp, closed.powerlaw_action_closed),
        ("period_mp", act.period_mp, closed.powerlaw_period_closed),
        ("contact_duration_mp", act.contact_duration_mp, closed.powerlaw_contact_duration_closed),
        ("dJ_dE_mp", act.dJ_dE_mp, closed.powerlaw_dJ_dE_closed),
    ]:
        _assert_mp_close(
            fn_mp(pot, m, E, dps=_MP_DPS),
            closed_fn(pot, m, E, mp=True, dps=_REF_DPS),
            rtol=_MP_RTOL,
            call=f"{name}({pot!r}, m={m}, E={E}, dps={_MP_DPS})",
        )


@pytest.mark.mpmath
def test_closed_form_dJdE_is_derivative_of_closed_form_J():
    # The Beta identity (a + 1/2) B(a, 3/2) = B(a, 1/2) / 2 behind powerlaw_dJ_dE_closed,
    # checked by differentiating the closed-form J numerically.
    pot, m, E = PowerLaw(2.5e7, 2.37), 0.03, 0.0417
    with mpmath.workdps(_REF_DPS):
        Em = mpmath.mpf(E)
        # J at the (raised) precision mpmath.diff works at, so the difference quotient keeps it.
        num = mpmath.diff(
            lambda e: closed.powerlaw_action_closed(pot, m, e, mp=True, dps=mpmath.mp.dps), Em
        )
    _assert_mp_close(
        num,
        closed.powerlaw_dJ_dE_closed(pot, m, E, mp=True, dps=_REF_DPS),
        rtol=_MP_RTOL,
        call="mpmath.diff(powerlaw_action_closed)",
    )


@pytest.mark.mpmath
def test_taylor_damped_linear_matches_closed_form():
    # Check of the solver itself: m q'' + c q' + k q = 0 has the closed form
    # q = v0/wd exp(-zeta wn t) sin(wd t).
    k, m, v0, c = 1e6, 0.05, 0.7, 60.0
    res = taylor_impact(PowerLaw(k, 1.0), m, v0, c_coeff=c, c_exponent=0, dps=_TAYLOR_DPS)
    with mpmath.workdps(_REF_DPS):
        wn = mpmath.sqrt(mpmath.mpf(k) / m)
        zeta = mpmath.mpf(c) / (2 * mpmath.sqrt(mpmath.mpf(k) * m))
        wd = wn * mpmath.sqrt(1 - zeta**2)
        t_c = mpmath.pi / wd
        e = mpmath.exp(-zeta * wn * t_c)
        t_m = mpmath.atan2(mpmath.sqrt(1 - zeta**2), zeta) / wd
        q_m = mpmath.mpf(v0) / wd * mpmath.exp(-zeta * wn * t_m) * mpmath.sin(wd * t_m)
    call = f"taylor_impact(PowerLaw({k}, 1), m={m}, v0={v0}, c={c}, e=0)"
    for got, ref, what in [
        (res.contact_time, t_c, "contact_time"),
        (res.restitution, e, "restitution"),
        (res.max_penetration, q_m, "max_penetration"),
        (res.time_of_max_penetration, t_m, "time_of_max_penetration"),
    ]:
        _assert_mp_close(got, ref, rtol=_TAYLOR_RTOL, call=f"{call}.{what}")


@pytest.mark.mpmath
def test_taylor_damped_cubic_matches_dop853():
    # p = 3 with the section 9 damping exponent (p-1)/2 = 1: C(q) = c q.
    k, m, v0, c = 1e6, 0.05, 0.7, 50.0
    res = taylor_impact(PowerLaw(k, 3.0), m, v0, c_coeff=c, c_exponent=1, dps=_TAYLOR_DPS)
    t_c, e, q_m = _dop853_impact(k, 3, m, v0, c, 1)
    call = f"taylor_impact(PowerLaw({k}, 3), m={m}, v0={v0}, c={c}, e=1) vs DOP853"
    assert_close(
        float(res.contact_time), t_c, rtol=_DOP853_CMP_RTOL, claim=CLAIM, call=call + " t_c"
    )
    assert_close(float(res.restitution), e, rtol=_DOP853_CMP_RTOL, claim=CLAIM, call=call + " e")
    assert_close(
        float(res.max_penetration), q_m, rtol=_DOP853_CMP_RTOL, claim=CLAIM, call=call + " q_max"
    )


@pytest.mark.parametrize(
    "pot, c_exponent",
    [
        (PowerLaw(1e6, 1.5), 0),  # Hertz force q^1.5
        (PowerLaw(1e6, 2.0), 0.5),  # Tsuji exponent (p-1)/2 for even p
        (PowerLaw(1e6, 1.0) + PowerLaw(1e6, 2.5), 0),  # one non-analytic term
        (_PAPER_ELLIPSOID, 0),  # volumetric V^alpha S
        (Sphere(0.01, 1e9, 1.0), 0),
        (PowerLaw(1e6, 3.0), -1),  # C ~ 1/q
    ],
)
def test_taylor_refuses_non_analytic_laws(pot, c_exponent):
    with pytest.raises(HCVInputError):
        taylor_impact(pot, 0.05, 0.7, c_coeff=1.0, c_exponent=c_exponent, dps=15)


@pytest.mark.parametrize(
    "call",
    [
        lambda: act.action(PowerLaw(1e6, 1.5), 0.05, 0.0),
        lambda: act.action(PowerLaw(1e6, 1.5), 0.05, -1.0),
        lambda: act.period(PowerLaw(1e6, 1.5), 0.05, float("nan")),
        lambda: act.period(PowerLaw(1e6, 1.5), 0.05, float("inf")),
        lambda: act.contact_duration(PowerLaw(1e6, 1.5), 0.0, 1.0),
        lambda: act.dJ_dE("not a potential", 0.05, 1.0),
        lambda: act.action_mp(PowerLaw(1e6, 1.5), -0.05, 1.0),
        lambda: act.period_mp(PowerLaw(1e6, 1.5), 0.05, 1.0, dps=0),
        lambda: closed.powerlaw_action_closed(_PAPER_ELLIPSOID, 0.05, 1.0),
        lambda: act.action(_PAPER_ELLIPSOID, 0.05, 1e9),  # beyond U(2a): no turning point
        lambda: act.action(SumPotential(PowerLaw(1.0, 1.0), PowerLaw(1.0, 2.0)), True, 1.0),
    ],
)
def test_action_rejects_bad_input(call):
    with pytest.raises(HCVInputError):
        call()


def test_the_mpmath_route_is_served_under_its_own_names():
    """`action` lists and serves exactly the names `action_mp` exports (one list each side)."""
    from reference_impl.theory import action_mp

    assert set(act._MP_NAMES) == set(action_mp.__all__), (
        f"got {sorted(act._MP_NAMES)}, should be {sorted(action_mp.__all__)} "
        "[tool, theory.action.__getattr__]"
    )
    for name in action_mp.__all__:
        assert getattr(act, name) is getattr(action_mp, name), f"{name} [tool, action]"
