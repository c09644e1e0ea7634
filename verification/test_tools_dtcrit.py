"""Tool tests of the section 6 instruments (no claim marks): the lane engine against an
independent scalar Verlet loop and the numpy fallback, the scenes, the search on
known truths (the linear spring's exact critical step, islands, homogeneity of
power laws), input checks and the result dict.

These validate what reference_impl.claims.sec6_dt_safe_bound and the claim tests
in test_sec6_dtcrit.py measure with.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from reference_impl.errors import HCVInputError
from reference_impl.integrators.verlet import (
    SCENE_IMPACT,
    SCENE_WALLS,
    STATUS_NAMES,
    LaneBatch,
    run_lanes,
)
from reference_impl.potentials import Ellipsoid, Expression, PowerLaw
from reference_impl.stability.bound import dt_safe
from reference_impl.stability.search import (
    EnergyGrowth,
    ImpactGain,
    SearchGrid,
    _next_dts,
    _Search,
    parse_criterion,
    search_scene,
)
from reference_impl.studies.dtcrit_map import criterion_sensitivity
from reference_impl.theory.damping import restitution_from_zeta
from verification._dtcrit_checks import HERTZ, RES, TWO_BRACKETS
from verification.assertions import assert_close, assert_true

# Lanes of the engine and of the scalar reference do the same arithmetic up to
# the last ulp of pow(); over 3000 steps of a stable orbit that grows to well
# below 1e-9 relative.
ENGINE_RTOL = 1e-9
# Steps of the engine-versus-reference comparisons: long enough for thousands of
# contacts' worth of force evaluations, short enough for the pure-Python loop.
REF_STEPS = 3000


# ----------------------------------------------------------------------------
# independent scalar reference
# ----------------------------------------------------------------------------
def _scalar_verlet(pot, m, scene, dt, y0, v0, gap, n_steps, zeta=0.0):
    """Plain-Python kick-drift-kick Verlet through the public Potential API (q > 0 only).

    Returns (energies E_1..E_n, separated) where n <= n_steps.
    """

    def force(y, v_half):
        if scene == SCENE_IMPACT:
            q, s = y, -1.0
        elif y > gap:
            q, s = y - gap, -1.0
        else:
            q, s = -y, 1.0
        if q <= 0:
            return 0.0, 0.0
        f, u = pot.dU(q), pot.U(q)
        damp = 2 * zeta * math.sqrt(m) * f / math.sqrt(2 * u) * v_half if zeta > 0 else 0.0
        return s * f - damp, u

    y, v = y0, v0
    F, _ = force(y, v)
    touched, energies = False, []
    for _ in range(n_steps):
        vh = v + 0.5 * dt * F / m
        y = y + dt * vh
        F, U = force(y, vh)
        v = vh + 0.5 * dt * F / m
        energies.append(0.5 * m * v * v + U)
        touched |= U > 0
        if scene == SCENE_IMPACT and touched and y <= 0:
            return np.array(energies), True
    return np.array(energies), False


class _Spy(PowerLaw):
    """A power law (numpy path) that fails the test if evaluated outside (0, q_sup]."""

    def _dU(self, q):
        assert np.all(q > 0), f"U' evaluated at q = {q.min()!r} <= 0"
        return super()._dU(q)

    def _U(self, q):
        assert np.all(q > 0), f"U evaluated at q = {q.min()!r} <= 0"
        return super()._U(q)


@pytest.mark.parametrize(
    "label, pot, m, v0, scene, gap, phase, zeta",
    [
        ("hertz two-sided", HERTZ, 1.0, 1.0, SCENE_WALLS, 0.0, 0.0, 0.0),
        (
            "ellipsoid two-walls",
            Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5),
            0.05,
            0.99,
            SCENE_WALLS,
            0.02,
            0.0,
            0.0,
        ),
        (
            "sum impact, onset phase 0.37",
            PowerLaw(1e3, 1.0) + PowerLaw(1e5, 2.5),
            0.2,
            0.7,
            SCENE_IMPACT,
            0.0,
            0.37,
            0.0,
        ),
        ("damped hertz impact", HERTZ, 1.0, 1.0, SCENE_IMPACT, 0.0, 0.0, 0.3),
    ],
)
def test_engine_matches_scalar_reference(label, pot, m, v0, scene, gap, phase, zeta):
    """The numba lanes reproduce an independent scalar loop step for step."""
    # Stable steps: 0.3 dt_safe for the sustained scene, 0.01 dt_safe to resolve the impact.
    dt = (0.3 if scene == SCENE_WALLS else 0.01) * dt_safe(pot, m, v0).dt_safe
    y0 = gap if scene == SCENE_WALLS else -phase * v0 * dt
    E_ref, sep = _scalar_verlet(pot, m, scene, dt, y0, v0, gap, REF_STEPS, zeta)
    b = LaneBatch(dt=[dt], y0=y0, v0=v0, gap=gap, e_limit=np.inf, max_steps=REF_STEPS)
    res = run_lanes(pot, m, scene, b, zeta=zeta, engine="numba")
    assert_true(
        int(res.steps[0]) == E_ref.size,
        got=f"{res.steps[0]} steps",
        should=f"{E_ref.size} ({label})",
        claim="tool: dt-crit",
        call="run_lanes",
    )
    assert_close(
        res.e_end[0],
        E_ref[-1],
        rtol=ENGINE_RTOL,
        claim="tool: dt-crit",
        call=f"run_lanes e_end {label}",
    )
    assert_close(
        res.e_max[0],
        max(E_ref.max(), 0.5 * m * v0 * v0),
        rtol=ENGINE_RTOL,
        claim="tool: dt-crit",
        call=f"run_lanes e_max {label}",
    )
    if scene == SCENE_IMPACT:
        assert_true(
            sep and STATUS_NAMES[res.status[0]] in ("separated", "end-over-limit"),
            got=STATUS_NAMES[res.status[0]],
            should="separated",
            claim="tool: dt-crit",
            call=label,
        )


def test_numpy_fallback_matches_numba():
    """A user Expression on the numpy fallback and the PowerLaw kernel give the same lanes.

    The numpy engine is asked for by name: q**2.5/2.5 has a term table since the
    table was shared (`reference_impl.potentials._terms`), so ``engine="auto"`` now
    runs it in the power-law kernel itself (identical lanes: test_term_table.py).
    """
    expr = Expression("q**2.5/2.5")  # = PowerLaw(1, 1.5)
    ds = dt_safe(HERTZ, 1.0, 1.0).dt_safe
    # Far from the threshold 0.75 dt_safe on both sides, so round-off cannot flip a verdict.
    ratios = np.array([0.2, 0.4, 0.6, 1.2, 1.6])
    for scene, gap in ((SCENE_WALLS, 0.0), (SCENE_WALLS, 3.0), (SCENE_IMPACT, 0.0)):
        b = LaneBatch(
            dt=ratios * ds,
            y0=gap if scene == SCENE_WALLS else -0.25 * ratios * ds,
            v0=1.0,
            gap=gap,
            e_limit=50.0,
            max_steps=5000,
        )
        a = run_lanes(HERTZ, 1.0, scene, b, engine="numba")
        n = run_lanes(expr, 1.0, scene, b, engine="numpy")
        assert_true(
            n.engine == "numpy" and list(a.status) == list(n.status),
            got=f"{n.engine} {[STATUS_NAMES[s] for s in n.status]}",
            should=f"numpy {[STATUS_NAMES[s] for s in a.status]}",
            claim="tool: dt-crit",
            call=f"run_lanes scene={scene} gap={gap}",
        )
        ok = a.status != 4  # blown lanes have no end energy
        assert_close(
            n.e_max[ok], a.e_max[ok], rtol=ENGINE_RTOL, claim="tool: dt-crit", call="numpy e_max"
        )


def test_one_sided_scenes_never_evaluate_nonpositive_overlap():
    spy = _Spy(1.0, 0.5)  # p < 1: U'' is singular at 0, as for a user formula with sqrt(q)
    dts = np.array([0.01, 0.1, 0.5, 1.0, 3.0, 10.0])  # contact time is about 3.4 s
    for scene, y0, gap in ((SCENE_IMPACT, -0.3 * dts, 0.0), (SCENE_WALLS, 2.0, 2.0)):
        b = LaneBatch(dt=dts, y0=y0, v0=1.0, gap=gap, e_limit=50.0, max_steps=2000)
        res = run_lanes(spy, 1.0, scene, b)
        assert_true(
            res.engine == "numpy" and bool(np.all(res.steps > 0)),
            got=res.engine,
            should="numpy engine, all lanes run",
            claim="tool: dt-crit",
            call=f"run_lanes scene={scene}",
        )


def test_ellipsoid_through_the_wall_is_blown():
    """q > q_sup = 2a ends the lane as blown (the body passed through the wall)."""
    ell = Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5)
    b = LaneBatch(dt=[1.0], y0=0.0, v0=0.99, e_limit=np.inf, max_steps=10)  # y_1 = 0.99 m > 0.03 m
    res = run_lanes(ell, 0.05, SCENE_WALLS, b)
    assert_true(
        STATUS_NAMES[res.status[0]] == "blown" and res.failed[0],
        got=STATUS_NAMES[res.status[0]],
        should="blown",
        claim="tool: dt-crit",
        call="run_lanes",
    )


@pytest.mark.parametrize("k, m", [(1.0, 1.0), (4.0e6, 0.05)])
def test_linear_spring_dt_crit_is_2_over_omega(k, m):
    """Two-sided linear spring: the runaway dt_crit = 2/omega for every factor F.

    The bounded orbit below 2/omega peaks at E0 / (1 - (omega dt / 2)^2), so it
    crosses F E0 from (2/omega) sqrt(1 - 1/F): that is dt_bounded (a bounded
    excursion, not an instability), found on the tried steps at or above that
    threshold.
    """
    omega = math.sqrt(k / m)
    grid = SearchGrid()
    df = criterion_sensitivity(
        PowerLaw(k, 1.0), m, 0.3, "two-sided", factors=(10.0, 100.0, 1e4), n_steps=(20_000,)
    )
    for F, got, kind in zip(df.factor, df.dt_crit, df.failure_kind, strict=True):
        assert_close(got, 2 / omega, rtol=RES, claim="tool: dt-crit", call=f"dt_crit, factor={F:g}")
        assert_true(
            kind == "runaway",
            got=kind,
            should="runaway",
            claim="tool: dt-crit",
            call=f"failure_kind, factor={F:g}",
        )
    for F, dt_b in zip(df.factor, df.dt_bounded, strict=True):
        thr = 2 / omega * math.sqrt(1 - 1 / F)
        if not math.isfinite(dt_b):
            # No tried step fell in [thr, 2/omega): only possible when that gap is
            # narrower than the scan step.
            assert_true(
                2 / omega - thr < grid.step * 2 / omega,
                got=f"dt_bounded = inf with [thr, 2/omega) = [{thr:.6g}, {2 / omega:.6g})",
                should="a bounded excursion on the scan",
                claim="tool: dt-crit",
                call=f"dt_bounded, factor={F:g}",
            )
            continue
        # 1e-9: the threshold is met by the Verlet orbit's peak to round-off of
        # the 2e4-step energy sum; the upper end is one scan step above it.
        assert_true(
            thr * (1 - 1e-9) <= dt_b <= min(thr + grid.step * 2 / omega, 2 / omega),
            got=f"dt_bounded = {dt_b:.9g} s",
            should=f"in [{thr:.9g}, {thr + grid.step * 2 / omega:.9g}] s",
            claim="tool: dt-crit",
            call=f"dt_bounded, factor={F:g}",
        )
    # The F = 10 threshold (0.9487 of 2/omega) lies a scan step below 2/omega:
    # its bounded excursion must be found.
    assert_true(
        math.isfinite(df.dt_bounded.iloc[0]),
        got=str(df.dt_bounded.iloc[0]),
        should="finite dt_bounded at F = 10",
        claim="tool: dt-crit",
        call="dt_bounded, factor=10",
    )


def test_search_reports_smallest_failure_below_an_island():
    """With failures on [0.50, 0.53] and [0.9, inf) the k-section finds 0.50 (units of dt_ref)."""
    grid = SearchGrid()
    s = _Search(1.0, 1.0, np.zeros(1))
    for _ in range(50):
        dts = _next_dts(s, grid)
        if dts.size == 0:
            break
        for d in dts:
            s.tried[float(d)] = bool(0.5 <= d <= 0.53 or d >= 0.9)
    lo, f = s.bracket()
    assert_true(
        0.5 <= f <= 0.5 + RES and f - lo <= RES,
        got=f"bracket [{lo}, {f}]",
        should=f"[~0.5 - {RES}, 0.5]",
        claim="tool: dt-crit",
        call="_next_dts",
    )


def test_power_law_ratio_is_scale_free():
    """dt_crit / dt_safe of a power law depends on p only (homogeneous equation of motion)."""
    a = search_scene(PowerLaw(1.0, 1.5), 1.0, [1.0], "two-sided")[0]
    b = search_scene(PowerLaw(2.0e5, 1.5), 0.05, [0.37], "two-sided")[0]
    assert_close(
        b.ratio, a.ratio, rtol=0, atol=TWO_BRACKETS, claim="tool: dt-crit", call="search_scene"
    )


def test_damped_impact_restitution():
    """Universal damping in the lanes: rebound speed -> e(zeta) as dt -> 0 (Theorem 3)."""
    zeta = 0.3
    ds = dt_safe(HERTZ, 1.0, 1.0).dt_safe
    b = LaneBatch(dt=[1e-3 * ds], y0=0.0, v0=1.0, e_limit=np.inf, max_steps=10**6)
    res = run_lanes(HERTZ, 1.0, SCENE_IMPACT, b, zeta=zeta)
    # 2e-3: the dashpot uses the half-step velocity (first order in dt) and the
    # separation is detected at a step boundary; both are O(1e-3) at this dt.
    assert_close(
        math.sqrt(res.e_end[0] / 0.5),
        restitution_from_zeta(zeta),
        rtol=2e-3,
        claim="tool: dt-crit",
        call="run_lanes zeta=0.3",
    )


def test_bad_inputs_raise_one_line_errors():
    for kwargs in (
        dict(kind="two_sided"),
        dict(velocities=[0.0]),
        dict(m=-1.0),
        dict(criterion=ImpactGain()),
        dict(gap=-1.0),
    ):
        args = dict(potential=HERTZ, m=1.0, velocities=[1.0], kind="two-walls") | kwargs
        with pytest.raises(HCVInputError) as err:
            search_scene(**args)
        assert_true(
            "\n" not in str(err.value),
            got=repr(str(err.value)),
            should="one line",
            claim="tool: dt-crit",
            call=f"search_scene {kwargs}",
        )
    for text in ("factor", "tol=0.1", "factor=abc", "factor=0.5"):
        with pytest.raises(HCVInputError):
            parse_criterion(text, "two-sided")
    got = parse_criterion("factor=1e3, n_steps=2e5", "two-sided")
    assert_true(
        got == EnergyGrowth(1000.0, 200_000),
        got=repr(got),
        should="EnergyGrowth(1000, 200000)",
        claim="tool: dt-crit",
        call="parse_criterion",
    )


def test_result_dict_and_progress():
    calls = []
    rs = search_scene(
        PowerLaw(1.0, 0.75),
        1.0,
        [0.5, 2.0],
        "impact",
        progress=lambda done, total: calls.append((done, total)),
    )
    d = json.loads(json.dumps([r.to_dict() for r in rs]))
    keys = {
        "v0",
        "kind",
        "dt_safe",
        "dt_safe_shortcut",
        "dt_crit",
        "ratio",
        "criterion",
        "holds",
        "counterexample",
    }
    assert_true(
        keys <= set(d[0]) and [r["v0"] for r in d] == [0.5, 2.0],
        got=str(sorted(d[0])),
        should=f"keys {sorted(keys)}",
        claim="tool: dt-crit",
        call="to_dict",
    )
    # p < 1: sup U'/sqrt(2U) is infinite at q -> 0, so dt_safe = 0 and the bound is vacuous.
    assert_true(
        all(r.degenerate and r.dt_safe == 0 and r.holds and math.isfinite(r.dt_crit) for r in rs),
        got=str([(r.dt_safe, r.dt_crit) for r in rs]),
        should="dt_safe = 0, finite dt_crit",
        claim="tool: dt-crit",
        call="search_scene p=0.75",
    )
    assert_true(
        calls and calls[-1][0] == calls[-1][1],
        got=str(calls[-3:]),
        should="ends at total",
        claim="tool: dt-crit",
        call="progress",
    )
