"""Hostile input to ``hcv bench`` and the adapter contract (issues 10, 12 and 22).

Here: the contract for outsiders (declined scenes, sustained scenes, wrong signs, a
signed or NaN value, adapters that print), what a code returns read strictly, and our
own reference failing (never the code's failure). Floods, hangs and signals are in
``test_hostile_bench_processes.py``, usage and configuration errors in
``test_hostile_bench_usage.py``.

Every case is a small scripted adapter (`verification/_adapter_script.py`) or a
hand-made record. The expectation of each test is the documented behaviour
(docs/adapter-protocol.md, the exit statuses of ``hcv bench``), never a value read back
from the code under test.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
import subprocess
import sys

import pytest

from reference_impl.adapters import AdapterOutputError, get_adapter
from reference_impl.adapters.base import ImplementedLaw
from reference_impl.adapters.registry import parse_spec
from reference_impl.adapters.subprocess import AdapterDeclined
from reference_impl.bench import run_bench
from reference_impl.bench.scorecard.metrics import METRICS, SceneContext, SpeedRecord
from reference_impl.errors import HCVInputError
from reference_impl.potentials import PowerLaw
from reference_impl.scenes import parse_scene
from verification._adapter_cases import FAST, SCRIPT, ascene, cmd, scene
from verification._adapter_cases import by as _by
from verification._hcv_run import ROOT, hcv

_WALLS = (
    'name = "walls"\nmass = 4.1103e-3\nvelocities = [1.0]\nkind = "two-walls"\n'
    'gap = 1e-4\n[potential]\nfamily = "power"\nk = 1.0879e10\np = 1.5\n'
)


# ----------------------------------------------------------------------------
# issue 12, section 3: an error of ours is never the code's failure
# ----------------------------------------------------------------------------
def test_reference_failure_is_an_internal_error_not_a_metric_failure():
    """The exact solver raising on the implemented law: status "error", gate exit 3."""
    from reference_impl.bench.scorecard import metrics, runner

    real = metrics.exact_reference

    def broken(law, v0, **kw):
        raise NameError("name 'DiracDelta' is not defined")

    runner.exact_reference = broken
    try:
        res = run_bench(cmd(), scenes=[scene(vels=(1.0,))], tolerances=FAST)
    finally:
        runner.exact_reference = real
    statuses = {m.metric: m.status for m in res.metrics}
    assert statuses["restitution_exact"] == "error" and statuses["dt_crit"] == "error"
    assert statuses["restitution_asked"] == "pass"  # needs no exact reference of ours
    assert "fail" not in statuses.values()
    assert (
        "internal error of the reference (ours"
        in _by(res, "small", "restitution_exact").explanation
    )
    assert res.exit_status(gate=True) == 3 and res.exit_status(gate=False) == 0


_BROKEN_REFERENCE_CLI = """
import sys
from reference_impl.bench.scorecard import runner


def broken(law, v0, **kw):
    raise NameError("name 'DiracDelta' is not defined")


runner.exact_reference = broken
from reference_impl.cli import main

