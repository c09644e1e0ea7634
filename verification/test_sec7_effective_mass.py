"""Section 7: the point-canonical lift x = f(q), P = p / f'(q) and its effective mass.

What is identity and what is content:

* H(x, P) = P^2 / (2 M_eff) + K x^2 / 2 with M_eff = m / f'^2 equals the
  physical p^2/(2m) + U(q) *identically* at every state. Comparing the two at
  the same state (`test_lifted_hamiltonian_equals_physical_at_each_state`) tests
  only the implementation (HarmonicMap.effective_mass, its inverse q(x));
  comparing with the impact energy along a trajectory adds only the integrator.
* The content of section 7 is that H(x, P) *generates* the contact dynamics
  (the lift is canonical): `test_lifted_hamiltonian_generates_the_dynamics`
  integrates Hamilton's equations in (x, P) on their own and compares x(t) with
  x(q(t)) of the physical integration; a constant-mass oscillator (the lift
  without the position dependence) fails the same comparison.
* M_eff is constant iff U ~ q^2: for a power law M_eff ~ x^(2(1-p)/(p+1)),
  which is measured as a log-log slope.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from reference_impl import Ellipsoid, HarmonicMap, PowerLaw, Sphere
from reference_impl.claims import sec7_effective_mass
from reference_impl.claims._tolerances import IDENTITY_RTOL, MP_DERIV_DPS, ODE_RTOL, SLOPE_TOL
from reference_impl.integrators.ivp import integrate_impact
from verification.assertions import assert_close, assert_true, check_measurement
from verification.strategies import impacts, log_uniform, masses, power_laws, reference_constants

_ODE_RTOL = ODE_RTOL  # shared: reference_impl/claims/_tolerances.py
# Two independent ODE solutions (physical and (x, P)) compared at the same times:
# each carries ~1e-10 global error, x amplifies q errors by n/2 <= 3: 1e-8 of x_max.
_TWO_ODES_TOL = 1e-8
_IDENTITY_RTOL = IDENTITY_RTOL  # shared: reference_impl/claims/_tolerances.py
# Energy along the ODE path (integrator only): global error ~1e-10 in q and v.
_ENERGY_RTOL = 1e-9
_MP_DPS = MP_DERIV_DPS  # shared: reference_impl/claims/_tolerances.py
# Relative central-difference step for dx/dq at _MP_DPS digits (see MP_DERIV_DPS).
_MP_REL_STEP = mpmath.mpf("1e-15")
_SLOPE_ATOL = SLOPE_TOL  # shared: reference_impl/claims/_tolerances.py
# A relative variation of M_eff is "measurable" above 1e3 times the identity
# tolerance.
_MEASURABLE = 1e3 * _IDENTITY_RTOL
# Fraction of the outgoing half-contact integrated in (x, P): stays away from
# x = 0, where M_eff is 0 or infinite (n < 2 or n > 2) and the lifted equations
# are singular.
_OUT_FRACTION = 0.9


def _lifted_state(hmap: HarmonicMap, q: np.ndarray, v: np.ndarray):
    """(x, P) of physical states (q > 0): P = m v / f'(q)."""
    return hmap.x(q), hmap.m * v / hmap.dxdq(q)


def _lifted_H(hmap: HarmonicMap, x: np.ndarray, P: np.ndarray) -> np.ndarray:
    """H(x, P) = P^2 / (2 M_eff(x)) + K x^2 / 2 (J) with HarmonicMap.effective_mass."""
    return P**2 / (2.0 * hmap.effective_mass(x)) + 0.5 * hmap.K * x**2


def _meff_and_slope(hmap: HarmonicMap, x: float) -> tuple[float, float]:
    """M_eff(x) = 2 m K U / U'^2 and dM_eff/dx = 2 m K (U'^2 - 2 U U'') / U'^3 * dq/dx."""
    pot = hmap.potential
    q = float(hmap.q_of_x(x))
    U, dU, d2U = float(pot.U(q)), float(pot.dU(q)), float(pot.d2U(q))
    meff = 2.0 * hmap.m * hmap.K * U / dU**2
    dmeff_dq = 2.0 * hmap.m * hmap.K * (dU**2 - 2.0 * U * d2U) / dU**3
    return meff, dmeff_dq * math.sqrt(2.0 * hmap.K * U) / dU


