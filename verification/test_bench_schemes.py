"""Every integrator judged fairly (issue 40, §1): the implementation verdict allows the
error of the scheme a code *declares* (contract item 12), asks its step-refinement study
for that scheme's order and its extrapolated answer for the declared law's exact one,
and checks the reported force against the declared law at the reported states.

The codes are in verification/_implicit_codes.py: a first-order implicit-Euler code
(correct), the same with a dashpot 10 % too strong, and with its force reported x2 and
x1e300. On main (before schemes were declared) the correct implicit code failed
restitution_exact at 200 steps per contact (its error ~2e-2 against 3 x Verlet's ~1e-3)
and the x2 force passed every implementation metric.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from reference_impl.adapters.base import ImplementedLaw, Scheme, Trajectory, scheme_of
from reference_impl.adapters.reference import law_trajectory
from reference_impl.bench.measure import exact_reference, measure
from reference_impl.bench.scorecard._schemes import force_mismatch, scheme_trajectory
from reference_impl.bench.scorecard.runner import run_bench
from reference_impl.errors import HCVInputError
from reference_impl.potentials.power import PowerLaw
from reference_impl.scenes import scene_from_dict
from reference_impl.theory.damping import zeta_from_restitution

from .assertions import assert_true

sys.path.insert(0, str(Path(__file__).parent))
import _implicit_codes as codes  # noqa: E402

# One speed, a linear contact (the law Drake's point contact and every code share), e = 0.5:
# one bench of it is ~2 to 5 s.
_SCENE = scene_from_dict(
    {
        "name": "hooke-one",
        "mass": 1.0,
        "velocities": [1.0],
        "kind": "impact",
        "potential": {"family": "power", "k": 1.0e4, "p": 1.0},
        "damping": {"law": "universal", "restitution": 0.5},
    }
)
_HERTZ = scene_from_dict(
    {
        "name": "hertz-one",
        "mass": 4.1103e-3,
        "velocities": [1.0],
        "kind": "impact",
        "potential": {"family": "power", "k": 1.0879e10, "p": 1.5},
        "damping": {"law": "universal", "restitution": 0.5},
    }
)


def _statuses(res) -> dict:
    return {(m.scene, m.metric): m for m in res.metrics if m.verdict == "implementation"}


@pytest.mark.parametrize("scene", [_SCENE, _HERTZ], ids=["hooke", "hertz"])
def test_implicit_euler_passes_implementation(scene):
    """A correct first-order implicit code passes every implementation metric."""
    res = run_bench(codes.ImplicitEuler(), scenes=[scene])
    bad = {
        k[1]: m.explanation for k, m in _statuses(res).items() if m.status not in ("pass", "n/a")
    }
    assert_true(not bad, got=bad, should="every implementation metric pass or n/a",
                claim="issue 40 §1", call="implicit Euler, order 1, run_bench")  # fmt: skip
    # and it is judged against its own scheme: its error at 200 steps is far above
    # 3 x velocity Verlet's, which the bench allowed before the scheme was declared
    m = _statuses(res)[(scene.name, "restitution_exact")]
    assert_true(m.error > 0.003, got=m.error, should="> 3e-3 (first order at 200 steps)",
                claim="issue 40 §1", call="implicit Euler's restitution error")  # fmt: skip


def test_damping_error_fails_implementation():
    """A dashpot 10 % too strong, declared as the scene's law, fails implementation on the
    extrapolated answer (an error the step does not shrink) and on the force."""
    st = _statuses(run_bench(codes.DampingOff(), scenes=[_SCENE]))
    for metric in ("extrapolated", "force_law"):
        m = st[("hooke-one", metric)]
        assert_true(m.status == "fail" and m.error > 1.5 * m.limit, got=(m.status, m.error, m.limit),
                    should="fail by a margin of 1.5", claim="issue 40 §1", call=f"10 % damping error, {metric}")  # fmt: skip
    assert_true("does not shrink with the step" in st[("hooke-one", "extrapolated")].explanation,
                got=st[("hooke-one", "extrapolated")].explanation,
                should="say the error does not shrink with the step", claim="issue 40 §1", call="extrapolated")  # fmt: skip
    # the order of its error is ~0.3: it does not converge to the declared law (issue 40 §4)
    sp = st[("hooke-one", "speed_error")]
    assert_true(sp.status == "fail" and sp.explanation.startswith("does not converge"),
                got=(sp.status, sp.explanation), should="fail, saying it does not converge",
                claim="issue 40 §4", call="speed_error of a 10 % damping error")  # fmt: skip


@pytest.mark.parametrize("cls", [codes.ForceTimesTwo, codes.ForceTimes1e300], ids=["x2", "x1e300"])
def test_force_units_bug_fails_naming_the_force(cls):
    """A force reported x2 or x1e300 fails implementation on ``force_law``, naming the force."""
    tol = {"run": {"speed_error_steps": [50, 100, 200]}}  # the study is not what fails here
    m = _statuses(run_bench(cls(), scenes=[_SCENE], tolerances=tol))[("hooke-one", "force_law")]
    assert_true(m.status == "fail" and m.error >= 1.0, got=(m.status, m.error),
                should="fail with |diff| / peak >= 1", claim="issue 40 §1", call=f"{cls.name}, force_law")  # fmt: skip
    assert_true(m.explanation.startswith("force ") and "declared law gives" in m.explanation,
                got=m.explanation, should="name the force and the declared law's",
                claim="issue 40 §1", call="force_law explanation")  # fmt: skip


def _law(e=0.5):
    return ImplementedLaw(PowerLaw(1.0e4, 1.0), 1.0, zeta=float(zeta_from_restitution(e)))


@pytest.mark.parametrize(
    "name, order",
    [("symplectic-euler", 1), ("explicit-euler", 1), ("implicit-euler", 1), ("rk4", 4)],
)
def test_schemes_converge_at_their_order(name, order):
    """Each scheme the bench runs on the exact law converges to it at its nominal order
    (undamped linear contact: smooth, so the nominal order shows; fit over 100-800 steps)."""
    law = ImplementedLaw(PowerLaw(1.0e4, 1.0), 1.0, zeta=0.0)
    ex = exact_reference(law, 1.0)
    errs = []
    steps = (100, 200, 400, 800)
    for n in steps:
        dt = ex["contact_time"] / n
        t, q, v, f = scheme_trajectory(law, Scheme(name, float(order)), 1.0, dt, 2 * n)
        errs.append(
            abs(measure(Trajectory(t, q, v, f), 1.0)["max_penetration"] - ex["max_penetration"])
        )
    # the sampled maximum is itself first order in dt off the peak (x dt^2 near it); the
    # order of q_max is min(scheme, 2) for a smooth peak sampled at the steps
    got = float(np.polyfit(np.log(steps), np.log(errs), 1)[0]) * -1.0
    assert_true(got > min(order, 2) - 0.3, got=got, should=f">= {min(order, 2) - 0.3}",
                claim="issue 40 §1", call=f"{name} order of q_max, scheme_trajectory")  # fmt: skip


def test_verlet_scheme_is_the_recorder_bit_for_bit():
    """Declaring nothing (velocity Verlet) runs the suite's one Verlet recorder unchanged."""
    law = _law()
    a = scheme_trajectory(law, Scheme("velocity-verlet", 2.0), 1.0, 1e-4, 500)
    b = law_trajectory(law, 1.0, 1e-4, 500)
    assert_true(all(np.array_equal(x, y) for x, y in zip(a, b, strict=True)), got="differs",
                should="identical arrays", claim="issue 40 §1", call="scheme_trajectory(velocity-verlet)")  # fmt: skip


