"""Hostile input to ``hcv bench`` (issues 12 and 22): resources and signals.

Output floods, hangs, Ctrl-C and SIGTERM, adapters that daemonise: each run is stopped
at its bound, ``hcv`` says what happened, and nothing of the code is left running. Every
case is a small scripted adapter (`verification/_adapter_script.py`, the ``yes`` and
``sleep`` programs); the expectation is the documented behaviour
(docs/adapter-protocol.md, the exit statuses of ``hcv bench``).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from reference_impl.adapters import AdapterOutputError, get_adapter
from reference_impl.adapters.subprocess import response_limit
from reference_impl.bench import run_bench
from verification._adapter_cases import FAST, SCRIPT, ascene, cmd, scene
from verification._adapter_cases import by as _by
from verification._hcv_run import ROOT, hcv, processes_with


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
    assert not processes_with("yes hcv-flood-marker")
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
    while not processes_with(f"sleep {marker}") and time.time() < deadline:
        time.sleep(0.2)
    assert processes_with(f"sleep {marker}"), "the adapter never started"
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, (out, err)
    assert err.strip().splitlines()[-1] == "hcv: interrupted", err
    assert "gate:" not in out and "Traceback" not in err
    assert not processes_with(f"sleep {marker}")
    assert json.loads((tmp_path / "out.json").read_text())["status"] == "interrupted"


def test_progress_lines_when_not_on_a_terminal(tmp_path):
    (tmp_path / "s.toml").write_text(
        'name = "s"\nmass = 4.1103e-3\nvelocities = [1.0]\n[potential]\nfamily = "power"\n'
        "k = 1.0879e10\np = 1.5\n"
    )
    (tmp_path / "fast.toml").write_text(
        "[dt_crit]\nresolution = 0.05\n[run]\nspeed_error_steps = [50, 100, 200]\n"
    )
    r = hcv(["bench", "reference", "--scenes", "s.toml", "--tolerances", "fast.toml"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "0 of 1 scene runs done" in r.stderr and "1 of 1 scene runs done" in r.stderr


# ----------------------------------------------------------------------------
# issue 22: SIGTERM, adapters that daemonise
# ----------------------------------------------------------------------------
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
        if processes_with(needle):
            return True
        time.sleep(0.1)
    return False


def _gone(needle: str, seconds: float = 5) -> bool:
    """No process starts with ``needle`` (a SIGKILLed process may take a moment to go)."""
    deadline = time.monotonic() + seconds
    while processes_with(needle) and time.monotonic() < deadline:
        time.sleep(0.1)
    return not processes_with(needle)


def _kill_leftovers(needle: str) -> None:
    for pid in processes_with(needle):  # only our marker processes, by pid
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
    # For SIGTERM the adapter also hangs after daemonising, so that the signal finds hcv
    # still running: a one-scene run that completes can end first (seen in CI, exit 0).
    hang = " --mode hang" if how == "sigterm" else ""
    adapter = f"cmd:{sys.executable} {SCRIPT}{hang} --daemon {marker}"
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
            f"got {len(processes_with(f'sleep {marker}'))} daemonised adapter processes left, "
            "should be 0 [issue 22, subreaper]"
        )
    finally:
        proc.kill()
        _kill_leftovers(f"sleep {marker}")