def _integrate_lifted(hmap: HarmonicMap, x0: float, P0: float, t_span, t_eval, *, mass=None):
    """Hamilton's equations of H(x, P); ``mass`` replaces M_eff(x) by a constant."""

    def rhs(t, y):
        x, P = y
        if mass is not None:
            return [P / mass, -hmap.K * x]
        meff, slope = _meff_and_slope(hmap, x)
        return [P / meff, 0.5 * P * P * slope / meff**2 - hmap.K * x]

    scale = np.array([x0, math.sqrt(hmap.K * hmap.m) * x0])
    res = solve_ivp(
        rhs,
        t_span,
        [x0, P0],
        method="DOP853",
        rtol=_ODE_RTOL,
        atol=_ODE_RTOL * scale,
        t_eval=t_eval,
    )
    assert res.success, res.message
    return res.y[0]


@pytest.mark.claim("sec7-effective-mass")
@given(case=impacts(), km=reference_constants())
def test_lifted_hamiltonian_equals_physical_at_each_state(case, km):
    """IMPLEMENTATION/INTEGRATOR CHECK: H(x, P) = p^2/2m + U at each state, = m v0^2/2 on the path.

    Algebraically an identity (M_eff = m / f'^2); a wrong section 7 dynamics
    would pass it. It checks effective_mass and q_of_x, and the ODE's energy.
    """
    pot, m, v0 = case
    hmap = HarmonicMap(pot, m, *km)
    res = integrate_impact(pot, m, v0, rtol=_ODE_RTOL)
    inside = res.q > 0
    q, v = res.q[inside], res.v[inside]
    x, P = _lifted_state(hmap, q, v)
    H_xP = _lifted_H(hmap, x, P)
    H_qp = 0.5 * m * v**2 + pot.U(q)
    assert_close(
        H_xP,
        H_qp,
        rtol=_IDENTITY_RTOL,
        claim="sec7-effective-mass",
        call=f"H(x, P) vs H(q, p) on integrate_impact({pot!r}, m={m!r}, v0={v0!r})",
    )
    assert_close(
        H_xP,
        0.5 * m * v0 * v0,
        rtol=_ENERGY_RTOL,
        claim="sec7-effective-mass",
        call=f"H(x, P) vs m v0^2/2 along the path of {pot!r}",
    )


@pytest.mark.claim("sec7-effective-mass")
@pytest.mark.parametrize(
    "pot",
    [
        PowerLaw(1e6, 1.5),
        PowerLaw(1e3, 0.5),
        PowerLaw(1e4, 3.0),
        PowerLaw(1e4, 1.0) + PowerLaw(1e6, 2.0),
        Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5),
    ],
    ids=["hertz", "p=0.5", "p=3", "q^2+q^3", "paper-ellipsoid"],
)
def test_lifted_hamiltonian_generates_the_dynamics(pot):
    """Hamilton's equations of H(x, P), integrated alone, reproduce x(q(t)) of the physical ODE.

    Start at maximum penetration (x_max, P = 0) and follow 90 % of the outgoing
    half. The same run with M_eff frozen at M_eff(x_max) must deviate
    measurably (it is harmonic in physical time, which the contact is not).
    """
    m, v0 = 0.05, 1.0
    hmap = HarmonicMap(pot, m, K=2.0, M=0.3)
    phys = integrate_impact(pot, m, v0, rtol=_ODE_RTOL, dense_output=True)
    t0 = phys.t_q_max
    t1 = t0 + _OUT_FRACTION * (phys.contact_time - t0)
    t = np.linspace(t0, t1, 60)
    x_phys = hmap.x(phys.sol(t)[0])
    x_max = float(hmap.x(phys.q_max))
    x_lift = _integrate_lifted(hmap, x_max, 0.0, (t0, t1), t)
    assert_close(
        x_lift,
        x_phys,
        rtol=0.0,
        atol=_TWO_ODES_TOL * x_max,
        claim="sec7-effective-mass",
        call=f"Hamilton's equations of H(x, P) vs physical ODE for {pot!r}",
    )
    x_const = _integrate_lifted(hmap, x_max, 0.0, (t0, t1), t, mass=_meff_and_slope(hmap, x_max)[0])
    dev = np.max(np.abs(x_const - x_phys)) / x_max
    assert_true(
        dev > 1e3 * _TWO_ODES_TOL,
        got=f"constant-mass deviation {dev:.3g}",
        should=f"> {1e3 * _TWO_ODES_TOL:.0e} (M_eff must vary)",
        claim="sec7-effective-mass",
        call=f"frozen M_eff for {pot!r}",
    )


