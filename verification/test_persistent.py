"""Persistent mode of the adapter protocol and options of ``cmd:`` programs (issue 28).

One process serves many runs (JSON lines); a request that hangs or a process that
dies fails one run with one line and the next run starts a fresh process; banner
lines are skipped; the answer must carry the request's id. ``cmd[KEY=V]:`` options
reach the program in the request, so ``hcv calibrate`` works on a ``cmd:`` program.
Uses `verification/_persistent_script.py` (no third-party code needed).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

from reference_impl import solve_impact
from reference_impl.adapters import AdapterScene, get_adapter
from reference_impl.adapters.base import AdapterOutputError, AdapterRunError
from reference_impl.adapters.subprocess import SubprocessAdapter
from reference_impl.bench.scorecard.runner import resolve_scenes

from .assertions import assert_close, assert_true

HERE = Path(__file__).resolve().parent
SCRIPT = f"{sys.executable} {HERE / '_persistent_script.py'}"
ONESHOT = f"{sys.executable} {HERE / '_adapter_script.py'}"
CLAIM = "bench-persistent"  # the benchmark machinery, not a paper claim


def scene_at(v0: float, name: str = "hertz-damped") -> AdapterScene:
    sc = resolve_scenes([name])[0]
    t_c = solve_impact(sc.potential, sc.mass, v0, sc.zeta or 0.0).contact_time
    return AdapterScene.from_scene(sc, v0, t_c / 50, 200)


def persistent(args: str = "", **kw) -> SubprocessAdapter:
    extra = "".join(f",{k}={v}" for k, v in kw.items())
    return get_adapter(f"cmd[persistent=true{extra}]:{SCRIPT} {args}")


def test_one_process_serves_every_run_with_the_one_shot_results():
    adapter = persistent("--banner")  # the banner lines are skipped
    oneshot = get_adapter(f"cmd:{ONESHOT}")
    try:
        pids = set()
        for v0 in (0.1, 1.0, 5.0):
            tr = adapter.impact(scene_at(v0))
            ref = oneshot.impact(scene_at(v0))
            pids.add(tr.meta["pid"])
            assert_close(tr.q, ref.q, rtol=0, atol=0, claim=CLAIM, call=f"q at v0 = {v0}")
        assert_true(
            len(pids) == 1 and adapter._server.starts == 1,
            got=f"{len(pids)} process ids, {adapter._server.starts} starts",
            should="one process for three runs",
            claim=CLAIM,
            call="cmd[persistent=true]",
        )
    finally:
        adapter.close()
    assert not adapter._server.alive


def test_a_hanging_request_fails_one_run_and_the_next_starts_afresh():
    adapter = persistent("--hang-above 2", timeout=1.5)
    try:
        first = adapter.impact(scene_at(0.1)).meta["pid"]
        with pytest.raises(AdapterRunError, match=r"timeout after") as info:
            adapter.impact(scene_at(5.0))
        assert "\n" not in str(info.value)
        assert getattr(info.value, "timed_out", False)
        after = adapter.impact(scene_at(1.0)).meta["pid"]
        assert after != first and adapter._server.starts == 2
    finally:
        adapter.close()


def test_a_process_dying_between_requests_fails_one_run_in_one_line():
    adapter = persistent("--die-after 1")
    try:
        adapter.impact(scene_at(0.1))
        with pytest.raises(
            AdapterRunError, match=r"ended (between requests|before answering) \(exit status 7\)"
        ) as e:
            adapter.impact(scene_at(1.0))
        assert "\n" not in str(e.value)
        tr = adapter.impact(scene_at(5.0))  # the rest go on, in a fresh process
        assert tr.q.size > 2 and adapter._server.starts == 2
    finally:
        adapter.close()


def test_an_answer_without_the_request_id_is_refused():
    adapter = persistent("--no-id")
    try:
        with pytest.raises(AdapterOutputError, match="carries id None"):
            adapter.impact(scene_at(0.1))
        assert not adapter._server.alive  # replaced: its next answer could be out of step
    finally:
        adapter.close()


def test_options_reach_the_program_in_the_request():
    adapter = get_adapter(f"cmd[zeta_scale=0.5,label=half]:{ONESHOT}")
    assert adapter.options == {"zeta_scale": 0.5}
    per = persistent(zeta_scale=0.5)
    try:
        tr = per.impact(scene_at(1.0))
        assert tr.meta["options"] == {"zeta_scale": 0.5}
        assert per.implemented_law(scene_at(1.0)).zeta == pytest.approx(0.05, rel=1e-15)
        assert per.label.endswith("[zeta_scale=0.5]")
    finally:
        per.close()
    with pytest.raises(Exception, match="must be a finite number"):
        SubprocessAdapter(SCRIPT, zeta_scale=float("nan"))
    with pytest.raises(Exception, match="looks like a misspelt 'sustained'"):
        get_adapter(f"cmd[sustaned=true]:{SCRIPT}")


def test_calibrate_a_cmd_program_through_an_option():
    """hcv calibrate over a cmd: program's option (once refused: "adapter 'subprocess' has
    no option"). The program integrates zeta_scale x the asked zeta, so the option that
    delivers the asked restitution is 1, to the calibration's tolerance plus the first-order
    step error of the half-step dashpot at 200 steps per contact (measured 1e-3)."""
    from reference_impl.bench.calibration.calibrate import calibrate

    res = calibrate(
        f"cmd[persistent=true]:{SCRIPT}",
        "hertz-damped",
        param="zeta_scale",
        target=float(np.exp(-np.pi * 0.1 / np.sqrt(1 - 0.01))),
        bracket=(0.2, 3.0),
    )
    assert res.found, res.message
    assert_close(res.value, 1.0, rtol=3e-3, claim=CLAIM, call=res.message)


def test_the_server_dies_with_a_killed_suite():
    """PR_SET_PDEATHSIG: a server busy with a request dies when the suite's process is
    SIGKILLed (Linux), so no server outlives a killed benchmark."""
    import os
    import signal
    import subprocess
    import time

    if not sys.platform.startswith("linux"):
        pytest.skip("PR_SET_PDEATHSIG is Linux only")
    code = (
        "import sys, shlex\n"
        "from reference_impl.adapters._persistent import PersistentProcess\n"
        f"pp = PersistentProcess(shlex.split({SCRIPT + ' --hang-above 0'!r}), 'hang')\n"
        "pp._start()\nprint(pp._proc.pid, flush=True)\n"
        "pp.request({'scene': {'v0': 1.0}}, timeout=3600, limit=1 << 20)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    server = int(parent.stdout.readline())
    time.sleep(0.5)  # the request is on its way: the server sleeps in it
    parent.send_signal(signal.SIGKILL)
    parent.wait(timeout=10)

    def alive(pid: int) -> bool:
        try:
            with open(f"/proc/{pid}/status") as fh:
                return "\nState:\tZ" not in fh.read()
        except FileNotFoundError:
            return False

    deadline = time.monotonic() + 10
    while alive(server) and time.monotonic() < deadline:
        time.sleep(0.1)
    survived = alive(server)
    if survived:
        os.kill(server, signal.SIGKILL)  # leave nothing behind, then report
    assert not survived, "the server outlived the killed suite process by 10 s"


def test_stderr_is_kept_as_its_last_8000_characters_while_the_process_runs():
    """Issue 36 item 6: a persistent program's stderr went into a temporary file that grew
    without bound (>= 100 MB, then the disk). Now only its last 8000 characters are kept,
    as in one-shot mode: the program's fd 2 is not a growing file, the kept bytes stay
    <= 8000 after 8 MB of log, and a failure still quotes the last lines."""
    import stat

    if not Path("/proc/self/fd").is_dir():
        pytest.skip("needs /proc to see the program's stderr")
    adapter = persistent("--stderr-bytes 4000000 --die-after 3")
    try:
        adapter.impact(scene_at(0.1))
        adapter.impact(scene_at(1.0))
        server = adapter._server
        fd2 = os.stat(f"/proc/{server._proc.pid}/fd/2")
        on_disk = fd2.st_size if stat.S_ISREG(fd2.st_mode) else 0
        assert_true(
            on_disk <= 8000,
            got=f"a {on_disk}-byte file behind the program's stderr after 8 MB of log",
            should="at most 8000 bytes kept (a pipe read while it runs)",
            claim=CLAIM,
            call="cmd[persistent=true] --stderr-bytes 4000000",
        )
        kept = len(server._err) if isinstance(server._err, (bytes, bytearray)) else on_disk
        assert_true(
            kept <= 8000,
            got=f"{kept} bytes of stderr kept",
            should="at most 8000",
            claim=CLAIM,
            call="PersistentProcess._err",
        )
        with pytest.raises(AdapterRunError, match=r"exit status 7") as info:
            adapter.impact(scene_at(5.0))  # answers, logs, exits: fails the next request
            adapter.impact(scene_at(5.0))
        tail = info.value.stderr
        assert_true(
            tail.endswith("end of the log of answer 3") and len(tail) <= 4003,
            got=f"a stderr tail of {len(tail)} characters ending {tail[-40:]!r}",
            should="the last <= 4000 characters, ending with the last line written",
            claim=CLAIM,
            call="AdapterRunError.stderr",
        )
    finally:
        adapter.close()
