"""Section 9: the power-law family U = k q^(p+1)/(p+1) and Tsuji damping.

The ratio U'/sqrt(U) = sqrt(k (p+1)) q^((p-1)/2) is an exact power, so its
log-log slope is (p-1)/2 to round-off; the universal law of Theorem 3 is then
the Tsuji form c q^((p-1)/2) (exponent 1/4 for Hertz, p = 3/2). The dynamical
content, checked with the ODE, is that Hertz with this damping has a
restitution independent of the impact speed, while the exponents 0 (constant
C) and 1/2 (the viscoelastic Kuwabara-Kono form) do not.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from reference_impl import (
    HarmonicMap,
    PowerLaw,
    UniversalDamping,
    restitution_from_zeta,
    tsuji_coefficient,
)
from reference_impl.claims import sec9_power_law
from reference_impl.claims._tolerances import (
    E_ATOL,
    E_RTOL,
    MEASURABLE_FACTOR,
    ODE_RTOL,
    ROUNDOFF_TOL,
    SLOPE_TOL,
)
from reference_impl.integrators.ivp import integrate_impact
from verification.assertions import assert_close, assert_less, assert_true, check_measurement
from verification.strategies import log_uniform, masses, power_laws, reference_constants

_SLOPE_ATOL = SLOPE_TOL  # shared: reference_impl/claims/_tolerances.py
_ROUNDOFF_RTOL = ROUNDOFF_TOL  # shared: reference_impl/claims/_tolerances.py
_ODE_RTOL = ODE_RTOL  # shared: reference_impl/claims/_tolerances.py
_E_ATOL = E_ATOL  # shared: reference_impl/claims/_tolerances.py
_E_RTOL = E_RTOL  # shared: reference_impl/claims/_tolerances.py
_MEASURABLE_FACTOR = MEASURABLE_FACTOR  # shared: reference_impl/claims/_tolerances.py
# Hertz case: force exponent, stiffness, mass, damping ratio, speeds over 3 decades.
_HERTZ_P = 1.5
_HERTZ = PowerLaw(k=1e6, p=_HERTZ_P)
_MASS = 0.05
_ZETA = 0.3
_SPEEDS = (1e-2, 1e-1, 1.0, 10.0)


def _loglog_slope(q: np.ndarray, f: np.ndarray) -> float:
    return float(np.polyfit(np.log(q), np.log(f), 1)[0])


@pytest.mark.claim("sec9-power-law")
@given(pot=power_laws())
def test_ratio_is_power_of_q(pot):
    """U'/sqrt(U) ~ q^((p-1)/2): log-log slope over six decades of q."""
    q = pot.q_scale * np.logspace(-3, 3, 60)
    ratio = pot.dU(q) / np.sqrt(pot.U(q))
    assert_close(
        _loglog_slope(q, ratio),
        0.5 * (pot.p - 1.0),
        rtol=0.0,
        atol=_SLOPE_ATOL,
        claim="sec9-power-law",
        call=f"slope of U'/sqrt(U) for {pot!r}",
    )


@pytest.mark.claim("sec9-power-law")
@given(pot=power_laws(), m=masses(), km=reference_constants(), zeta=st.floats(0.01, 0.9))
def test_universal_law_is_tsuji_form(pot, m, km, zeta):
    """UniversalDamping.C(q) equals tsuji_coefficient's c q^((p-1)/2) for every K, M."""
    law = UniversalDamping(HarmonicMap(pot, m, *km), zeta=zeta)
    c, e = tsuji_coefficient(pot, m, zeta)
    assert_close(
        e,
        0.5 * (pot.p - 1.0),
        rtol=0.0,
        atol=0.0,
        claim="sec9-power-law",
        call=f"tsuji_coefficient({pot!r}) exponent",
    )
    q = pot.q_scale * np.logspace(-3, 3, 40)
    assert_close(
        law.C(q),
        c * q**e,
        rtol=_ROUNDOFF_RTOL,
        claim="sec9-power-law",
        call=f"UniversalDamping(HarmonicMap({pot!r}, m={m!r}, K, M={km!r}), zeta={zeta!r}).C",
    )


