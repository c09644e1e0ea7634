"""A zero-force end at a tiny overlap just before the exit (general-law solver and its truth).

Where C(0) = 0 or nearly (C = c0 + c1 q with c0 = 0 or 3.6e-291, c q, A U'' on Hertz, a
sphere's cap), F = U'(q) + C(q) q' goes through 0 on the way out at a tiny overlap
(k q^3 = c1 q |w| on p = 3: q ~ sqrt(c1 |w| / k)), 1e-12 to 1e-7 s before q = 0. The
30-digit truth (`reference_impl.exact._general_law_mp`) missed it: its exit step's
series G sums O(1) coefficients to round-off (~1e-45) at rho = 0, which hid the sign
of F there (c0 w ~ -1e-290, or 0), and the crossing lay between its last two samples;
it reported the zero-force end at the exit, and the solver (right) looked off by up to
5e4 times its bound (`test_general_taylor`'s truth test, once under the random profile).
The solver's Taylor kernel missed it too, at an rtol (1e-10): its root from the exit's
value ~0 landed on the exit (`reference_impl.exact._taylor_force.zero_force_root`).

Each case here is checked twice: the truth's zero-force end against an independent
witness (near the exit the speed is constant to ~1e-12: the crossing lies q_zf / |w_end|
before the exit, q_zf the root of U'(q) + C(q) w_end = 0), and the solver's ends and
restitutions against the truth within their own bounds. (Tool test, no claim mark.)
"""

from __future__ import annotations

import math

import pytest
from scipy.optimize import brentq

from reference_impl import PowerLaw, Sphere
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact.general_law import solve_law_impact
from reference_impl.theory.laws import law_from_dict
from verification.assertions import assert_close, assert_less

CALL = "solve_law_impact_mp"
# The witness takes the speed constant over the last q_zf / |w| before the exit: it
# changes there by at most C(q_zf) |w| / m times that time (F runs from 0 to C(0) w), a
# relative C(q_zf) q_zf / (m |w|) < 1e-20 in these cases; its root q_zf is a float's
# (brentq to 4 ulps). Measured: 0 to 1.1e-15 relative.
WITNESS_RTOL = 1e-10

# (potential, m, v0, law, rtol of the solver): main's truth missed the zero-force end of
# the first four (put it at the exit, 3e-12 to 1e-7 s later); at rtol 1e-10 main's Taylor
# kernel missed it in the last two (5.5e-10 and 6.7e-12 s, bounds 1.2e-12 and 3.1e-14 s).
CASES = [
    # the reported draw: k q^3, C = c0 + c1 q with a denormal-sized c0 (t_zf 5e-10 s before t_c)
    (
        PowerLaw(56796532.80788986, 3.0),
        0.0015724852401864868,
        0.010952265788383615,
        {"law": "polynomial", "c": [3.6e-291, 1.5393784782598136e-13]},
        None,
    ),
    # c0 = 0 exactly: F = q (k q^2 + c1 w), G / q = c1 w < 0 at the exit (9.5e-8 s before it)
    (PowerLaw(1e7, 3.0), 0.01, 0.5, {"law": "polynomial", "c": [0.0, 4.472135954999581e-08]}, None),
    # Kuwabara-Kono on Hertz: F = k q^0.5 (q + 1.5 A w), crossing at q = 1.5 A |w|
    (PowerLaw(1e7, 1.5), 0.01, 0.5, {"law": "viscoelastic", "A": 2.1031911482673098e-12}, None),
    # a sphere's cap (the Taylor kernel's cap path), C = c1 q: 9e-10 s before the exit
    (Sphere(R=0.01, Kn=1e8), 0.0327, 1.0, {"law": "polynomial", "c": [0.0, 1e-3]}, None),
    # the Taylor kernel's root of the zero-force end: Illinois from the exit's value c0 W
    # (-6e-291) landed on the exit (`_taylor_force.zero_force_root`)
    (
        PowerLaw(267785.9349100233, 3.0),
        0.04292276354690093,
        0.1287850644494752,
        {"law": "polynomial", "c": [3.6e-291, 1.046165015890675e-14]},
        1e-10,
    ),
    (
        PowerLaw(106774821.04432686, 3.0),
        0.001556303573587216,
        1.882308220277293,
        {"law": "polynomial", "c": [3.6e-291, 9.0260537343781e-15]},
        1e-10,
    ),
]


def _witness(pot, m, v0, law, w_end, q_top):
    """Time (s) from the zero-force end to the exit: q_zf / |w_end|, q_zf the root of
    U'(q) + C(q) w_end = 0 (the force near the exit at the exit's speed), by brentq on log q."""
    fam, params = law.family, law.params

    def g(x):
        q = math.exp(x)
        return float(pot.dU(q)) + float(fam.C(params, pot, m, q, w_end)) * w_end

    lo, hi = math.log(1e-25 * q_top), math.log(1e-2 * q_top)
    assert g(lo) < 0.0 < g(hi), "the case has no crossing at a tiny overlap"
    x = brentq(g, lo, hi, xtol=1e-15, rtol=4 * 2.0**-52)
    return math.exp(x) / abs(w_end)


_IDS = ["k-q3-c0-tiny", "k-q3-c0-zero", "hertz-visco", "cap", "rtol-a", "rtol-b"]


@pytest.mark.parametrize("case", CASES, ids=_IDS)
def test_zero_force_end_just_before_exit(case):
    """The truth's zero-force end where the witness puts it, the solver's within its bounds."""
    pot, m, v0, law, rtol = case
    call = f"{CALL}({pot!r}, m={m!r}, v0={v0!r}, {law})"
    tr = solve_law_impact_mp(pot, m, v0, law, dps=30)
    gap = float(tr["contact_time"] - tr["contact_time_zero_force"])
    w_end = -float(tr["restitution"]) * v0
    want = _witness(pot, m, v0, law_from_dict(law), w_end, float(tr["max_penetration"]))
    # the truth's zero-force end lies the witness's time before its exit (main: gap 0)
    assert_close(gap, want, rtol=WITNESS_RTOL, claim="general-law", call=call)
    sol = solve_law_impact(pot, m, v0, law, rtol=rtol)
    scall = f"solve_law_impact({pot!r}, m={m!r}, v0={v0!r}, {law}, rtol={rtol})"
    for key, bound in (
        ("contact_time_zero_force", sol.error_time),
        ("contact_time", sol.error_time),
        ("restitution_zero_force", sol.error_restitution),
        ("restitution", sol.error_restitution),
    ):
        err = abs(getattr(sol, key) - float(tr[key]))
        assert_less(err, bound, claim="general-law", call=scall, what=f"|{key} - truth|")
