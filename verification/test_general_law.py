"""Damping laws beyond the universal one (issue 18): the general-law reference solver.

References: the 30-digit Taylor-series truth (`reference_impl.exact._general_law_mp`, exact
series in rho = q^(1/N) at the ends), the exact quadrature of the universal law
(given to the general solver through its Tsuji power form or polynomial form), and
closed forms of the linear spring-dashpot (overdamped: no return).
"""

from __future__ import annotations

import functools
import math

import mpmath
import pytest
from hypothesis import Phase, example, given, settings
from hypothesis import strategies as st

from reference_impl import PowerLaw, solve_impact, solve_impacts
from reference_impl.errors import HCVInputError
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact.general_law import solve_law_impact
from reference_impl.potentials import Expression, SumPotential
from reference_impl.theory.damping import (
    restitution_zero_force_from_zeta,
    tsuji_coefficient,
    zeta_from_restitution,
)
from reference_impl.theory.laws import LAWS, DampingLaw, law_from_dict
from verification import strategies as hs
from verification.assertions import assert_close, assert_less, assert_true

# The goal of issue 18 for every law: 1e-12 relative. Measured errors against the
# truth are ~1e-14 (GBS extrapolation at 1e-14 per step over ~30 steps plus round-off).
GOAL_RTOL = 1e-12
# Agreement of the general path with the exact universal quadrature: both reach ~1e-14,
# the issue asks for 1e-13 (a few hundred ulps of the ~30 steps' round-off).
UNIVERSAL_RTOL = 1e-13
# Truth runs cost 2-4 s each: a handful of derandomised draws per law, cached.
TRUTH_EXAMPLES = 3
CALL = "solve_law_impact"


@functools.cache
def _truth(pot_key, m, v0, law_key):
    pot = _pot_from_key(pot_key)
    return solve_law_impact_mp(pot, m, v0, dict(law_key))


def _pot_from_key(key):
    terms = [PowerLaw(k, p) for k, p in key]
    return terms[0] if len(terms) == 1 else SumPotential(*terms)


def _key(pot):
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    return tuple((t.k, t.p) for t in terms)


def _check_against_truth(pot, m, v0, law):
    sol = solve_law_impact(pot, m, v0, law)
    assert_true(
        sol.returns_to_q0,
        got=f"no return for {law} (v0 = {v0})",
        should="a return (law_cases draws only returning bodies)",
        claim="general-law",
        call=CALL,
    )
    tr = _truth(
        _key(pot), m, v0, tuple((k, tuple(v) if isinstance(v, list) else v) for k, v in law.items())
    )
    call = f"{CALL}({pot!r}, m={m!r}, v0={v0!r}, {law})"
    for key, bound in (
        ("contact_time", sol.error_time),
        ("contact_time_zero_force", sol.error_time),
        ("time_of_max_penetration", sol.error_time),
        ("restitution", sol.error_restitution),
        ("restitution_zero_force", sol.error_restitution),
    ):
        got, want = getattr(sol, key), float(tr[key])
        assert_less(abs(got - want), bound, claim="general-law", call=call, what=f"|{key} error|")
        assert_close(got, want, rtol=GOAL_RTOL, claim="general-law", call=call)
    for key in ("max_penetration", "max_force", "peak_force"):
        assert_close(
            getattr(sol, key), float(tr[key]), rtol=GOAL_RTOL, claim="general-law", call=call
        )


# Draws every run checks (hypothesis's explicit phase): C = c on U' = k q^3 at gamma = 0.2,
# the strategy's bound where a law may creep, its slowest return (e = 0.23; the body creeps
# for ever from gamma = 0.296, see `strategies._CREEP_GAMMA`).
_PINNED = {"linear": [(PowerLaw(1e4, 3.0), 1.0, 1.0, {"law": "linear", "c": 4.756828460010884})]}


@pytest.mark.parametrize("name", [n for n in LAWS if n != "none"])
def test_law_against_30_digit_truth(name):
    # No shrinking: each truth run costs seconds, and the failing draw is printed as is.
    @settings(max_examples=TRUTH_EXAMPLES, phases=(Phase.explicit, Phase.generate))
    @given(hs.law_cases(name))
    def run(case):
        _check_against_truth(*case)

    for case in _PINNED.get(name, ()):
        run = example(case)(run)
    run()


