"""The scorecard's two verdicts (issue 26, item 1): implementation and delivery.

* implementation: measured against the exact solution of the law the code declares,
  with the step-scaled allowance (verification/test_bench_gate.py: a correct code passes
  it at every generated scene);
* delivery: measured against what the scene asks (restitution at the asked end,
  contact time, peak force), with fixed user-facing tolerances that never grow with
  the step, and the error split into a model part (declared law vs asked) and a
  step part (measured vs declared law).

A correct, calibrated code passes both at fine steps; a correct but mis-calibrated code
passes implementation and fails delivery at every step; the MuJoCo case of the issue
(which passed at 10 steps per contact and failed at 100 before) fails delivery at both.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from reference_impl.adapters.reference import ReferenceAdapter
from reference_impl.bench.scorecard.runner import run_bench
from reference_impl.scenes import scene_from_dict

from ._sweeps import cli, needs_dask
from .assertions import assert_true
from .strategies import bench_scenes

sys.path.insert(0, str(Path(__file__).parent))
import _wrong_codes as wrong  # noqa: E402

CLAIM = "bench-verdicts"  # the benchmark machinery, not a paper claim
# Each example is a whole benchmark (~1-2 s): a few examples keep the module near 30 s.
_FEW = settings(max_examples=3, suppress_health_check=[HealthCheck.too_slow], deadline=None)
# Fine step of the calibrated test: Verlet's restitution error at t_c/400 is <= 5e-3 up to
# zeta = 0.45 (1e-2 at zeta = 0.6 and t_c/200, first order), well inside the 2 % asked.
_FINE = 400


def _by(result) -> dict:
    return {m.metric: m for m in result.metrics}


def _steps(n: int) -> dict:
    return {"run": {"steps_per_contact": n}}


@_FEW
@given(data=bench_scenes())
def test_a_calibrated_correct_code_passes_both_verdicts_at_fine_steps(data):
    scene = scene_from_dict(data)
    result = run_bench(ReferenceAdapter(), [scene], tolerances=_steps(_FINE))
    bad = [(m.metric, m.explanation) for m in result.metrics if m.status in ("fail", "error")]
    delivered = [m.metric for m in result.gated("delivery") if m.status == "pass"]
    assert_true(
        not bad and len(delivered) == 3 and result.exit_status("both") == 0,
        got=f"failures {bad}, delivery passes {delivered}, exit {result.exit_status('both')}",
        should="no failure, the three delivery metrics pass, exit 0",
        claim=CLAIM,
        call=f"run_bench(reference, {data}, t_c/{_FINE})",
    )


@_FEW
@given(data=bench_scenes(), steps=st.sampled_from([50, 200, 1000]))
def test_a_miscalibrated_correct_code_fails_delivery_and_passes_implementation(data, steps):
    scene = scene_from_dict(data)
    result = run_bench(wrong.MisCalibrated(), [scene], tolerances=_steps(steps))
    by = _by(result)
    e = by["restitution_asked"]
    impl_bad = [
        (m.metric, m.explanation)
        for m in result.gated("implementation")
        if m.status in ("fail", "error")
    ]
    call = f"run_bench(mis-calibrated, {data}, t_c/{steps})"
    assert_true(
        e.status == "fail" and e.verdict == "delivery" and not impl_bad,
        got=f"restitution_asked {e.status} ({e.explanation}); implementation failures {impl_bad}",
        should="restitution_asked fails (delivery), no implementation metric fails",
        claim=CLAIM,
        call=call,
    )
    # the error is the calibration's: the model part carries it, the step part is small
    assert_true(
        e.model_error is not None
        and abs(e.model_error) > 0.05
        and abs(e.step_error) < abs(e.model_error),
        got=f"model {e.model_error}, step {e.step_error}",
        should="|model part| > 0.05 (8 % off by construction) and > |step part|",
        claim=CLAIM,
        call=call,
    )
    codes = (result.exit_status("implementation"), result.exit_status("delivery"),
             result.exit_status(True))  # fmt: skip
    assert_true(
        codes == (0, 1, 1),
        got=f"exit (implementation, delivery, both) = {codes}",
        should="(0, 1, 1)",
        claim=CLAIM,
        call=call,
    )


# The case of issue 26: MuJoCo, solref timeconst, constant impedance, Euler, dampratio 0.1,
# Hooke k = 2e5 N/m, m = 0.01 kg, v0 = 0.5 m/s, the scene asking e = 0.7. It delivered
# 0.771 (10.2 % off) at 10 steps per contact and passed; 0.746 (6.6 %) at 100 and failed.
_MJ_SCENE = {
    "name": "mujoco-issue26", "mass": 0.01, "velocities": [0.5], "kind": "impact",
    "potential": {"family": "power", "k": 2.0e5, "p": 1.0},
    "damping": {"law": "universal", "restitution": 0.7},
}  # fmt: skip
_MJ_SPEC = "mujoco[timeconst,constant,Euler,dampratio=0.1]"


@pytest.mark.mujoco
@pytest.mark.parametrize("steps, delivered", [(10, 0.771), (100, 0.746)])
def test_the_mujoco_case_of_issue_26_fails_delivery_at_10_and_100_steps(steps, delivered):
    from reference_impl.adapters.mujoco import mujoco_available

    if mujoco_available() is not None:
        pytest.skip("MuJoCo not installed (pip install -e '.[mujoco]')")
    result = run_bench(_MJ_SPEC, [scene_from_dict(_MJ_SCENE)], tolerances=_steps(steps))
    e = _by(result)["restitution_asked"]
    call = f"run_bench({_MJ_SPEC}, e = 0.7 asked, t_c/{steps})"
    assert_true(
        e.status == "fail"
        and abs(e.measured - delivered) < 5e-4
        and e.expected == pytest.approx(0.7),
        got=f"{e.status}: measured {e.measured}, expected {e.expected} ({e.explanation})",
        should=f"fail: measured {delivered}, expected 0.7",
        claim=CLAIM,
        call=call,
    )
    # the declared law (dampratio 0.1 as MuJoCo's timeconst form) gives 0.744: the model part
    # (6.3 %) alone exceeds the 2 % asked, at any step: recalibrate, not refine
    assert_true(
        e.model_error == pytest.approx(0.063, abs=1e-3) and e.model_error > 0.02,
        got=f"model {e.model_error}, step {e.step_error}",
        should="model part 0.063 > rtol 0.02",
        claim=CLAIM,
        call=call,
    )
    assert result.exit_status("delivery") == 1 and result.exit_status(True) == 1


def test_gate_selects_a_verdict_on_the_command_line():
    """``--gate`` (both), ``--gate implementation``, ``--gate delivery``: exit 1, 0, 1 for a
    mis-calibrated correct code, and the last line names the verdict read."""
    import os
    import subprocess

    root = Path(__file__).resolve().parent.parent
    base = [sys.executable, "-m", "reference_impl.cli", "bench",
            "verification._wrong_codes:MisCalibrated", "--scenes", "hooke-damped"]  # fmt: skip
    got = {}
    for gate in ([], ["implementation"], ["delivery"]):
        r = subprocess.run(
            [*base, "--gate", *gate], cwd=root, env={**os.environ, "PYTHONPATH": str(root)},
            capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        got[" ".join(gate) or "plain"] = (r.returncode, r.stdout.strip().splitlines()[-1])
    codes = {k: v[0] for k, v in got.items()}
    assert_true(
        codes == {"plain": 1, "implementation": 0, "delivery": 1}
        and got["delivery"][1].startswith("gate (delivery): FAIL")
        and got["implementation"][1].startswith("gate (implementation): pass"),
        got=str(got),
        should="exit 1, 0, 1; 'gate (delivery): FAIL', 'gate (implementation): pass'",
        claim=CLAIM,
        call="hcv bench MisCalibrated --gate [implementation|delivery]",
    )


@needs_dask
def test_a_bench_sweeps_summary_shows_measured_expected_and_error(tmp_path, capsys):
    """summary.md of a bench: sweep shows the delivered restitution, the asked one and the
    error between them (issue 26: not only pass / fail)."""
    spec = tmp_path / "bench.toml"
    spec.write_text(
        'task = "bench:verification._wrong_codes:MisCalibrated"\n'
        '[scene]\nname = "s"\nmass = 0.01\nvelocities = [1.0]\nkind = "impact"\n'
        '[scene.potential]\nfamily = "power"\nk = 1e6\np = 1.0\n'
        '[scene.damping]\nlaw = "universal"\nrestitution = 0.5\n'
        '[sweep]\n"potential.p" = [1.5]\n'
    )
    out = tmp_path / "out"
    code, stdout, err = cli(["sweep", str(spec), "--workers", "1", "--out", str(out)], capsys)
    summary = (out / "summary.md").read_text()
    header = next((line for line in summary.splitlines() if "failed_metrics" in line), "")
    assert_true(
        code == 1
        and all(c in header for c in ("measured.restitution", "asked_restitution",
                                      "rel_error.restitution_asked")),
        got=f"exit {code}; header {header!r}",
        should="exit 1 and the measured, asked and error columns of the restitution",
        claim=CLAIM,
        call="hcv sweep bench:MisCalibrated",
    )  # fmt: skip


class _MisDeclared(wrong.MisCalibrated):
    """Runs the asked law (reference Verlet, the scene's zeta) but declares the law 8 %
    off: the model part is +0.08, the step part about -0.08, the error small."""

    name = "mis-declared"

    def _impact_impl(self, scene):
        from reference_impl.adapters import Trajectory
        from reference_impl.adapters.reference import verlet_trajectory
        from reference_impl.theory.damping import zeta_from_restitution

        t, q, v, f = verlet_trajectory(
            scene.potential, scene.mass, scene.v0, scene.dt, scene.n_steps,
            zeta=float(zeta_from_restitution(scene.restitution)),
        )  # fmt: skip
        return Trajectory(t, q, v, f)


def test_the_delivery_error_is_the_sum_of_its_signed_model_and_step_parts():
    """error = |model + step| at every speed, to round-off (a few ulp of the ~1 values
    subtracted: 1e-12), with the parts signed: a declared law 8 % off that the run does
    not follow shows model > 0 and step < 0 (the step compensates the model)."""
    data = {
        "name": "mis-declared", "mass": 0.01, "velocities": [0.5, 2.0], "kind": "impact",
        "potential": {"family": "power", "k": 2.0e5, "p": 1.0},
        "damping": {"law": "universal", "restitution": 0.7},
    }  # fmt: skip
    e = _by(run_bench(_MisDeclared(), [scene_from_dict(data)]))["restitution_asked"]
    rows = [(r["error"], r["model_error"], r["step_error"]) for r in e.per_v0]
    ok = all(
        abs(abs(model + step) - err) <= 1e-12 and model > 0.05 and step < -0.05
        for err, model, step in rows
    )
    assert_true(
        ok,
        got=f"(error, model, step) per speed {rows}",
        should="error = |model + step| (1e-12), model > 0.05, step < -0.05",
        claim=CLAIM,
        call="run_bench(runs the asked law, declares it 8 % off)",
    )
