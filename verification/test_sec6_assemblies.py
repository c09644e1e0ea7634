"""Section 6 where DEM lives (issue 39): does Delta t_safe <= Delta t_crit hold in chains and
packings? The claim module (`reference_impl.claims.sec6_assemblies`) measures ensembles of
Hertz assemblies; here its quick measurement is checked, and a refutation is confirmed by a
velocity-Verlet loop written in this file (plain Python, not the compiled kernel).
"""

from __future__ import annotations

import math

import pytest

from reference_impl.claims import sec6_assemblies as claim_mod
from verification.assertions import assert_true, check_measurement

CLAIM = claim_mod.ID
claim = pytest.mark.claim(CLAIM)
# Below Delta t_safe by a margin far wider than the search's bracket (0.2 %) and the lanes'
# spread (a few %): the independent loop must run away there.
_BELOW = 0.9
# Steps the loop may take; the runaway criterion's horizon in the quick measurement.
_STEPS = 1000


def _two_bodies_run_away(dt_over_safe: float) -> tuple[bool, int]:
    """Two Hertz spheres between two walls, the first struck: velocity Verlet at
    dt_over_safe Delta t_safe (the paper's, striker's mass and energy) exceeds 1e6 E_0?"""
    k, p, m, _, v0 = claim_mod.HERTZ
    e0 = 0.5 * m * v0 * v0
    q_max = (e0 * (p + 1) / k) ** (1 / (p + 1))  # U(q_max) = E_0, U = k q^(p+1) / (p+1)
    dt = (
        dt_over_safe
        * 2
        * math.sqrt(m)
        * math.sqrt(2 * k * q_max ** (p + 1) / (p + 1))
        / (k * q_max**p)
    )  # stiffening: the supremum of U'/sqrt(2U) is at q_max

    def forces(x0, x1):
        qs = (-x0, x0 - x1, x1)  # left wall, between the spheres, right wall
        f = [k * q**p if q > 0 else 0.0 for q in qs]
        u = sum(k * q ** (p + 1) / (p + 1) for q in qs if q > 0)
        return f[0] - f[1], f[1] - f[2], u

    x0 = x1 = 0.0
    v_0, v_1 = v0, 0.0
    f0, f1, _ = forces(x0, x1)
    for n in range(1, _STEPS + 1):
        v_0 += 0.5 * dt * f0 / m
        v_1 += 0.5 * dt * f1 / m
        x0 += dt * v_0
        x1 += dt * v_1
        f0, f1, u = forces(x0, x1)
        v_0 += 0.5 * dt * f0 / m
        v_1 += 0.5 * dt * f1 / m
        if not 0.5 * m * (v_0 * v_0 + v_1 * v_1) + u <= 1e6 * e0:
            return True, n
    return False, _STEPS


@claim
def test_assemblies_quick_measurement_gives_the_recorded_verdict():
    m = claim_mod.measure(quick=True)

    def real(meas) -> bool:
        chain2 = next(r for r in meas.figures["rows"] if r["case"].startswith("chain N=2"))
        ran_away, _ = _two_bodies_run_away(_BELOW)
        return chain2["ratio_5"] < _BELOW and ran_away

    check_measurement(m, expect="refuted", real=real, call="sec6_assemblies.measure(quick=True)")


def test_the_independent_loop_is_stable_well_below_the_measured_step():
    """The loop is not simply unstable: at 0.3 Delta t_safe it stays below 1e6 E_0."""
    ran_away, n = _two_bodies_run_away(0.3)
    assert_true(
        not ran_away,
        got=f"runaway at step {n}",
        should=f"stable for {_STEPS} steps",
        claim=CLAIM,
        call="_two_bodies_run_away(0.3)",
    )


def test_every_case_reports_the_linear_prediction_beside_its_factor():
    m = claim_mod.measure(quick=True)
    for r in m.figures["rows"]:
        want = math.sqrt(r["dim"] / (2.0 * r["coordination"]))
        assert_true(
            r["linear_prediction"] == want and 0 < r["factor"] <= 1.0,
            got=f"linear {r['linear_prediction']}, factor {r['factor']}",
            should=f"sqrt(d / 2Z) = {want}, a factor in (0, 1]",
            claim=CLAIM,
            call=f"measure(quick=True) row {r['case']}",
        )