# Draws of `law_cases` screened for a return: the solver alone (~0.1 ms an impact) on enough
# derandomised draws that a law which stops the body is met (before the strategy's creep
# bound, ~1 % of linear draws, C = c on U' = k q^3 with gamma > 0.296, did not return).
RETURN_EXAMPLES = 400


@pytest.mark.parametrize("name", [n for n in LAWS if n != "none"])
def test_law_cases_draw_returning_bodies(name):
    """Every case `law_cases` draws returns the body to q = 0, as the truth tests assume
    (the 30-digit truth runs out of steps on a body that creeps for ever)."""

    @settings(max_examples=RETURN_EXAMPLES, deadline=None)
    @given(hs.law_cases(name))
    def run(case):
        pot, m, v0, law = case
        assert_true(
            solve_law_impact(pot, m, v0, law).returns_to_q0,
            got="no return",
            should="a return (law_cases draws only returning bodies)",
            claim="general-law",
            call=f"{CALL}({pot!r}, m={m!r}, v0={v0!r}, {law})",
        )

    run()


def test_linear_dashpot_on_cubic_spring_creeps_for_ever():
    """A draw of the random profile before the strategy's creep bound (gamma = 0.305 on
    U' = k q^3, where C = c stops the body short of q = 0 above gamma = 0.296): the solver
    reports no return, and its zero-force end meets the 30-digit truth (which stops there)."""
    pot, m, v0 = PowerLaw(943726.1877119081, 3.0), 0.024791949334966878, 0.4055969506689753
    law = {"law": "linear", "c": 0.9004860848794701}
    sol = solve_law_impact(pot, m, v0, law)
    call = f"{CALL}({pot!r}, m={m!r}, v0={v0!r}, {law})"
    assert_true(
        not sol.returns_to_q0 and sol.contact_time == math.inf and sol.restitution == 0.0,
        got=f"returns {sol.returns_to_q0}, t_c = {sol.contact_time}, e = {sol.restitution}",
        should="no return (t_c = inf, e = 0): the body creeps for ever",
        claim="general-law",
        call=call,
    )
    tr = solve_law_impact_mp(pot, m, v0, law, zero_force_only=True)
    for key, bound in (
        ("contact_time_zero_force", sol.error_time),
        ("time_of_max_penetration", sol.error_time),
        ("restitution_zero_force", sol.error_restitution),
    ):
        got, want = getattr(sol, key), float(tr[key])
        assert_less(abs(got - want), bound, claim="general-law", call=call, what=f"|{key} error|")
        assert_close(got, want, rtol=GOAL_RTOL, claim="general-law", call=call)
    assert_close(
        sol.max_penetration,
        float(tr["max_penetration"]),
        rtol=GOAL_RTOL,
        claim="general-law",
        call=call,
    )


def test_truth_is_converged():
    """The truth agrees with itself at 30 and 45 digits (the series step control holds)."""
    pot = PowerLaw(1.0879e10, 1.5)
    law = {"law": "universal", "zeta": 0.3}
    a = solve_law_impact_mp(pot, 0.0041103, 1.0, law)
    b = solve_law_impact_mp(pot, 0.0041103, 1.0, law, dps=45)
    for key in ("contact_time", "restitution", "contact_time_zero_force", "peak_force"):
        assert_less(
            abs(a[key] - b[key]) / abs(b[key]),
            mpmath.mpf(10) ** -29,
            claim="general-law",
            call="solve_law_impact_mp",
            what=key,
        )
    # closed form of the universal law's restitution
    z = mpmath.mpf(0.3)
    with mpmath.workdps(40):
        e = mpmath.exp(-mpmath.pi * z / mpmath.sqrt(1 - z * z))
    assert_less(
        abs(b["restitution"] - e),
        mpmath.mpf(10) ** -29,
        claim="general-law",
        call="solve_law_impact_mp",
        what="restitution - closed form",
    )