sys.exit(main(sys.argv[1:]))
"""


def test_gate_on_an_error_of_ours_exits_3_and_says_so(tmp_path):
    """``hcv bench --gate`` when only our reference failed: exit 3, the scorecard lists each
    undecided metric once as ERROR (ours), JUnit has <error> (not <failure>), JSON "error"."""
    import xml.etree.ElementTree as ET

    (tmp_path / "s.toml").write_text(
        'name = "s"\nmass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = "power"\n'
        'k = 1.0\np = 1.5\n[damping]\nlaw = "universal"\nzeta = 0.1\n'
    )
    (tmp_path / "fast.toml").write_text(
        "[dt_crit]\nresolution = 0.05\n[run]\nspeed_error_steps = [50, 100, 200]\n"
    )
    (tmp_path / "cli.py").write_text(_BROKEN_REFERENCE_CLI)
    r = subprocess.run(
        [sys.executable, "cli.py", "bench", "reference", "--scenes", "s.toml", "--tolerances",
         "fast.toml", "--gate", "--junit", "b.xml", "--json", "b.json"],
        cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True,
        text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 3, r.stdout[-3000:] + r.stderr[-2000:]
    out = r.stdout
    assert "FAIL" not in out and "gate: ERROR (internal error of the reference)" in out
    listed = [line for line in out.splitlines() if line.strip().startswith("ERROR (ours) s / ")]
    root = ET.parse(tmp_path / "b.xml").getroot()
    errors = root.findall("./testsuite/testcase/error")
    assert errors and len(listed) == len(errors) == int(root.get("errors")), out
    assert not root.findall("./testsuite/testcase/failure")
    assert json.loads((tmp_path / "b.json").read_text())["status"] == "error"


def test_abs_expression_scene_never_fails_the_reference_adapter(tmp_path):
    """Our own Verlet on abs(q)**2.5: whatever our dt_safe cannot do is "error", never "fail"."""
    path = tmp_path / "abs.toml"
    path.write_text(
        'name = "abs"\nmass = 1.0\nvelocities = [1.0]\n[potential]\n'
        'family = "expression"\nU = "abs(q)**2.5"\n'
    )
    res = run_bench("reference", scenes=[str(path)], tolerances=FAST)
    assert not res.failures, [m.explanation for m in res.failures]
    for m in res.internal_errors:
        assert m.explanation.startswith("internal error of the reference (ours"), m.explanation
    assert res.exit_status(gate=True) == (3 if res.internal_errors else 0)


# ----------------------------------------------------------------------------
# issue 10: the contract for outsiders
# ----------------------------------------------------------------------------
def test_cmd_can_decline_a_scene():
    """{"unsupported": reason} is a skip with the reason, not a failure (contract point 1)."""
    with pytest.raises(AdapterDeclined, match="no model for this scene"):
        get_adapter(cmd("--mode", "decline")).impact(ascene())
    res = run_bench(
        cmd("--mode", "decline", "--above", "1"),
        scenes=[scene("ok", vels=(0.5,)), scene("no", vels=(2.0,))],
        tolerances=FAST,
    )
    assert {m.status for m in res.metrics if m.scene == "no"} == {"skip"}
    assert (
        "declined by the code: no model for this scene"
        in _by(res, "no", "restitution_exact").explanation
    )
    assert _by(res, "ok", "restitution_exact").status == "pass"
    assert res.exit_status(gate=True) == 0


_DECLINER = """
from reference_impl.adapters import AdapterDeclined
from reference_impl.adapters.reference import ReferenceAdapter


class Decliner(ReferenceAdapter):
    name = "decliner"
    isolate = {isolate}

    def _impact_impl(self, scene):
        if scene.v0 > 1.0:
            raise AdapterDeclined("no model above 1 m/s")
        return super()._impact_impl(scene)
"""


@pytest.mark.parametrize("isolate", [False, True], ids=["in-process", "worker"])
def test_python_adapter_can_decline_a_scene_at_run_time(tmp_path, monkeypatch, isolate):
    """AdapterDeclined raised by a Python adapter (in-process or in the worker) is a skip
    with its reason, like a cmd: program's {"unsupported": reason} (contract item 7)."""
    from reference_impl.adapters import AdapterDeclined as exported

    assert exported is AdapterDeclined  # one class for both forms
    (tmp_path / "decliner_mod.py").write_text(_DECLINER.format(isolate=isolate))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), str(tmp_path)]))
    res = run_bench(
        "decliner_mod:Decliner",
        scenes=[scene("ok", vels=(0.5,)), scene("no", vels=(2.0,))],
        tolerances=FAST,
    )
    assert {m.status for m in res.metrics if m.scene == "no"} == {"skip"}
    why = _by(res, "no", "restitution_exact").explanation
    assert "declined by the code: no model above 1 m/s" in why, why
    assert _by(res, "ok", "restitution_exact").status == "pass"
    assert res.exit_status(gate=True) == 0


