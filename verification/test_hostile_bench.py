"""Hostile input to ``hcv bench`` and the adapter contract (issues 10 and 12).

Every case is a small scripted adapter (`verification/_adapter_script.py`, the
``yes`` and ``sleep`` programs) or a hand-made record: output floods, hangs,
Ctrl-C, declined scenes, wrong signs, our own reference failing, output paths
that cannot be written. The expectation of each test is the documented
behaviour (docs/adapter-protocol.md, the exit statuses of ``hcv bench``), never
a value read back from the code under test.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from reference_impl.adapters import AdapterOutputError, get_adapter
from reference_impl.adapters.base import ImplementedLaw
from reference_impl.adapters.registry import parse_spec
from reference_impl.adapters.subprocess import AdapterDeclined, response_limit
from reference_impl.bench import run_bench
from reference_impl.bench.metrics import METRICS, SceneContext, SpeedRecord
from reference_impl.cli import main
from reference_impl.errors import HCVInputError
from reference_impl.potentials import PowerLaw
from reference_impl.scenes import parse_scene

from .test_adapters import FAST, SCRIPT, _by, ascene, cmd, scene

ROOT = Path(__file__).resolve().parent.parent
_WALLS = (
    'name = "walls"\nmass = 4.1103e-3\nvelocities = [1.0]\nkind = "two-walls"\n'
    'gap = 1e-4\n[potential]\nfamily = "power"\nk = 1.0879e10\np = 1.5\n'
)


def _hcv(args, cwd, timeout=120):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _processes_with(needle: str) -> list[int]:
    """PIDs whose command line starts with ``needle`` (Linux /proc)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                line = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            if line.startswith(needle):
                pids.append(int(entry.name))
    return pids


# ----------------------------------------------------------------------------
# issue 12, section 1: resources and signals
# ----------------------------------------------------------------------------
def test_output_flood_is_capped_while_reading_and_the_command_killed():
    """`cmd:yes` writes without end: stopped at the response bound, not at exit."""
    s = ascene()
    t0 = time.perf_counter()
    with pytest.raises(AdapterOutputError, match="more than .* bytes on stdout"):
        get_adapter("cmd:yes hcv-flood-marker").impact(s)
    assert time.perf_counter() - t0 < 20
    assert not _processes_with("yes hcv-flood-marker")
    # The bound follows the step budget (a sample is 4 numbers) and never exceeds 32 MiB.
    assert response_limit(s.n_steps) < response_limit(10 * s.n_steps) <= 32 << 20


def test_python_flood_is_capped_too():
    with pytest.raises(AdapterOutputError, match="the command was stopped"):
        get_adapter(cmd("--mode", "flood")).impact(ascene())


def test_python_adapter_flooding_its_output_is_stopped():
    """A worker writing without end is killed at the output bound, long before its timeout."""
    t0 = time.perf_counter()
    res = run_bench(
        "verification._adapter_script:FloodAdapter",
        scenes=[scene("ok", vels=(0.5,)), scene("bad", vels=(2.0,))],
        tolerances=FAST,
    )
    assert time.perf_counter() - t0 < 50
    bad = _by(res, "bad", "restitution_exact")
    assert bad.status == "fail" and "bytes of output; stopped" in bad.explanation
    assert _by(res, "ok", "restitution_exact").status == "pass"


def test_after_a_timeout_the_scene_s_other_runs_are_not_run():
    """Two hanging speeds with a 1 s timeout: one timeout, then a clear reason, quickly."""
    tol = {**FAST, "run": {**FAST["run"], "timeout": 1.0}}
    t0 = time.perf_counter()
    res = run_bench(cmd("--mode", "hang"), scenes=[scene("h", vels=(0.5, 2.0))], tolerances=tol)
    assert time.perf_counter() - t0 < 30
    recs = res.contexts[0].speeds
    assert "timeout after 1 s" in recs[0].error
    assert "not run: an earlier run on this scene timed out after 1 s" in recs[1].error
    assert _by(res, "h", "restitution_exact").status == "fail"