@given(
    p=st.sampled_from([1.0, 1.5, 2.0, 3.0]),
    k=hs.log_uniform(1e3, 1e10),
    m=hs.masses(),
    v0=hs.speeds(),
    zeta=st.floats(0.0, 0.9),
)
def test_universal_through_power_and_polynomial_forms(p, k, m, v0, zeta):
    """The general path given C(q) of the universal law agrees with the exact quadrature."""
    pot = PowerLaw(k, p)
    ex = solve_impact(pot, m, v0, zeta)
    c, e = tsuji_coefficient(pot, m, zeta)
    laws = [{"law": "power", "c": c, "exponent": e}]
    if float(e).is_integer():  # p = 1 and p = 3: C is c or c q, a polynomial
        laws.append({"law": "polynomial", "c": [0.0] * int(e) + [c]})
    for law in laws:
        sol = solve_law_impact(pot, m, v0, law)
        call = f"{CALL}({pot!r}, m={m!r}, v0={v0!r}, {law})"
        for key in (
            "contact_time",
            "restitution",
            "contact_time_zero_force",
            "restitution_zero_force",
            "max_penetration",
            "max_force",
        ):
            assert_close(
                getattr(sol, key),
                getattr(ex, key),
                # max_force = k q_max^p carries p times q_max's relative error (found by
                # a generated case: p = 2, 1.69e-13 from a q_max within 8.5e-14)
                rtol=UNIVERSAL_RTOL * (p if key == "max_force" else 1.0),
                # a restitution is -w/v0 and w is integrated to round-off of v0, not of
                # itself: e = 1.6e-3 (zeta = 0.9) carries ~2e-16 absolute, 1.5e-13 relative
                atol=UNIVERSAL_RTOL if key.startswith("restitution") else 0.0,
                claim="general-law",
                call=call,
            )


@pytest.mark.parametrize("scene_name", ["paper-ellipsoid-damped", "sphere"])
def test_other_families_universal_against_exact(scene_name):
    """The plain-Python path (sphere, ellipsoid) against the exact quadrature."""
    from reference_impl import load_scene

    sc = load_scene(scene_name)
    for v0 in sc.velocities[:2]:
        ex = solve_impact(sc.potential, sc.mass, v0, 0.2)
        sol = solve_law_impact(sc.potential, sc.mass, v0, {"law": "universal", "zeta": 0.2})
        for key in (
            "contact_time",
            "restitution",
            "contact_time_zero_force",
            "restitution_zero_force",
            "max_penetration",
        ):
            assert_close(
                getattr(sol, key),
                getattr(ex, key),
                rtol=UNIVERSAL_RTOL,
                claim="general-law",
                call=f"{CALL}({scene_name}, v0={v0})",
            )


@pytest.mark.parametrize(
    "law",
    [
        {"law": "hunt-crossley", "alpha": 0.3},
        {"law": "viscoelastic", "A": 2e-6},
        {"law": "power", "c": 40.0, "exponent": 0.5},
    ],
)
def test_python_path_matches_compiled_path(law):
    """An Expression equal to Hertz (Python path) gives the compiled PowerLaw's answer."""
    k, m, v0 = 1.0879e10, 0.0041103, 1.0
    expr = Expression("k*q**(5/2)/(5/2)", k=k)
    a = solve_law_impact(PowerLaw(k, 1.5), m, v0, law)
    b = solve_law_impact(expr, m, v0, law)
    for key in (
        "contact_time",
        "restitution",
        "contact_time_zero_force",
        "restitution_zero_force",
        "peak_force",
    ):
        assert_close(
            getattr(b, key),
            getattr(a, key),
            rtol=UNIVERSAL_RTOL,
            claim="general-law",
            call=f"{CALL}(Expression, {law})",
        )