def test_cmd_declares_sustained_scenes_in_its_spec():
    assert parse_spec("cmd[sustained=true,timeout=5]:./code --x") == (
        "subprocess",
        {"command": "./code --x", "sustained": True, "timeout": 5},
    )
    walls = parse_scene(_WALLS, "<test>/walls.toml")
    res = run_bench(
        cmd().replace("cmd:", "cmd[sustained=true]:", 1),
        scenes=[walls, scene("ok", vels=(0.5,))],
        tolerances=FAST,
    )
    drift = _by(res, "walls", "energy_drift")
    assert drift.status == "skip" and "no two-walls model" in drift.explanation
    assert _by(res, "ok", "restitution_exact").status == "pass"


def test_one_scene_catalogue():
    """The bench's default scenes are ordinary embedded scenes (contract point 2)."""
    from reference_impl.bench.scorecard.runner import DEFAULT_SCENES
    from reference_impl.scenes import embedded_scenes

    assert set(DEFAULT_SCENES) <= set(embedded_scenes())
    r = hcv(["solve", "hooke-damped", "--json"], ROOT)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["results"]
    # p = 1 with restitution 0.5 asked: the linear oscillator's e is 0.5 at every speed.
    assert all(abs(row["restitution"] - 0.5) < 1e-12 for row in rows)
    assert "hertz-walls" in hcv(["scenes"], ROOT).stdout


@pytest.mark.parametrize(
    "mode, message",
    [
        ("flipq", "q must be positive in contact (got q[1] = -"),
        ("flipv", "v = dq/dt must be positive while approaching (got v[0] = -"),
        ("flipf", "force must be positive (repulsive) in contact (got -"),
    ],
)
def test_sign_conventions_are_checked_first(mode, message):
    res = run_bench(cmd("--mode", mode), scenes=[scene(vels=(1.0,))], tolerances=FAST)
    m = _by(res, "small", "restitution_exact")
    assert m.status == "fail" and message in m.explanation, m.explanation
    assert "did not separate" not in m.explanation and "unstable" not in m.explanation


def _ctx(quantity: str, value: float, exact: float) -> SceneContext:
    law = ImplementedLaw(PowerLaw(1.0, 1.5), 1.0, zeta=0.1)
    meas = {
        "separated": True,
        "finite": True,
        "restitution": 0.7,
        "energy_ratio": 0.49,
        "contact_time": 1.0,
        "max_penetration": 1.0,
        "tensile": 0.0,
        quantity: value,
    }
    ex = {
        "restitution": 0.7,
        "energy_ratio": 0.49,
        "contact_time": 1.0,
        "max_penetration": 1.0,
        "tensile": 0.0,
        quantity: exact,
    }
    ctx = SceneContext("code", "s", "impact", damped=False)
    for v0 in (1.0, 2.0):
        ctx.speeds.append(
            SpeedRecord(
                v0=v0,
                asked_e=1.0,
                law=law,
                exact=dict(ex),
                measured=dict(meas),
                dt_crit={"ratio": 1.0, "verlet_ratio": 1.0, "dt_crit": 1.0},
                textbook=dict.fromkeys(
                    ("restitution", "contact_time", "max_penetration", "energy_ratio", "tensile"),
                    0.0,
                ),
            )
        )
    ctx.order = ctx.textbook_order = 2.0
    return ctx


@pytest.mark.parametrize(
    "metric, quantity, value, exact",
    [
        ("restitution_v0_spread", "restitution", -0.343, 0.343),  # the reported case
        ("restitution_exact", "restitution", -0.7, 0.7),
        ("contact_time", "contact_time", -1.0, 1.0),
        ("max_penetration", "max_penetration", -1.0, 1.0),
        ("attractive_force", "tensile", -0.005, 0.0),
        ("restitution_v0_spread", "restitution", math.nan, 0.7),
    ],
)
def test_a_signed_or_nan_value_never_passes(metric, quantity, value, exact):
    """Every magnitude metric: a negative (wrong sign) or NaN measurement fails (point 5)."""
    m = next(x for x in METRICS if x.name == metric)
    from reference_impl.bench.scorecard.tolerances import default_tolerances

    res = m.evaluate(_ctx(quantity, value, exact), default_tolerances())
    assert res.status == "fail", (metric, res)