def test_ctrl_c_on_a_gate_kills_the_adapter_and_says_interrupted(tmp_path):
    (tmp_path / "s.toml").write_text(
        'name = "s"\nmass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = "power"\n'
        "k = 1.0\np = 1.5\n"
    )
    marker = "97.5312"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "reference_impl.cli",
            "bench",
            f"cmd:sleep {marker}",
            "--scenes",
            "s.toml",
            "--gate",
            "--json",
            "out.json",
        ],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 60
    while not _processes_with(f"sleep {marker}") and time.time() < deadline:
        time.sleep(0.2)
    assert _processes_with(f"sleep {marker}"), "the adapter never started"
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, (out, err)
    assert err.strip().splitlines()[-1] == "hcv: interrupted", err
    assert "gate:" not in out and "Traceback" not in err
    assert not _processes_with(f"sleep {marker}")
    assert json.loads((tmp_path / "out.json").read_text())["status"] == "interrupted"


def test_progress_lines_when_not_on_a_terminal(tmp_path):
    (tmp_path / "s.toml").write_text(
        'name = "s"\nmass = 4.1103e-3\nvelocities = [1.0]\n[potential]\nfamily = "power"\n'
        "k = 1.0879e10\np = 1.5\n"
    )
    (tmp_path / "fast.toml").write_text(
        "[dt_crit]\nresolution = 0.05\n[run]\nspeed_error_steps = [50, 100, 200]\n"
    )
    r = _hcv(["bench", "reference", "--scenes", "s.toml", "--tolerances", "fast.toml"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "0 of 1 scene runs done" in r.stderr and "1 of 1 scene runs done" in r.stderr


@pytest.mark.parametrize(
    "field, text, message",
    [
        ("velocities", "velocities = [" + ", ".join(["1.0"] * 40) + "]", "at most 32 per scene"),
        (
            "zeta",
            "velocities = [1.0]\n[damping]\nlaw = 'universal'\nzeta = 1.5",
            "needs damping zeta < 1",
        ),
    ],
)
def test_bench_bounds_are_checked_before_work(tmp_path, field, text, message):
    path = tmp_path / "s.toml"
    path.write_text(
        f"name = 's'\nmass = 1.0\n{text}\n".replace(
            "[damping]", "[potential]\nfamily = 'power'\nk = 1.0\np = 1.5\n[damping]"
        )
        + (
            ""
            if "[potential]" in text or "damping" in text
            else "[potential]\nfamily = 'power'\nk = 1.0\np = 1.5\n"
        )
    )
    with pytest.raises(HCVInputError, match=message):
        run_bench("reference", scenes=[str(path)])


@pytest.mark.parametrize(
    "override, message",
    [
        ({"run": {"sustained_steps": 10**12}}, "must be <= 1e+07"),
        ({"run": {"steps_per_contact": 10**9}}, "must be <= 100000"),
        ({"run": {"speed_error_steps": [2, 10**9]}}, "each <= 100000"),
        ({"run": {"speed_error_steps": list(range(2, 40))}}, "at most 12 values"),
        ({"run": {"timeout": 1e300}}, "must be <= 86400"),
        ({"dt_crit": {"resolution": 1e-12}}, "must be >= 0.0001"),
    ],
)
def test_tolerance_sizes_are_bounded(override, message):
    from reference_impl.bench import load_tolerances

    with pytest.raises(HCVInputError, match=re.escape(message)):
        load_tolerances(override)


def test_too_many_scenes_is_refused():
    with pytest.raises(HCVInputError, match="at most 64"):
        run_bench("reference", scenes=["hertz"] * 65)


# ----------------------------------------------------------------------------
# issue 12, section 3: an error of ours is never the code's failure
# ----------------------------------------------------------------------------
def test_reference_failure_is_an_internal_error_not_a_metric_failure():
    """The exact solver raising on the implemented law: status "error", gate exit 3."""
    from reference_impl.bench import metrics, runner

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
from reference_impl.bench import runner


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
    from reference_impl.bench.runner import DEFAULT_SCENES
    from reference_impl.scenes import embedded_scenes

    assert set(DEFAULT_SCENES) <= set(embedded_scenes())
    r = _hcv(["solve", "hooke-damped", "--json"], ROOT)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["results"]
    # p = 1 with restitution 0.5 asked: the linear oscillator's e is 0.5 at every speed.
    assert all(abs(row["restitution"] - 0.5) < 1e-12 for row in rows)
    assert "hertz-walls" in _hcv(["scenes"], ROOT).stdout


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
    from reference_impl.bench.tolerances import default_tolerances

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


# ----------------------------------------------------------------------------
# issue 12, section 4: one line and exit 2
# ----------------------------------------------------------------------------
def _one_line_exit_2(capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], err


@pytest.mark.parametrize("option", ["--json", "--junit", "--markdown", "--plot"])
def test_output_paths_are_checked_before_work(tmp_path, capsys, option):
    _one_line_exit_2(
        capsys, ["bench", "reference", option, str(tmp_path / "no" / "f")], "does not exist"
    )
    _one_line_exit_2(capsys, ["bench", "reference", option, str(tmp_path)], "is a directory")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into any directory")
def test_unwritable_output_directory(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    _one_line_exit_2(capsys, ["bench", "reference", "--json", str(ro / "b.json")], "not writable")


def test_report_out_checked_before_work(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    _one_line_exit_2(capsys, ["report", "--out", str(tmp_path / "file")], "not a directory")
    _one_line_exit_2(capsys, ["report", "--out", str(tmp_path / "a" / "b")], "does not exist")


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["bench", 'cmd:python "unbalanced'], "check its quotes"),
        (["bench", "subprocess"], "needs the argument(s) command; use cmd:COMMAND"),
        (["bench", "reference", "--scenes", ""], "names no scene"),
        (["bench", "reference", "--scenes", " , "], "names no scene"),
        (["bench", "cmd[timeout=1,timeout=2]:x"], "repeats"),
    ],
)
def test_bench_usage_errors_are_one_line(capsys, argv, needle):
    _one_line_exit_2(capsys, argv, needle)


def test_deeply_nested_json_answer_is_malformed_output(tmp_path):
    prog = tmp_path / "deep.py"
    prog.write_text("import sys; sys.stdout.write('[' * 100000 + ']' * 100000)\n")
    with pytest.raises(AdapterOutputError):
        get_adapter(f"cmd:{sys.executable} {prog}").impact(ascene())


def test_script_path_is_usable():
    assert SCRIPT.exists()


# ----------------------------------------------------------------------------
# issue 22: lenient inputs refused, SIGTERM, adapters that daemonise
# ----------------------------------------------------------------------------
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


@pytest.mark.parametrize(
    "spec, needle",
    [
        ("cmd[sustained=maybe]:yes", "sustained must be true or false"),
        ("cmd[sustained=1]:yes", "sustained must be true or false"),
        ("cmd[label=3]:yes", "label must be text"),
        ("cmd:/nonexistent/prog", "does not exist"),
        ("cmd:./no-such-program --flag", "does not exist"),
        ("cmd:no-such-program-hcv-22", "not found on PATH"),
    ],
)
def test_adapter_configuration_errors_are_exit_2_not_a_code_failure(capsys, spec, needle):
    with pytest.raises(HCVInputError, match=re.escape(needle)):
        get_adapter(spec)
    _one_line_exit_2(capsys, ["bench", spec, "--scenes", "hertz"], needle)


def test_a_program_that_is_not_executable_is_a_configuration_error(tmp_path, capsys):
    prog = tmp_path / "code.sh"
    prog.write_text("#!/bin/sh\n")
    prog.chmod(0o644)
    _one_line_exit_2(capsys, ["bench", f"cmd:{prog}", "--scenes", "hertz"], "not executable")


def test_scenes_given_twice_are_all_run(capsys):
    """``--scenes a --scenes b`` names both (argparse's default kept only b)."""
    from reference_impl import cli
    from reference_impl.cli.bench import _scene_args

    args = cli._parser().parse_args(
        ["bench", "reference", "--scenes", "hertz", "--scenes", "hooke-damped,hertz-damped"]
    )
    got = _scene_args(args.scenes)
    assert got == ["hertz", "hooke-damped", "hertz-damped"], (
        f"got {got}, should be all three scenes [issue 22, --scenes twice]"
    )


def _start_hcv(args, cwd) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "reference_impl.cli", *args],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for(needle: str, seconds: float = 90) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if _processes_with(needle):
            return True
        time.sleep(0.1)
    return False