@given(k=hs.log_uniform(1e2, 1e8), m=hs.masses(), v0=hs.speeds(), over=st.floats(1.05, 20.0))
def test_overdamped_linear_dashpot_never_returns(k, m, v0, over):
    """m q'' + c q' + k q = 0 with c > 2 sqrt(m k): no return; zero-force end in closed form."""
    c = over * 2.0 * math.sqrt(m * k)
    sol = solve_law_impact(PowerLaw(k, 1.0), m, v0, {"law": "linear", "c": c})
    call = f"{CALL}(Hooke k={k!r}, m={m!r}, v0={v0!r}, linear c={c!r})"
    assert_true(
        not sol.returns_to_q0 and math.isinf(sol.contact_time) and sol.restitution == 0.0,
        got=f"returns={sol.returns_to_q0}, t_c={sol.contact_time}",
        should="no return",
        claim="general-law",
        call=call,
    )
    # q = v0 (e^(-l2 t) - e^(-l1 t)) / (l1 - l2); zero force <=> q'' = 0
    disc = math.sqrt(c * c - 4 * m * k)
    l1, l2 = (c + disc) / (2 * m), (c - disc) / (2 * m)
    t_star = 2 * math.log(l1 / l2) / (l1 - l2)
    w = v0 * (-l2 * math.exp(-l2 * t_star) + l1 * math.exp(-l1 * t_star)) / (l1 - l2)
    # 1e-10: the closed form itself loses digits to cancellation in l1 - l2 near critical
    assert_close(sol.contact_time_zero_force, t_star, rtol=1e-10, claim="general-law", call=call)
    assert_close(sol.restitution_zero_force, -w / v0, rtol=1e-10, claim="general-law", call=call)


def test_hertz_constant_dashpot_at_low_speed_creeps():
    """Hertz + constant dashpot: at low speed the body creeps back and never reaches q = 0."""
    sol = solve_law_impact(PowerLaw(1e9, 1.5), 1e-3, 1e-4, {"law": "linear", "c": 50.0})
    assert not sol.returns_to_q0 and sol.restitution == 0.0 and math.isinf(sol.contact_time)
    assert 0 < sol.restitution_zero_force < 1


def test_zero_force_restitution_inverse():
    """restitution_end = 'zero-force': the issue's 0.5503 and a round trip through solve_impact."""
    z_overlap = zeta_from_restitution(0.5)
    assert_close(
        restitution_zero_force_from_zeta(z_overlap),
        0.5502831696271158,
        rtol=1e-12,
        claim="general-law",
        call="restitution_zero_force_from_zeta",
    )
    for e in (0.05, 0.5, 0.95):
        z = zeta_from_restitution(e, end="zero-force")
        sol = solve_impact(PowerLaw(1e9, 1.5), 0.01, 1.0, z)
        assert_close(
            sol.restitution_zero_force,
            e,
            rtol=1e-13,
            claim="general-law",
            call=f"zeta_from_restitution({e}, end='zero-force')",
        )
    with pytest.raises(HCVInputError, match="end"):
        zeta_from_restitution(0.5, end="q0")


@pytest.mark.parametrize(
    "table, match",
    [
        ({"law": "linear", "c": -1.0}, "c = -1.0"),
        ({"law": "linear", "c": float("nan")}, "nan"),
        ({"law": "power", "c": 1.0}, "exponent"),
        ({"law": "power", "c": 1.0, "exponent": 99.0}, "exponent = 99.0"),
        ({"law": "polynomial", "c": []}, "list of 1 to"),
        ({"law": "polynomial", "c": [1.0] * 40}, "list of 1 to"),
        ({"law": "viscoelastic", "A": "x"}, "'x'"),
        ({"law": "hunt-crossley", "beta": 1.0}, "beta"),
        ({"law": "maxwell"}, "maxwell"),
    ],
)
def test_bad_law_is_one_line(table, match):
    with pytest.raises(HCVInputError, match=match) as info:
        law_from_dict(table)
    assert "\n" not in str(info.value)


def test_viscoelastic_needs_finite_curvature():
    with pytest.raises(HCVInputError, match="viscoelastic"):
        solve_law_impact(PowerLaw(1e6, 0.5), 1.0, 1.0, {"law": "viscoelastic", "A": 1e-3})


def test_solve_impact_and_batch_take_a_law():
    pot, m = PowerLaw(1e9, 1.5), 0.01
    law = {"law": "hunt-crossley", "alpha": 0.2}
    one = solve_impact(pot, m, 1.0, law=law)
    batch = solve_impacts(pot, m, [1.0, 2.0], law=law)
    assert batch["restitution"][0] == one.restitution
    assert batch["peak_force"][1] >= batch["max_force"][1]
    uni = solve_impact(pot, m, 1.0, law={"law": "universal", "zeta": 0.1})
    assert uni.restitution == solve_impact(pot, m, 1.0, 0.1).restitution
    assert uni.peak_force > uni.max_force  # the damper adds to the force while compressing
    with pytest.raises(HCVInputError, match="once"):
        solve_impact(pot, m, 1.0, 0.1, law={"law": "universal", "zeta": 0.1})
    assert DampingLaw("none").is_zero()