def test_python_adapter_printing_to_stdout_is_warned_once(capsys):
    res = run_bench(
        "verification._adapter_script:ChattyAdapter",
        scenes=[scene(vels=(0.5, 1.0))],
        tolerances=FAST,
    )
    err = capsys.readouterr().err
    assert err.count("printed") == 1, err
    assert "verification._adapter_script:ChattyAdapter" in err and "chatty-adapter" in err
    assert _by(res, "small", "restitution_exact").status == "pass"


def test_module_class_from_the_current_directory(tmp_path, monkeypatch):
    (tmp_path / "my_code_adapter.py").write_text(
        "from verification._adapter_script import ScriptAdapter\n\n"
        "class MyCode(ScriptAdapter):\n    name = 'my-code'\n"
    )
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(tmp_path))])
    assert type(get_adapter("my_code_adapter:MyCode")).__name__ == "MyCode"
    res = run_bench("my_code_adapter:MyCode", scenes=[scene(vels=(0.5,))], tolerances=FAST)
    assert _by(res, "small", "restitution_exact").status == "pass"
    with pytest.raises(HCVInputError, match="current directory .* is on the import path"):
        get_adapter("no_such_adapter_module:X")


def test_reports_are_written_0644_under_umask_022(tmp_path):
    old = os.umask(0o022)
    try:
        run_bench(
            cmd(),
            scenes=[scene(vels=(1.0,))],
            tolerances=FAST,
            json_path=tmp_path / "b.json",
            junit_path=tmp_path / "b.xml",
        )
    finally:
        os.umask(old)
    for name in ("b.json", "b.xml"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o644, name


def test_script_path_is_usable():
    assert SCRIPT.exists()


# ----------------------------------------------------------------------------
# issues 12 and 22: what a code returns is read strictly
# ----------------------------------------------------------------------------
def test_deeply_nested_json_answer_is_malformed_output(tmp_path):
    prog = tmp_path / "deep.py"
    prog.write_text("import sys; sys.stdout.write('[' * 100000 + ']' * 100000)\n")
    with pytest.raises(AdapterOutputError):
        get_adapter(f"cmd:{sys.executable} {prog}").impact(ascene())


def _response(**changes) -> dict:
    data = {"t": [0.0, 1.0, 2.0], "q": [0.0, 0.5, -0.1], "v": [1.0, 0.0, -1.0]}
    data["force"] = [0.0, 1.0, 0.0]
    data.update(changes)
    return data


@pytest.mark.parametrize(
    "changes",
    [
        {"q": ["0.0", "0.5", "-0.1"]},
        {"v": [1.0, "0", -1.0]},
        {"force": [0.0, True, 0.0]},
        {"t": "0 1 2"},
        {"q": {"0": 0.0}},
    ],
    ids=["q-strings", "one-string", "bool", "text", "object"],
)
def test_trajectory_values_must_be_numbers_not_text(changes):
    from reference_impl.adapters.base import trajectory_from_mapping

    with pytest.raises(AdapterOutputError, match="is not an array of numbers"):
        trajectory_from_mapping(_response(**changes), who="code")


@pytest.mark.parametrize(
    "law, needle",
    [
        ({"clips_tension": "yes"}, "clips_tension' must be true or false"),
        ({"clips_tension": 1}, "clips_tension' must be true or false"),
        ({"clip_tension": True}, "unknown key 'implemented_law.clip_tension'"),
        ({"dampign": {"law": "none"}}, "unknown key 'implemented_law.dampign'"),
        ({"damping": {"law": "universal", "zeta": 0.1, "c": 2}}, "damping.c"),
        ({"damping": {"law": "universal", "zeta": "0.1"}}, "bad 'implemented_law.damping'"),
        ({"damping": {"law": "power", "c": "3.2"}}, "bad 'implemented_law.damping'"),
        ({"mass": True}, "needs mass > 0"),
        ({"description": ["x"]}, "description' must be a string"),
    ],
)
def test_implemented_law_is_read_strictly(law, needle):
    from reference_impl.adapters.subprocess import law_from_json

    with pytest.raises(AdapterOutputError, match=re.escape(needle)):
        law_from_json(law, ascene(), "code")
