"""The Drake adapter against real Drake (``pip install -e '.[drake]'``).

Marked ``drake``; skipped, with the install line, when Drake is not installed
(``pytest -m "not drake"`` deselects them). CI installs the extra and runs them.

What is checked: the force Drake applies is each mode's declared law at sampled
states (Hunt-Crossley k x (1 + d xdot) clamped at 0 for the continuous plant and the
lagged / similar / tamsi approximations, Kelvin-Voigt k (x + tau xdot) clamped at 0 for
SAP); Drake's combination rules for stiffness, dissipation and relaxation time; the
declared schemes; the refusals; the issue's done-when (issue 40, §5): lagged at 200
steps per contact passes implementation at order ~1 and delivery, at 10 steps it
fails delivery saying "refine the step"; ``hcv calibrate`` finds the d that delivers
an asked e.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from reference_impl.adapters.drake import drake_available

pytestmark = [
    pytest.mark.drake,
    pytest.mark.skipif(
        drake_available() is not None,
        reason="Drake not installed (pip install -e '.[drake]')",
    ),
]

from reference_impl.adapters import AdapterScene, get_adapter  # noqa: E402
from reference_impl.adapters._drake_model import combine  # noqa: E402
from reference_impl.adapters.base import scheme_of  # noqa: E402
from reference_impl.bench.scorecard.runner import run_bench  # noqa: E402
from reference_impl.errors import HCVInputError  # noqa: E402
from reference_impl.exact.solve import solve_impact  # noqa: E402
from reference_impl.scenes import scene_from_dict  # noqa: E402
from verification._adapter_cases import FAST  # noqa: E402
from verification._adapter_cases import scene_at as _scene_at  # noqa: E402

from .assertions import assert_close, assert_true  # noqa: E402

CLAIM = "bench-drake"  # the benchmark machinery, not a paper claim
# Force against the declared law. The continuous plant evaluates k x (1 + d xdot) in
# double precision from the combined k and d: round-off of a few operations (1e-16
# measured), so 1e-12. A discrete step's force is the impulse it applied over dt,
# -m (v1 - v0) / dt, against the law at the state the step ends at: the lagged,
# similar and SAP approximations are solved by Drake's convex SAP solver, which stops at
# its relative tolerance 1e-6 on the momentum balance (SapSolverParameters.rel_tolerance);
# measured 1e-9 of the peak at 40 steps per contact, 2e-14 at 200 (TAMSI: 2e-14).
_CONT_RTOL = 1e-12
_STEP_RTOL = 1e-6
# Hunt-Crossley on Hooke (the mass and spring of hooke-damped), e = 0.5 asked at 1 m/s.
_HC = {
    "name": "hooke-hc", "mass": 4.1103e-3, "velocities": [1.0], "kind": "impact",
    "potential": {"family": "power", "k": 1.0e6, "p": 1.0},
    "damping": {"law": "hunt-crossley", "restitution": 0.5, "restitution_speed": 1.0},
}  # fmt: skip


def _ascene(spc: int = 40, v0: float = 1.0, universal: bool = False) -> AdapterScene:
    """The HC scene (or hooke-damped, universal e = 0.5) at v0, dt = t_c / spc."""
    if universal:
        return _scene_at("hooke-damped", v0, spc)
    sc = scene_from_dict(_HC)
    t_c = solve_impact(sc.potential, sc.mass, v0, 0.0).contact_time
    return AdapterScene.from_scene(sc, v0, t_c / spc, 4 * spc)


def _law_force(law, q, rate):
    """The declared law's total force at (q, dq/dt), clamped at 0 when it clips (N)."""
    q, rate = np.asarray(q, float), np.asarray(rate, float)
    f = law.potential._dU(q) + np.array([float(law.damping_coefficient(x)) for x in q]) * rate
    return np.maximum(f, 0.0) if law.clips_tension else f