def test_force_mismatch_is_zero_for_a_consistent_record():
    """An implicit-Euler record reports F(q_n, v_n) of its own law: mismatch 0; x2: 1."""
    law = _law()
    t, q, v, f = scheme_trajectory(law, Scheme("implicit-euler", 1.0), 1.0, 1e-4, 500)
    assert_true(force_mismatch(Trajectory(t, q, v, f), law)["error"] == 0.0, got="nonzero",
                should="0", claim="issue 40 §1", call="force_mismatch of a consistent record")  # fmt: skip
    got = force_mismatch(Trajectory(t, q, v, 2.0 * f), law)["error"]
    assert_true(math.isclose(got, 1.0, rel_tol=1e-12), got=got, should="1",
                claim="issue 40 §1", call="force_mismatch of a x2 force")  # fmt: skip


class _Declares:
    label = "x"

    def __init__(self, **kw):
        self.__dict__.update(kw)


@pytest.mark.parametrize(
    "kw, needle",
    [
        ({"time_scheme": "leapfrog2"}, "'leapfrog2'"),
        ({"time_scheme": "rk4", "claimed_order": -1}, "-1"),
        ({"time_scheme": "variable-step"}, "scheme_rtol"),
    ],
)
def test_bad_scheme_declarations_are_refused_by_name(kw, needle):
    with pytest.raises(HCVInputError) as exc:
        scheme_of(_Declares(**kw))
    assert_true(needle in str(exc.value) and "\n" not in str(exc.value), got=str(exc.value),
                should=f"one line naming {needle}", claim="issue 40 §1", call="scheme_of")  # fmt: skip