def _gone(needle: str, seconds: float = 5) -> bool:
    """No process starts with ``needle`` (a SIGKILLed process may take a moment to go)."""
    deadline = time.monotonic() + seconds
    while _processes_with(needle) and time.monotonic() < deadline:
        time.sleep(0.1)
    return not _processes_with(needle)


def _kill_leftovers(needle: str) -> None:
    for pid in _processes_with(needle):  # only our marker processes, by pid
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def test_sigterm_to_bench_kills_the_adapter_and_exits_143(tmp_path):
    """SIGTERM (CI's cancel) is handled as Ctrl-C: adapter killed, JSON written, 143."""
    (tmp_path / "s.toml").write_text(
        'name = "s"\nmass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = "power"\n'
        "k = 1.0\np = 1.5\n"
    )
    marker = "97.6123"
    proc = _start_hcv(
        ["bench", f"cmd:sleep {marker}", "--scenes", "s.toml", "--json", "out.json"], tmp_path
    )
    try:
        assert _wait_for(f"sleep {marker}"), "the adapter never started"
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 143, f"got exit {proc.returncode} ({err[-400:]}), should be 143"
        assert err.strip().splitlines()[-1] == "hcv: terminated (SIGTERM)", err[-400:]
        assert "Traceback" not in err
        assert _gone(f"sleep {marker}"), "got the adapter still running after SIGTERM"
        assert json.loads((tmp_path / "out.json").read_text())["status"] == "interrupted"
    finally:
        proc.kill()
        _kill_leftovers(f"sleep {marker}")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="subreaper is Linux only")