def test_continuous_force_is_the_declared_law_at_sampled_states():
    """k x (1 + d xdot) clamped at 0: approaching, leaving, and leaving fast enough that
    1 + d xdot < 0 (Drake reports no force: the clamp)."""
    adapter = get_adapter("drake[continuous]")
    scene = _ascene()
    law = adapter.implemented_law(scene)
    d = law.params["hunt_crossley_dissipation"]
    q_top = float(law.potential.turning_point(0.5 * scene.mass))
    for frac in (0.1, 0.5, 1.0):
        for rate in (0.8, 0.1, -0.3, -2.0 / d):
            got = adapter.probe(scene, frac * q_top, rate)["force"]
            want = float(_law_force(law, [frac * q_top], [rate])[0])
            assert_close(got, want, rtol=_CONT_RTOL, atol=1e-12 * law.potential.k * q_top,
                         claim=CLAIM, call=f"probe(q = {frac} q_top, rate = {rate})")  # fmt: skip


@pytest.mark.parametrize(
    ("mode", "universal"),
    [("lagged", False), ("similar", False), ("tamsi", False), ("sap", True)],
)
def test_discrete_step_force_is_the_declared_law_at_the_new_state(mode, universal):
    """Each step applies the declared law at the state it ends at (implicit Euler), read
    from the impulse over the whole trajectory of an impact."""
    from pydrake.multibody.plant import DiscreteContactApproximation

    if not hasattr(DiscreteContactApproximation, f"k{mode.capitalize()}"):
        pytest.skip(f"this Drake has no {mode} approximation (TAMSI: removed after 2026-09-01)")
    adapter = get_adapter(f"drake[{mode}]")
    scene = _ascene(spc=40, universal=universal)
    law = adapter.implemented_law(scene)
    tr = adapter.impact(scene)
    inside = tr.q > 0
    want = _law_force(law, tr.q[inside], tr.v[inside])
    err = float(np.max(np.abs(tr.force[inside] - want)) / np.max(np.abs(want)))
    assert_true(err < _STEP_RTOL and inside.sum() > 20, got=err, should=f"< {_STEP_RTOL:g}",
                claim=CLAIM, call=f"drake[{mode}].impact: max|F - law| / peak")  # fmt: skip


def test_combination_rules_for_stiffness_dissipation_and_relaxation_time():
    """Unequal values on the two geometries: the contact gets k1 k2 / (k1 + k2),
    (k2 d1 + k1 d2) / (k1 + k2) (continuous) and tau1 + tau2 (SAP, one step)."""
    scene = _ascene(spc=40, universal=True)
    k1, d1, t1, k2, d2, t2 = 3.0e6, 0.2, 4e-6, 1.5e6, 0.7, 1e-6
    k, d, tau = combine(k1, k2, d1, d2, t1, t2)
    mp = {"ball": (k1, d1, t1), "ground": (k2, d2, t2)}
    q, rate = 2e-5, 0.4
    cont = get_adapter("drake[continuous]")
    diagram, plant, joint, R = cont.build(scene, mp)
    pc = plant.GetMyMutableContextFromRoot(diagram.CreateDefaultContext())
    joint.set_translation(pc, R - q)
    joint.set_translation_rate(pc, -rate)
    got = cont._contact_force(plant, pc)
    assert_close(got, k * q * (1.0 + d * rate), rtol=_CONT_RTOL, claim=CLAIM,
                 call="continuous force, k and d combined")  # fmt: skip
    sap = get_adapter("drake[sap]")
    sap._mapping = lambda s: {**mp, "k": k, "d": d, "tau": tau}  # the unequal split
    one = sap.probe(scene, q, rate)
    assert_close(one["force"], k * (one["q"] + tau * one["v"]), rtol=_STEP_RTOL, claim=CLAIM,
                 call="sap one step, relaxation times added")  # fmt: skip


def test_declared_schemes():
    """Contract item 12: discrete modes implicit Euler of order 1, continuous
    variable-step at its target accuracy."""
    got = {m: scheme_of(get_adapter(f"drake[{m}]")).to_json() for m in ("lagged", "continuous")}
    want = {
        "lagged": {"name": "implicit-euler", "order": 1.0, "rtol": None},
        "continuous": {"name": "variable-step", "order": None, "rtol": 1e-6},
    }
    assert_true(got == want, got=got, should=want, claim=CLAIM, call="scheme_of(drake[...])")


