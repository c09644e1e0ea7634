"""The PyBullet adapter against real PyBullet (``pip install -e '.[pybullet]'``).

Marked ``pybullet``; skipped, with the install line, when PyBullet is not installed
(``pytest -m "not pybullet"`` deselects them). CI installs the extra and runs them.

What is checked: the soft contact's force is the declared law (a linear spring-dashpot,
tension clipped) at the state each step ends at; Bullet's combination rules (stiffness
in series, damping added); contactSlop starts the spring at q = slop and is declared as
a force offset, whose scenes the bench refuses by name; the rigid contact bounces
without penetrating and gets a delivery verdict on e alone (issue 40 §3), and stops
dead below PyBullet's restitution velocity threshold; soft + restitution is declined
with its reason; the import banner stays off stdout.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from reference_impl.adapters.pybullet import pybullet_available

pytestmark = [
    pytest.mark.pybullet,
    pytest.mark.skipif(
        pybullet_available() is not None,
        reason="PyBullet not installed (pip install -e '.[pybullet]')",
    ),
]

from reference_impl.adapters import get_adapter  # noqa: E402
from reference_impl.adapters.base import offset_refusal, scheme_of  # noqa: E402
from reference_impl.adapters.pybullet import _pybullet  # noqa: E402
from reference_impl.bench.scorecard.report import scorecard_text  # noqa: E402
from reference_impl.bench.scorecard.runner import run_bench  # noqa: E402
from reference_impl.errors import HCVInputError  # noqa: E402
from reference_impl.scenes import scene_from_dict  # noqa: E402
from verification._adapter_cases import FAST  # noqa: E402
from verification._adapter_cases import scene_at as _scene_at  # noqa: E402

from .assertions import assert_close, assert_true  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CLAIM = "bench-pybullet"  # the benchmark machinery, not a paper claim
# A step's force is its impulse over dt, -m (v1 - v0) / dt, against the law at the state
# the step ends at: Bullet's first Gauss-Seidel iteration solves a single contact row in
# closed form (the 49 others change nothing), so what is left is round-off and the
# cancellation in v1 - v0 (1e-16 v / dv ~ 1e-13); measured 2e-14, so 1e-9.
_STEP_RTOL = 1e-9


def _soft_scene(spc: int = 40, v0: float = 1.0):
    """hooke-damped (k 1e6 N/m, m 4.11 g, universal e = 0.5) at v0, dt = t_c / spc."""
    return _scene_at("hooke-damped", v0, spc)


def _step_error(tr, k: float, c: float, offset: float = 0.0) -> float:
    """max |force - max(k (q - offset) + c v, 0)| / peak over the steps that start and end
    past the offset (the step that crosses it starts from a separated contact, which
    Bullet solves as a speculative one: no spring, the crossing only)."""
    inside = tr.q > offset
    if offset:
        inside[1:] &= tr.q[:-1] > offset
    want = np.maximum(k * (tr.q[inside] - offset) + c * tr.v[inside], 0.0)
    return float(np.max(np.abs(tr.force[inside] - want)) / np.max(want))


def test_soft_force_is_the_declared_law_at_the_new_state():
    adapter = get_adapter("pybullet[soft]")
    scene = _soft_scene()
    law = adapter.implemented_law(scene)
    k, zeta = float(law.potential.k), law.zeta
    c = 2.0 * zeta * np.sqrt(scene.mass * k)
    tr = adapter.impact(scene)
    err = _step_error(tr, k, c)
    assert_true(err < _STEP_RTOL and (tr.q > 0).sum() > 20, got=err, should=f"< {_STEP_RTOL:g}",
                claim=CLAIM, call="pybullet[soft].impact: max|F - law| / peak")  # fmt: skip
    assert_close(c, 2.0 * scene.zeta * np.sqrt(scene.mass * k), rtol=1e-15, claim=CLAIM,
                 call="contactDamping typed = the scene's dashpot")  # fmt: skip


def test_combination_rules_stiffness_in_series_damping_added():
    """Unequal values on the two bodies: the contact gets k1 k2 / (k1 + k2) and c1 + c2."""
    pb = _pybullet()
    adapter = get_adapter("pybullet[soft]")
    scene = _soft_scene()
    cid, ball, R = adapter._world(pb, scene)
    k1, c1, k2, c2 = 3.0e6, 2.0, 1.5e6, 5.0
    try:
        pb.changeDynamics(ball, -1, contactStiffness=k1, contactDamping=c1, physicsClientId=cid)
        pb.changeDynamics(0, -1, contactStiffness=k2, contactDamping=c2, physicsClientId=cid)
        pb.resetBaseVelocity(ball, [0.0, 0.0, -1.0], physicsClientId=cid)
        pb.stepSimulation(physicsClientId=cid)
        z = pb.getBasePositionAndOrientation(ball, physicsClientId=cid)[0][2]
        vz = pb.getBaseVelocity(ball, physicsClientId=cid)[0][2]
    finally:
        pb.disconnect(cid)
    q1, v1 = R - z, -vz
    force = -scene.mass * (v1 - 1.0) / scene.dt
    want = k1 * k2 / (k1 + k2) * q1 + (c1 + c2) * v1
    assert_close(force, want, rtol=_STEP_RTOL, claim=CLAIM, call="one soft step, unequal bodies")


def test_slop_starts_the_spring_late_and_is_declared_as_an_offset():
    slop = 1e-5
    adapter = get_adapter(f"pybullet[soft,slop={slop!r}]")
    scene = _soft_scene()
    tr = adapter._impact_impl(scene)  # the run itself; the bench refuses to score it
    law = adapter.implemented_law(scene)
    k = float(law.potential.k)
    c = 2.0 * law.zeta * np.sqrt(scene.mass * k)
    early = tr.force[(tr.q > 0) & (tr.q <= slop)]
    ok = early.size > 3 and np.all(early == 0.0) and _step_error(tr, k, c, slop) < _STEP_RTOL
    assert_true(ok, got=(early[:4], _step_error(tr, k, c, slop)),
                should="no force until q = slop, then the law of q - slop",
                claim=CLAIM, call="pybullet[soft,slop=1e-5]")  # fmt: skip
    why = offset_refusal(adapter) or ""
    assert_true(adapter.force_offset == -slop and "-1e-05" in why, got=(adapter.force_offset, why),
                should="force_offset -1e-05, refused by name", claim=CLAIM,
                call="offset_refusal")  # fmt: skip


def _rigid_scene(v0: float):
    return scene_from_dict({
        "name": "rigid", "mass": 4.1103e-3, "velocities": [v0], "kind": "impact",
        "potential": {"family": "power", "k": 1.0e6, "p": 1.0},
        "damping": {"law": "universal", "restitution": 0.5},
    })  # fmt: skip


def test_rigid_contact_gets_a_delivery_verdict_on_e():
    """Restitution 0.5 typed as is: one step bounces without penetrating, e = 0.5; the
    bench says NO PENETRATION and judges restitution_asked alone (issue 40 §3)."""
    res = run_bench(get_adapter("pybullet[rigid]"), scenes=[_rigid_scene(1.0)], tolerances=FAST)
    by = {m.metric: m for m in res.metrics}
    judged = {k: m.status for k, m in by.items() if m.status != "n/a"}
    ok = (
        judged == {"restitution_asked": "pass"}
        and abs(by["restitution_asked"].measured - 0.5) < 1e-12
    )
    ok = (
        ok
        and "NO PENETRATION" in scorecard_text(res)
        and "sign convention" not in scorecard_text(res)
    )
    assert_true(ok, got=judged, should="restitution_asked pass, the rest n/a", claim=CLAIM,
                call="run_bench(pybullet[rigid], e = 0.5 at 1 m/s)")  # fmt: skip


def test_rigid_contact_below_the_restitution_threshold_stops_dead():
    """PyBullet applies no restitution below restitutionVelocityThreshold: at 0.1 m/s the
    sphere stops (e = 0) unless the threshold is lowered to 0."""
    scene = _scene_at("hooke-damped", 0.1, 40)
    stopped = get_adapter("pybullet[rigid]").impact(scene)
    bounced = get_adapter("pybullet[rigid,restitution_threshold=0]").impact(scene)
    got = (float(stopped.v[-1]), float(-bounced.v[-1] / 0.1), float(np.max(bounced.q)))
    ok = got[0] == 0.0 and abs(got[1] - 0.5) < 1e-12 and got[2] <= 0.0
    assert_true(ok, got=got, should="(0, 0.5, <= 0)", claim=CLAIM,
                call="pybullet[rigid] at 0.1 m/s, default and zero threshold")  # fmt: skip


def test_declines_and_bad_input():
    scene = _soft_scene()
    hertz = _scene_at("hertz-damped", 1.0, 20)
    reasons = (
        get_adapter("pybullet[soft-restitution]").supports(scene) or "",
        get_adapter("pybullet[soft]").supports(hertz) or "",
    )
    ok = "no contact law" in reasons[0] and "p = 1" in reasons[1]
    assert_true(ok, got=reasons, should="one line each", claim=CLAIM, call="supports")
    assert scheme_of(get_adapter("pybullet[soft]")).to_json() == {
        "name": "implicit-euler", "order": 1.0, "rtol": None,
    }  # fmt: skip
    for spec, word in (("pybullet[mode=hard]", "'hard'"), ("pybullet[slop=-1]", "-1"),
                       ("pybullet[restitution=1.5]", "1.5")):  # fmt: skip
        with pytest.raises(HCVInputError) as exc:
            get_adapter(spec)
        msg = str(exc.value)
        assert_true("\n" not in msg and word in msg, got=msg, should=f"one line naming {word}",
                    claim=CLAIM, call=f"get_adapter({spec!r})")  # fmt: skip


def test_calibrate_finds_the_damping_that_delivers_e():
    """``hcv calibrate "pybullet[soft]" --param damping``: the contactDamping found delivers
    e = 0.5 at the scene's speed (the clipped contact needs more than the scene's c)."""
    from reference_impl.bench.calibration.calibrate import calibrate

    scene = _soft_scene()
    c_scene = 2.0 * scene.zeta * np.sqrt(scene.mass * scene.potential.k)
    res = calibrate("pybullet[soft]", "hooke-damped", param="damping", target=0.5,
                    steps_per_contact=50)  # fmt: skip
    ok = res.found and abs(res.achieved - 0.5) < 1e-6 and res.value > c_scene
    assert_true(ok, got=(res.found, res.achieved, res.value), should=f"found, e = 0.5, c > {c_scene:.4g}",
                claim=CLAIM, call=res.message)  # fmt: skip


def test_import_banner_stays_off_stdout():
    """pybullet prints its build time on stdout at import; the adapter sends it to stderr."""
    r = subprocess.run(
        [sys.executable, "-c", "from reference_impl.adapters.pybullet import _pybullet; _pybullet()"],
        env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert_true(r.returncode == 0 and r.stdout == "" and "pybullet" in r.stderr,
                got=(r.returncode, r.stdout, r.stderr[-200:]), should="(0, '', banner)",
                claim=CLAIM, call="_pybullet()")  # fmt: skip