@pytest.mark.parametrize("how", ["completes", "sigterm"])
def test_an_adapter_that_daemonises_leaves_nothing_running(tmp_path, how):
    """Each run leaves ``sleep`` in a new session (escapes killpg); hcv kills them at its end."""
    (tmp_path / "s.toml").write_text(
        'name = "s"\nmass = 4.1103e-3\nvelocities = [1.0]\n[potential]\nfamily = "power"\n'
        "k = 1.0879e10\np = 1.5\n"
    )
    (tmp_path / "tol.toml").write_text(
        "[dt_crit]\nresolution = 0.25\n[run]\nspeed_error_steps = [50, 100, 200]\n"
    )
    marker = "96.4417" if how == "completes" else "96.4418"
    adapter = f"cmd:{sys.executable} {SCRIPT} --daemon {marker}"
    proc = _start_hcv(
        ["bench", adapter, "--scenes", "s.toml", "--tolerances", "tol.toml"], tmp_path
    )
    try:
        assert _wait_for(f"sleep {marker}"), "the adapter never started"
        if how == "sigterm":
            proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=300)
        want = 143 if how == "sigterm" else 0
        assert proc.returncode == want, (
            f"got exit {proc.returncode} ({err[-400:]}), should be {want}"
        )
        assert _gone(f"sleep {marker}"), (
            f"got {len(_processes_with(f'sleep {marker}'))} daemonised adapter processes left, "
            "should be 0 [issue 22, subreaper]"
        )
    finally:
        proc.kill()
        _kill_leftovers(f"sleep {marker}")


def test_a_missing_program_is_refused_by_report_and_sweep_before_any_work(tmp_path, capsys):
    """``cmd:/nonexistent/prog`` through ``hcv report --adapter`` and a ``bench:`` sweep."""
    out = tmp_path / "rep"
    _one_line_exit_2(
        capsys,
        ["report", "--quick", "--out", str(out), "--adapter", "cmd:/nonexistent/prog"],
        "does not exist",
    )
    spec = tmp_path / "spec.toml"
    spec.write_text(
        'task = "bench:cmd:/nonexistent/prog"\n[scene]\nmass = 1.0\nvelocities = [1.0]\n'
        '[scene.potential]\nfamily = "power"\nk = 1.0\np = 1.5\n[sweep]\nmass = [1.0, 2.0]\n'
    )
    pytest.importorskip("distributed")
    _one_line_exit_2(capsys, ["sweep", str(spec), "--out", str(tmp_path / "sw")], "does not exist")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"], "got files written"
