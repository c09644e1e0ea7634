"""The general-law solver's error bounds hold near critical damping (GBS kernel families).

Reference: the universal law's 30-digit quadrature truth (`reference_impl.exact._truth.
solve_impact_mp`), for any family. Near zeta = 1 the return decays by orders before
q = 0 (e = 2.7e-10 at zeta = 0.99): the kernel once held its local errors to q_E and v0
there, and the contact time (q = 0 end) was up to 3000 times its reported bound
(Hertz, zeta = 0.99; 1-6 times on the user expression at zeta = 0.95-0.99). The
saturating force near zeta = 1 still exceeds it, from its float U (a strict xfail below,
with the numbers and the cause).
"""

from __future__ import annotations

import pytest
from hypothesis import example, given, settings

from reference_impl.exact._truth import solve_impact_mp
from reference_impl.exact.general_law import solve_law_impact
from reference_impl.potentials import PowerLaw, SaturatingForce
from verification import strategies as hs
from verification.assertions import assert_less

CLAIM = "general-law"
# Each example runs the truth (0.5-1.5 s) and, for the non-power families, the kernel's
# plain-Python path (0.1-0.8 s): a few draws keep the test within seconds.
EXAMPLES = 4


@settings(max_examples=EXAMPLES)
@given(hs.near_critical_universal_cases())
@example(("power", PowerLaw(1e5, 1.5), 0.1, 1.0, 0.99))  # 3000x its bound on main
def test_universal_near_critical_within_reported_bounds(case):
    """|solver - truth| <= the bound the solver reports, for both ends of contact."""
    _check_bounds(*case)


@pytest.mark.xfail(
    strict=True,
    reason="saturating force near critical damping: the contact time is 6.9x its bound at "
    "zeta = 0.99, v0 = 8 m/s (F0 = q_s = 1, m = 1; 3.5x at v0 = 0.25; 3100x before the "
    "kernel's relative error control). Cause: the potential's float U, not the integrator: "
    "SaturatingForce._U's series x^3/3 - x^5/5 + x^7/7 below x = 0.01 is 3e-13 off there "
    "(2e-13 just above, from x - atan x), and the universal law's C = 2 zeta sqrt(m) "
    "U'/sqrt(2U) carries it into a tail whose sensitivity grows like 1/(1 - zeta^2)^1.5; with "
    "U summed to 13 terms below x = 0.2 (1e-16) the same kernel gives 3.8e-13 relative, "
    "0.14 of its bound. potentials/saturating.py (and the Verlet kernel's copy of its "
    "closed form) is not this change's; measured 2026-11-26",
)
def test_saturating_near_critical_within_reported_bounds():
    _check_bounds("saturating", SaturatingForce(1.0, 1.0), 1.0, 8.0, 0.99)


def _check_bounds(family, pot, m, v0, zeta):
    sol = solve_law_impact(pot, m, v0, {"law": "universal", "zeta": zeta})
    ref = solve_impact_mp(pot, m, v0, zeta, dps=30)
    call = f"solve_law_impact({pot!r}, m={m!r}, v0={v0!r}, universal zeta={zeta!r}) [{family}]"
    # No tolerance of the test's own: the bound is the solver's claim, and the 30-digit
    # truth's error is negligible against it (~1e-12 of the contact time).
    for key, bound in (
        ("contact_time", sol.error_time),
        ("contact_time_zero_force", sol.error_time),
        ("restitution", sol.error_restitution),
        ("restitution_zero_force", sol.error_restitution),
    ):
        err = abs(getattr(sol, key) - float(ref[key]))
        assert_less(err, bound, claim=CLAIM, call=call, what=f"|error| of {key}")
