"""`solve_impact` picks its integration from one ordered tuple of strategies (issue 27, goal 7).

Each strategy answers or returns None (`reference_impl.exact._strategies`, its numbered
contract); these tests hold which one answers for each kind of impact, that a refusal
hands over to the next, and that `solve_impact` reports the answer it took.
"""

from __future__ import annotations

import pytest

from reference_impl import PowerLaw, solve_impact
from reference_impl.exact import _strategies as st
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._validate import _validated_top
from reference_impl.studies.workprecision import family_scenes
from verification.assertions import assert_true

_SCENES = {sc.name: sc for sc in family_scenes()}
# U' = 1e-12 q^0.01 + q^20 at v0 = 100: the terms hand over inside the contact
# (`verification/test_exact_reliability.py`, the issue-22 example).
_SPLIT = (PowerLaw(1e-12, 0.01) + PowerLaw(1.0, 20.0), 1.0, 100.0)


def _job(pot, m, v0, zeta, level=None):
    q_top = _validated_top(pot, 0.5 * m * v0 * v0)
    return st.Job(pot, m, v0, VirtualOscillator(v0, zeta), q_top, level)


def _cases():
    sc = _SCENES
    return [
        ("hertz", sc["hertz-k1e9-damped"], 0.2, None, "power_law"),
        ("hertz, zeta 0.95", sc["hertz-k1e9-damped"], 0.95, None, "general"),
        ("ellipsoid", sc["ellipsoid-damped"], 0.2, None, "fused"),
        ("sphere, level 5", sc["sphere-damped"], 0.2, 5, "general"),
        ("sphere, overdamped", sc["sphere-damped"], 2.5, None, "general"),
        ("power sum", sc["power-sum-damped"], 0.0, None, "fused"),
    ]


@pytest.mark.parametrize("label,sc,zeta,level,want", _cases(), ids=[c[0] for c in _cases()])
def test_strategy_per_impact(label, sc, zeta, level, want):
    name, answer = st.choose(_job(sc.potential, sc.m, sc.v0, zeta, level))
    sol = solve_impact(sc.potential, sc.m, sc.v0, zeta, level=level)
    assert_true(
        name == want and sol.contact_time == answer.branches.rise + answer.branches.fall,
        got=f"{name}, contact time {answer.branches.rise + answer.branches.fall!r} "
        f"(solve_impact {sol.contact_time!r})",
        should=f"{want}, and solve_impact reports its answer",
        claim="solve_impact",
        call=f"choose({label}, zeta={zeta}, level={level})",
    )


def test_split_sum_takes_a_split_strategy():
    pot, m, v0 = _SPLIT
    name, _ = st.choose(_job(pot, m, v0, 0.2))
    assert_true(
        name in ("split_gauss_jacobi", "split_quadrature"),
        got=name,
        should="a split strategy (the terms hand over inside the contact)",
        claim="solve_impact",
        call="choose(1e-12 q^0.01 + q^20, v0=100, zeta=0.2)",
    )


def test_a_refusal_hands_over_to_the_next(monkeypatch):
    sc = _SCENES["ellipsoid-damped"]
    job = _job(sc.potential, sc.m, sc.v0, 0.2)
    _, fused = st.choose(job)
    monkeypatch.setattr(
        st, "STRATEGIES", (lambda job: None, *(s for s in st.STRATEGIES if s is not st.fused))
    )
    name, general = st.choose(_job(sc.potential, sc.m, sc.v0, 0.2))
    rel = abs(general.branches.rise / fused.branches.rise - 1)
    # Both are the same integral by two rules, each to ~1e-14 (`_one_call`, `_branches`).
    assert_true(
        name == "general" and rel <= 1e-13,
        got=f"{name}, rise differs by {rel:.2g}",
        should="general, the same rise time to 1e-13",
        claim="solve_impact",
        call="choose(ellipsoid) without the fused strategy",
    )
