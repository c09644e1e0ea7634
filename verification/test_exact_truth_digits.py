"""The universal law's mpmath truth carries its 30 digits to the caller (issue 27, goal 6).

`solve_impact_mp` at 30 digits against truths that share none of its code, at 40
digits: Hooke's damped oscillator in closed form (the universal law on U = k q^2/2
is a linear dashpot 2 zeta sqrt(m k)), and Hertz's undamped contact time and
turning point from the classical energy integral (`_independent_truth`). Before
the fix the result was rounded to mpmath's default precision on return: 5e-17.
"""

from __future__ import annotations

import mpmath
import pytest

from reference_impl import PowerLaw
from reference_impl.exact.solve import solve_impact_mp
from verification._independent_truth import contact_time_undamped, power_sum, turning_point
from verification.assertions import assert_true

# The truth's quadratures are held to 10^-(dps+3) relative and the result carries
# dps = 30 digits: 1e-25 leaves five digits of margin, and is eight orders below a
# float round trip (5e-17), which it exists to catch.
TRUTH_DPS = 30
CHECK_DPS = 40
TOL = mpmath.mpf("1e-25")


def _hooke(k, m, v0, z) -> dict:
    """Closed form of q'' + 2 zeta w0 q' + w0^2 q = 0, q(0) = 0, q'(0) = v0 (40 digits)."""
    k, m, v0, z = (mpmath.mpf(x) for x in (k, m, v0, z))
    w0 = mpmath.sqrt(k / m)
    r = mpmath.sqrt((1 - z) * (1 + z))
    wd = w0 * r
    t_pk = mpmath.atan2(r, z) / wd  # q' = 0
    return {
        "contact_time": mpmath.pi / wd,
        "restitution": mpmath.exp(-mpmath.pi * z / r),
        "max_penetration": v0 / wd * mpmath.exp(-z * w0 * t_pk) * mpmath.sin(wd * t_pk),
        "contact_time_zero_force": 2 * t_pk,  # k q + c q' = -m q'' = 0
        "restitution_zero_force": mpmath.exp(-2 * z * w0 * t_pk),
    }


def _check(got: dict, want: dict, call: str) -> None:
    for key, ref in want.items():
        err = abs(got[key] - ref) / abs(ref) if ref else abs(got[key])
        assert_true(
            err <= TOL,
            got=f"{key} = {mpmath.nstr(got[key], 35)}, relative error {mpmath.nstr(err, 3)}",
            should=f"{mpmath.nstr(ref, 35)} to {mpmath.nstr(TOL, 1)}",
            claim="solve_impact_mp",
            call=call,
        )


@pytest.mark.parametrize(
    "k,m,v0,zeta", [(2.0e4, 0.3, 1.0, 0.0), (2.0e4, 0.3, 1.0, 0.2), (1.7e3, 0.0123, 0.77, 0.61)]
)
def test_truth_matches_hooke_closed_form_to_1e25(k, m, v0, zeta):
    got = solve_impact_mp(PowerLaw(k, 1.0), m, v0, zeta, dps=TRUTH_DPS)
    with mpmath.workdps(CHECK_DPS):
        _check(got, _hooke(k, m, v0, zeta), f"solve_impact_mp(Hooke k={k}, {m}, {v0}, {zeta})")


def test_truth_matches_hertz_energy_integral_to_1e25():
    k, p, m, v0 = 1.0e9, 1.5, 0.0041, 1.0
    got = solve_impact_mp(PowerLaw(k, p), m, v0, 0.0, dps=TRUTH_DPS)
    with mpmath.workdps(CHECK_DPS):
        U, _ = power_sum([(k, p)])
        E = mpmath.mpf(m) * mpmath.mpf(v0) ** 2 / 2
        q_max = turning_point(U, E, mpmath.mpf("1e-3"))
        want = {"contact_time": contact_time_undamped(U, m, q_max), "max_penetration": q_max}
        _check(got, want, f"solve_impact_mp(Hertz k={k}, {m}, {v0}, 0)")