def test_scheme_defaults():
    assert_true(scheme_of(_Declares()) == Scheme("velocity-verlet", 2.0), got=scheme_of(_Declares()),
                should="velocity Verlet, order 2", claim="issue 40 §1", call="scheme_of default")  # fmt: skip
    s = scheme_of(_Declares(time_scheme="variable-step", scheme_rtol=1e-8))
    assert_true(s.variable and s.rtol == 1e-8, got=s, should="variable, rtol 1e-8",
                claim="issue 40 §1", call="scheme_of variable-step")  # fmt: skip


def test_variable_step_code_is_judged_at_its_tolerance():
    """A variable-step code (RK45, rtol 1e-8, sampled at dt) passes implementation; the
    step-refinement metrics do not apply (its dt is its sampling)."""
    st = _statuses(run_bench(codes.VariableStep(), scenes=[_SCENE]))
    bad = {k[1]: m.explanation for k, m in st.items() if m.status not in ("pass", "n/a")}
    assert_true(not bad, got=bad, should="every implementation metric pass or n/a",
                claim="issue 40 §1", call="run_bench(variable-step)")  # fmt: skip
    for metric in ("speed_error", "extrapolated"):
        m = st[("hooke-one", metric)]
        assert_true(m.status == "n/a" and "sampling" in m.explanation, got=(m.status, m.explanation),
                    should="n/a: dt is its sampling", claim="issue 40 §1", call=metric)  # fmt: skip


_ELASTIC = scene_from_dict(
    {
        "name": "hooke-elastic",
        "mass": 1.0,
        "velocities": [1.0],
        "kind": "impact",
        "potential": {"family": "power", "k": 1.0e4, "p": 1.0},
    }
)


@pytest.mark.parametrize(
    "scheme, order", [("explicit-euler", 1), ("symplectic-euler", 1), ("rk4", 4)]
)
@pytest.mark.parametrize("scene", [_SCENE, _ELASTIC], ids=["damped", "elastic"])
def test_every_declared_scheme_passes_implementation(scheme, order, scene):
    """A correct code of each scheme passes implementation, critical step included (on
    main a correct explicit Euler failed dt_crit against Verlet's: 0.12 of it, elastic)."""
    res = run_bench(codes.Declared.of(scheme, order), scenes=[scene])
    bad = {
        k[1]: m.explanation for k, m in _statuses(res).items() if m.status not in ("pass", "n/a")
    }
    assert_true(not bad, got=bad, should="every implementation metric pass or n/a",
                claim="issue 40 §1", call=f"run_bench({scheme} code)")  # fmt: skip