@pytest.mark.claim("sec7-effective-mass")
@given(
    case=impacts(),
    km=reference_constants(),
    s=st.lists(st.floats(1e-4, 1.0), min_size=3, max_size=6),
)
def test_effective_mass_is_m_over_dxdq_squared(case, km, s):
    """effective_mass(x) = 2 m K U/U'^2 equals m/(dx/dq)^2, dx/dq differentiated numerically."""
    pot, m, v0 = case
    hmap = HarmonicMap(pot, m, *km)
    q_max = pot.turning_point(0.5 * m * v0 * v0)
    x = hmap.x(q_max * np.asarray(s))
    q = hmap.q_of_x(x)
    got = hmap.effective_mass(x)
    with mpmath.workdps(_MP_DPS):
        dxdq = [
            mpmath.diff(hmap.x, mpmath.mpf(float(qi)), h=_MP_REL_STEP * mpmath.mpf(float(qi)))
            for qi in q
        ]
        ref = np.array([float(m / d**2) for d in dxdq])
    assert_close(
        got,
        ref,
        rtol=_IDENTITY_RTOL,
        claim="sec7-effective-mass",
        call=f"HarmonicMap({pot!r}, m={m!r}, K, M={km!r}).effective_mass",
    )


@pytest.mark.claim("sec7-effective-mass")
@given(
    k=log_uniform(1e2, 1e10),
    k2=log_uniform(1e2, 1e10),
    m=masses(),
    km=reference_constants(),
    two_terms=st.booleans(),
)
def test_effective_mass_constant_for_quadratic_potential(k, k2, m, km, two_terms):
    """U ~ q^2 (p = 1, or a sum of two p = 1 terms): M_eff = m K / k_total at every x."""
    pot = PowerLaw(k, 1.0) + PowerLaw(k2, 1.0) if two_terms else PowerLaw(k, 1.0)
    k_tot = k + k2 if two_terms else k
    hmap = HarmonicMap(pot, m, *km)
    x = hmap.x(pot.q_scale * np.logspace(-6, 2, 40))
    assert_close(
        hmap.effective_mass(x),
        m * km[0] / k_tot,
        rtol=_IDENTITY_RTOL,
        claim="sec7-effective-mass",
        call=f"effective_mass for {pot!r}",
    )


@pytest.mark.claim("sec7-effective-mass")
@given(pot=power_laws(), m=masses(), km=reference_constants())
def test_effective_mass_power_law_slope(pot, m, km):
    """U = k q^(p+1)/(p+1): M_eff ~ x^(2(1-p)/(p+1)) exactly, non-constant for p != 1."""
    hmap = HarmonicMap(pot, m, *km)
    x = hmap.x(pot.q_scale * np.logspace(-3, 0, 60))
    slope, _ = np.polyfit(np.log(x), np.log(hmap.effective_mass(x)), 1)
    assert_close(
        slope,
        2.0 * (1.0 - pot.p) / (pot.p + 1.0),
        rtol=0.0,
        atol=_SLOPE_ATOL,
        claim="sec7-effective-mass",
        call=f"log-log slope of effective_mass for {pot!r}",
    )


@pytest.mark.claim("sec7-effective-mass")
@pytest.mark.parametrize(
    "pot, q_hi",
    [
        (PowerLaw(1e6, 1.5), 1e-3),
        (PowerLaw(1e4, 1.05), 1e-2),
        (Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5), 0.011),
        (Sphere(0.01, 1e8, 0.5), 0.007),
        (PowerLaw(1e4, 1.0) + PowerLaw(1e6, 2.0), 1e-1),
    ],
    ids=["hertz", "p=1.05", "paper-ellipsoid", "sphere", "q^2+q^3"],
)
def test_effective_mass_not_constant_otherwise(pot, q_hi):
    """Not U ~ q^2: M_eff varies over the contact by far more than round-off."""
    hmap = HarmonicMap(pot, 0.05, K=1.0, M=0.75)
    x = hmap.x(q_hi * np.logspace(-3, 0, 50))
    meff = hmap.effective_mass(x)
    variation = meff.max() / meff.min() - 1.0
    assert_true(
        variation > _MEASURABLE,
        got=f"max/min - 1 = {variation:.3g}",
        should=f"> {_MEASURABLE:.0e} (non-constant)",
        claim="sec7-effective-mass",
        call=f"effective_mass over x in [1e-3, 1] x({q_hi}) for {pot!r}",
    )


@pytest.mark.claim(sec7_effective_mass.ID)
def test_sec7_effective_mass_measurement():
    """The verdict the report prints for section 7, from reference_impl.claims.sec7_effective_mass."""
    check_measurement(
        sec7_effective_mass.measure(), expect="verified", call="sec7_effective_mass.measure()"
    )