@pytest.mark.parametrize(
    "table",
    [
        {"law": "hunt-crossley", "alpha": 0.3},
        {"law": "viscoelastic", "A": 1e-6},
        {"law": "polynomial", "c": [1.0, 1e4]},
        {"law": "linear", "c": 2.0},
    ],
)
def test_declared_law_is_run_by_the_references(table):
    """A code declaring any law of the table gets both references run with that law."""
    import pickle

    from reference_impl.adapters import implemented_law_from_table
    from reference_impl.adapters.base import Trajectory
    from reference_impl.adapters.reference import law_trajectory
    from reference_impl.bench.measure import exact_reference, measure

    pot, m = PowerLaw(1e9, 1.5), 0.01
    law = implemented_law_from_table(pot, m, table)
    assert pickle.loads(pickle.dumps(law)).to_json()["damping"] == table  # worker processes
    ex = exact_reference(law, 1.0)
    sol = solve_law_impact(pot, m, 1.0, table)
    assert ex["restitution"] == sol.restitution
    t, q, v, f = law_trajectory(law, 1.0, 1e-7, 200000)
    got = measure(Trajectory(t, q, v, f), 1.0)["restitution"]
    # Verlet at ~1300 steps per contact: second order, measured 1e-5..2e-5 relative
    assert_close(
        got, sol.restitution, rtol=1e-4, claim="general-law", call=f"law_trajectory({table})"
    )


_SCENE = """name = "hertz-{law}"
mass = 0.0041103
velocities = [0.1, 1.0]
[potential]
family = "power"
k = 1.0879e10
p = 1.5
[damping]
law = "{law}"
{params}
"""


def _hcv(*args):
    import subprocess
    import sys

    return subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_cli_solve_any_law_both_ends_and_spread(tmp_path):
    """Measured in a new process, as the user runs it: both ends, both forces, the spread."""
    import json

    path = tmp_path / "s.toml"
    path.write_text(_SCENE.format(law="hunt-crossley", params="alpha = 0.3"))
    r = _hcv("solve", str(path), "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    rows = out["results"]
    sols = [
        solve_law_impact(
            PowerLaw(1.0879e10, 1.5), 0.0041103, v, {"law": "hunt-crossley", "alpha": 0.3}
        )
        for v in (0.1, 1.0)
    ]
    for row, sol in zip(rows, sols, strict=False):
        for key in ("restitution", "restitution_zero_force", "peak_force", "max_force"):
            assert row[key] == getattr(sol, key), key
    es = [s.restitution for s in sols]
    assert out["restitution_spread"]["overlap"] == max(es) - min(es)
    assert "peak_force" in out["forces"] and "overlap" in json.dumps(out["end_of_contact"])
    r = _hcv("solve", str(path))
    assert r.returncode == 0 and "restitution spread over the 2 speeds" in r.stdout


@pytest.mark.parametrize(
    "law, params, needle",
    [
        ("linear", "c = -3.0", "c = -3.0"),
        ("polynomial", 'c = "x"', "'x'"),
        ("viscoelastic", "zeta = 0.1", "zeta"),
        ("magic", "", "magic"),
        ("universal", 'restitution = 0.5\nrestitution_end = "q0"', "q0"),
    ],
)
def test_cli_bad_law_is_one_line_exit_2(tmp_path, law, params, needle):
    path = tmp_path / "bad.toml"
    path.write_text(_SCENE.format(law=law, params=params))
    r = _hcv("solve", str(path))
    assert r.returncode == 2 and r.stdout == "", (r.returncode, r.stdout)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


def test_scene_restitution_end(tmp_path):
    from reference_impl import load_scene

    path = tmp_path / "zf.toml"
    path.write_text(
        _SCENE.format(law="universal", params='restitution = 0.5\nrestitution_end = "zero-force"')
    )
    sc = load_scene(str(path))
    sol = solve_impact(sc.potential, sc.mass, 1.0, sc.zeta)
    assert_close(
        sol.restitution_zero_force,
        0.5,
        rtol=1e-13,
        claim="general-law",
        call="scene restitution_end = zero-force",
    )
    assert sc.to_dict()["damping"] == {"law": "universal", "zeta": sc.zeta}