def test_refusals_and_bad_input():
    hc, uni = _ascene(), _ascene(universal=True)
    hertz = _scene_at("hertz-damped", 1.0, 20)
    reasons = {
        "lagged on universal": get_adapter("drake[lagged]").supports(uni),
        "sap on hunt-crossley": get_adapter("drake[sap]").supports(hc),
        "continuous on hertz": get_adapter("drake[continuous]").supports(hertz),
    }
    ok = (
        "give dissipation=D" in reasons["lagged on universal"]
        and "relaxation_time=TAU" in reasons["sap on hunt-crossley"]
        and "p = 1" in reasons["continuous on hertz"]
    )
    assert_true(ok, got=reasons, should="one line each naming the law and the input to give",
                claim=CLAIM, call="drake[...].supports")  # fmt: skip
    assert get_adapter("drake[lagged,dissipation=0.3]").supports(uni) is None
    for spec, word in (("drake[mode=euler]", "'euler'"), ("drake[dissipation=-1]", "-1"),
                       ("drake[accuracy=2]", "2")):  # fmt: skip
        with pytest.raises(HCVInputError) as exc:
            get_adapter(spec)
        msg = str(exc.value)
        assert_true("\n" not in msg and word in msg, got=msg, should=f"one line naming {word}",
                    claim=CLAIM, call=f"get_adapter({spec!r})")  # fmt: skip


def _verdicts(spc: int):
    tol = {**FAST, "run": {**FAST["run"], "steps_per_contact": spc}}
    res = run_bench(get_adapter("drake[lagged]"), scenes=[scene_from_dict(_HC)], tolerances=tol)
    return {m.metric: m for m in res.metrics}


def test_lagged_passes_implementation_at_order_one_and_delivery_follows_the_step():
    """Issue 40 §5 done-when. At 200 steps per contact: implementation passes with the
    measured order ~1 (0.99 measured) and delivery passes (0.4921 for 0.5: the first-order
    step error, 1.6 %, inside the fixed 2 %). At 10 steps: implementation still
    passes (the allowance is implicit Euler's own error), delivery fails and its line
    says "refine the step", not "recalibrate" (the model part is 0: d is the law's)."""
    fine, coarse = _verdicts(200), _verdicts(10)
    impl = [m for m in (*fine.values(), *coarse.values()) if m.verdict == "implementation"]
    bad = [(m.metric, m.status, m.explanation) for m in impl if m.status == "fail"]
    assert_true(not bad, got=bad, should="no implementation failure", claim=CLAIM,
                call="run_bench(drake[lagged], 200 and 10 steps)")  # fmt: skip
    order = fine["speed_error"].value
    assert_true(abs(order - 1.0) < 0.1, got=order, should="~1 (first-order implicit)",
                claim=CLAIM, call="speed_error at 200 steps")  # fmt: skip
    assert_true(fine["restitution_asked"].status == "pass", got=fine["restitution_asked"].status,
                should="pass", claim=CLAIM, call="restitution_asked at 200 steps")  # fmt: skip
    m = coarse["restitution_asked"]
    said = m.explanation
    ok = m.status == "fail" and "refine the step" in said and "recalibrate" not in said
    assert_true(ok, got=(m.status, said), should="fail, saying refine the step",
                claim=CLAIM, call="restitution_asked at 10 steps")  # fmt: skip


def test_calibrate_finds_the_dissipation_that_delivers_e():
    """``hcv calibrate drake[lagged] --param dissipation`` on a universal scene: the d
    found delivers e = 0.5 at the scene's speed, to the root's tolerance."""
    from reference_impl.bench.calibration.calibrate import calibrate

    res = calibrate("drake[lagged]", "hooke-damped", param="dissipation", target=0.5,
                    steps_per_contact=50)  # fmt: skip
    assert_true(res.found and abs(res.achieved - 0.5) < 1e-6 and math.isfinite(res.value),
                got=(res.found, res.achieved, res.value), should="found, e = 0.5",
                claim=CLAIM, call=res.message)  # fmt: skip