@pytest.mark.claim("sec9-power-law")
@given(k=log_uniform(1e2, 1e10), m=masses(), zeta=st.floats(0.01, 0.9))
def test_hertz_exponent_is_one_quarter(k, m, zeta):
    """Hertz (p = 3/2): the universal law is C ~ q^(1/4) (returned and measured exponent)."""
    pot = PowerLaw(k, _HERTZ_P)
    _, e = tsuji_coefficient(pot, m, zeta)
    assert_close(
        e, 0.25, rtol=0.0, atol=0.0, claim="sec9-power-law", call="tsuji_coefficient(Hertz)"
    )
    law = UniversalDamping(HarmonicMap(pot, m), zeta=zeta)
    q = pot.q_scale * np.logspace(-3, 3, 60)
    assert_close(
        _loglog_slope(q, law.C(q)),
        0.25,
        rtol=0.0,
        atol=_SLOPE_ATOL,
        claim="sec9-power-law",
        call=f"slope of UniversalDamping(Hertz k={k!r}).C",
    )


# A run that has not returned within the horizon counts as stuck (e = 0) only if
# the body has essentially stopped: speed below this fraction of v0 (so the true e,
# if it ever leaves, is of that order, far below every returning case's e > 0.01).
_STUCK_SPEED = 1e-3
# Horizon in units of q_max / v0: a returning Hertz contact ends within ~10 q_max / v0;
# creeping runs are cut here instead of at the default 1000.
_HORIZON = 50.0


def _restitution_or_stuck(res) -> float:
    """Restitution, or 0 when an overdamped tail creeps towards q = 0 without leaving.

    Constant C on Hertz at low speed: near q = 0 the damper dominates the
    vanishing spring force, q' ~ -k q^(3/2) / C, so q reaches 0 only as
    t -> infinity and the body leaves with zero speed.
    """
    if res.returned:
        return res.restitution
    v_end, v0 = abs(float(res.v[-1])), float(res.v[0])
    assert_true(
        v_end < _STUCK_SPEED * v0,
        got=f"no return, final speed {v_end:.3g} m/s",
        should=f"< {_STUCK_SPEED} v0 (stuck)",
        claim="sec9-power-law",
        call="integrate_impact(...).returned is False",
    )
    return 0.0


def _t_max(v0: float) -> float:
    return _HORIZON * _HERTZ.turning_point(0.5 * _MASS * v0 * v0) / v0


def _restitutions(C) -> list[float]:
    return [
        _restitution_or_stuck(
            integrate_impact(_HERTZ, _MASS, v0, C=C, rtol=_ODE_RTOL, t_max=_t_max(v0))
        )
        for v0 in _SPEEDS
    ]


@pytest.mark.claim("sec9-power-law")
def test_hertz_tsuji_restitution_independent_of_speed():
    """Hertz with c q^(1/4): restitution exp(-pi zeta/sqrt(1-zeta^2)) over three decades of v0."""
    c, e = tsuji_coefficient(_HERTZ, _MASS, _ZETA)
    es = _restitutions(lambda q: c * q**e)
    e_th = restitution_from_zeta(_ZETA)
    assert_close(
        es,
        e_th,
        rtol=_E_RTOL,
        atol=_E_ATOL,
        claim="sec9-power-law",
        call=f"integrate_impact(Hertz, Tsuji zeta={_ZETA}) at v0 = {_SPEEDS}",
    )
    assert_less(
        max(es) - min(es),
        _E_ATOL + _E_RTOL * e_th,
        claim="sec9-power-law",
        what="restitution spread",
        call=f"Hertz + Tsuji at v0 = {_SPEEDS}: {es}",
    )


@pytest.mark.claim("sec9-power-law")
@pytest.mark.parametrize("exponent", [0.0, 0.5], ids=["constant", "kuwabara-kono"])
def test_hertz_other_exponents_are_speed_dependent(exponent):
    """Contrast: C = c' q^s with s != 1/4, matched to Tsuji at the middle q_max, varies with v0."""
    c, e = tsuji_coefficient(_HERTZ, _MASS, _ZETA)
    v_mid = _SPEEDS[len(_SPEEDS) // 2]
    q_ref = _HERTZ.turning_point(0.5 * _MASS * v_mid * v_mid)
    c_s = c * q_ref ** (e - exponent)  # equal to the Tsuji law at q_ref
    es = _restitutions(lambda q: c_s * np.asarray(q, dtype=float) ** exponent)
    spread = max(es) - min(es)
    bound = _MEASURABLE_FACTOR * (_E_ATOL + _E_RTOL * max(es))
    assert_true(
        spread > bound,
        got=f"restitutions {es}",
        should=f"spread > {bound:.3g}",
        claim="sec9-power-law",
        call=f"Hertz with C ~ q^{exponent} at v0 = {_SPEEDS}",
    )


@pytest.mark.claim(sec9_power_law.ID)
def test_sec9_power_law_measurement():
    """The verdict the report prints for section 9, from reference_impl.claims.sec9_power_law."""
    check_measurement(sec9_power_law.measure(), expect="verified", call="sec9_power_law.measure()")
