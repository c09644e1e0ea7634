"""``hcv sweep`` on a real 2-worker LocalCluster: end to end, failures, resume, hangs.

The cluster tests start real ``distributed.LocalCluster`` processes (2 workers)
and run cheap cases (single impacts with a loose criterion, about 10 ms each),
so the whole file takes well under a minute; they skip when dask is absent.
"""

from __future__ import annotations

import json
import os
import textwrap

import pytest

from reference_impl.cli.sweep import run_sweep
from reference_impl.sweep import parse_spec, run_cases
from verification._hcv_run import processes_with
from verification._sweeps import SPEC, cli, needs_dask
from verification.assertions import assert_true


# --------------------------------------------------------------------------
# a real LocalCluster with 2 worker processes
# --------------------------------------------------------------------------
def _square_or_fail(x):
    if x == 3:
        raise ValueError("three is not allowed")
    if x == 4:
        os._exit(7)  # a crash: the worker process dies
    return x * x


@needs_dask
def test_run_cases_on_two_workers_failures_are_rows():
    import dask

    # One death is enough to give up on a case (the default retries it on 3 workers).
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        outs = run_cases(range(6), _square_or_fail, workers=2, errors="return")
    values = [o.value for o in outs]
    assert_true(
        values == [0, 1, 4, None, None, 25],
        got=str(values),
        should="[0, 1, 4, None, None, 25]",
        claim="sweep",
        call="run_cases",
    )
    assert_true(
        "ValueError: three is not allowed" in outs[3].error,
        got=outs[3].error,
        should="the exception's line",
        claim="sweep",
        call="run_cases raising case",
    )
    assert_true(
        "worker died" in outs[4].error,
        got=outs[4].error,
        should="a dead worker",
        claim="sweep",
        call="run_cases crashing case",
    )
    serial = run_cases([0, 1, 2, 5], _square_or_fail, workers=0)
    assert_true(
        serial == [0, 1, 4, 25],
        got=str(serial),
        should="[0, 1, 4, 25]",
        claim="sweep",
        call="run_cases(workers=0)",
    )


@needs_dask
def test_sweep_end_to_end_with_failing_cases_and_resume(tmp_path, capsys):
    import pandas as pd

    spec_path = tmp_path / "impact-map.toml"
    spec_path.write_text(SPEC, encoding="utf-8")
    out = tmp_path / "out"
    code, stdout, err = cli(["sweep", str(spec_path), "--workers", "2", "--out", str(out)], capsys)
    assert_true(
        code == 1 and "6 cases ran, 2 failed to run" in stdout,
        got=f"exit {code}: {stdout}{err}",
        should="exit 1 (some cases failed), 6 ok, 2 failed",
        claim="sweep",
        call="hcv sweep --workers 2",
    )
    df = pd.read_parquet(out / "results.parquet")
    assert_true(
        list(df.columns[:2]) == ["potential.p", "mass"] and len(df) == 8,
        got=f"{list(df.columns[:3])}, {len(df)} rows",
        should="swept parameters first, 8 rows",
        claim="sweep",
        call="results.parquet",
    )
    bad = df[df["error"].notna()]
    assert_true(
        sorted(bad["potential.p"]) == [-1.0, -1.0] and bad["ratio"].isna().all(),
        got=str(bad[["potential.p", "error"]].values.tolist()),
        should="the p = -1 cases failed with their error",
        claim="sweep",
        call="results.parquet",
    )
    # every good row equals `hcv dt-crit --json` on that case alone
    for _, r in df[df["error"].isna()].iterrows():
        case = tmp_path / "case.toml"
        case.write_text(
            f'mass = {r["mass"]!r}\nvelocities = [1.0]\nkind = "impact"\n[potential]\n'
            f'family = "power"\nk = 1.0\np = {r["potential.p"]!r}\n',
            encoding="utf-8",
        )
        code, stdout, _ = cli(
            ["dt-crit", str(case), "--json", "--criterion", "tol=0.5,n_phases=2"], capsys
        )
        alone = json.loads(stdout)["results"][0]
        same = all(alone[k] == r[k] for k in ("dt_safe", "dt_crit", "ratio", "holds"))
        assert_true(
            code == 0 and same,
            got=f"sweep {r['ratio']!r}, alone {alone['ratio']!r}",
            should="identical",
            claim="sweep",
            call=f"p = {r['potential.p']}",
        )
    summary = (out / "summary.md").read_text(encoding="utf-8")
    assert_true(
        "| potential.p | mass |" in summary
        and "dt_crit [s]" in summary
        and "failure_kind" in summary
        and "- failure kinds: " in summary
        and (out / "summary.png").stat().st_size > 0
        and (out / "spec.toml").read_text(encoding="utf-8") == SPEC,
        got=summary[:300],
        should="a table with units and failure kinds, a figure and the spec",
        claim="sweep",
        call="summary.md",
    )
    # Without --resume an existing sweep is refused.
    code, _, err = cli(["sweep", str(spec_path), "--out", str(out)], capsys)
    assert_true(
        code == 2 and "--resume" in err,
        got=f"{code} {err!r}",
        should="exit 2",
        claim="sweep",
        call="hcv sweep (existing DIR)",
    )
    # A killed sweep: 4 complete lines and one cut in the middle survive.
    lines = (out / "cases.jsonl").read_text(encoding="utf-8").splitlines(keepends=True)
    (out / "cases.jsonl").write_text("".join(lines[:4]) + lines[4][:40], encoding="utf-8")
    kept = {json.loads(x)["key"]: json.loads(x)["seconds"] for x in lines[:4]}
    spec = parse_spec(SPEC, str(spec_path))
    res = run_sweep(spec, out, workers=2, resume=True, progress=False)
    after = (out / "cases.jsonl").read_text(encoding="utf-8").splitlines()
    rerun = [json.loads(x)["key"] for x in after[5:]]
    assert_true(
        len(rerun) == 4 and not set(rerun) & set(kept) and res["failed"] == 2,
        got=f"{len(rerun)} cases rerun ({res})",
        should="exactly the 4 lost cases",
        claim="sweep",
        call="run_sweep(resume=True)",
    )
    df2 = pd.read_parquet(out / "results.parquet")
    cols = [c for c in df.columns if c not in ("case_seconds", "case_cpu_seconds", "lane_steps")]
    assert_true(
        df2[cols].equals(df[cols]),
        got="a different table after resume",
        should="the same table",
        claim="sweep",
        call="run_sweep(resume=True)",
    )


@needs_dask
def test_a_real_scheduler_passes_the_probe_and_runs_the_cases():
    """The identity probe (bounded handshake) accepts a Dask scheduler: cases run there.

    An in-process cluster (threads, no worker processes) keeps this to about a second.
    """
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        got = run_cases([1, 2, 5], _square_or_fail, scheduler=cluster.scheduler_address)
    assert got == [1, 4, 25], f"got {got}, should be [1, 4, 25] [issue 22, --scheduler probe]"


# --------------------------------------------------------------------------
# issue 22: hangs
# --------------------------------------------------------------------------
class _NotAScheduler:
    """A plain TCP server on 127.0.0.1: accepts and stays silent, or answers HTTP."""

    def __init__(self, reply: bytes = b""):
        import socket
        import threading

        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.port = self.sock.getsockname()[1]
        self.reply, self.conns = reply, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.reply:
                conn.sendall(self.reply)

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


@needs_dask
@pytest.mark.parametrize(
    "reply, needle",
    [
        (b"", "no Dask scheduler answered within 1 s"),
        (b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nhi" * 4, "not answer as a Dask scheduler"),
    ],
    ids=["silent", "http"],
)
def test_scheduler_address_of_another_service_times_out_in_one_line(
    tmp_path, capsys, monkeypatch, reply, needle
):
    """Issue 22: ``--scheduler`` naming a non-Dask listener hung forever; now exit 2."""
    import time

    from reference_impl.sweep import _runner

    monkeypatch.setattr(_runner, "_CONNECT_TIMEOUT", 1.0)  # 10 s in use
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    server = _NotAScheduler(reply)
    try:
        t0 = time.monotonic()
        code, out, err = cli(
            [
                "sweep",
                str(spec),
                "--scheduler",
                f"tcp://127.0.0.1:{server.port}",
                "--out",
                str(tmp_path / "out"),
            ],
            capsys,
        )
        waited = time.monotonic() - t0
    finally:
        server.close()
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and needle in lines[0], (
        f"got exit {code}, stderr {err!r}, should be 2 with one line naming {needle!r}"
    )
    # The bound is the 1 s timeout plus start-up; a hang would never return.
    assert waited < 30, f"got {waited:.1f} s, should return after the 1 s timeout"
    assert not (tmp_path / "out").exists()


@needs_dask
@pytest.mark.skipif(not os.path.isdir("/proc"), reason="process listing needs /proc")
def test_sigterm_to_a_bench_sweep_leaves_no_adapter_running(tmp_path):
    """Issue 22: SIGTERM (CI's cancel) to ``hcv sweep`` of ``bench:`` left the adapters running.

    One worker, one case whose adapter is ``sleep MARKER`` (it never answers): SIGTERM
    once it runs; hcv must exit 143 with nothing of it left (the adapter runs in its
    own session, below a worker process of the local cluster).
    """
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    marker = "95.3391"
    spec = tmp_path / "spec.toml"
    spec.write_text(
        textwrap.dedent(
            f"""
            task = "bench:cmd:sleep {marker}"
            [scene]
            name = "s"
            mass = 1.0
            velocities = [1.0]
            [scene.potential]
            family = "power"
            k = 1.0
            p = 1.5
            [sweep]
            mass = [1.0]
            """
        )
    )

    def running() -> list[int]:
        return processes_with(f"sleep {marker}")

    root = Path(__file__).resolve().parents[1]
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "reference_impl.cli",
            "sweep",
            str(spec),
            "--workers",
            "1",
            "--out",
            str(tmp_path / "out"),
        ],
        env={**os.environ, "PYTHONPATH": str(root)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        # Wait for the adapter, or for hcv to end without starting it (then say why).
        deadline = time.monotonic() + 120
        while not running() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.2)
        if not running():
            proc.kill()
            _, err = proc.communicate(timeout=60)
            pytest.fail(
                f"got no adapter process (hcv sweep ended with exit {proc.returncode}, or was "
                f"killed after 120 s: stderr {err[-800:]!r}), should be one "
                "running before SIGTERM is sent [issue 22, hcv sweep bench:cmd:sleep]"
            )
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 143, f"got exit {proc.returncode} ({err[-400:]}), should be 143"
        deadline = time.monotonic() + 5
        while running() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not running(), "got the adapter still running after SIGTERM [issue 22]"
    finally:
        proc.kill()
        for pid in running():  # only the marker processes, by pid
            os.kill(pid, signal.SIGKILL)


@needs_dask
def test_ctrl_c_on_a_sweep_prints_one_line(tmp_path):
    """Ctrl-C reaches the whole process group; the workers must not print tracebacks."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    # The documentation's example, its 8 cases repeated over 8 masses: 64 searches keep the
    # two workers busy for seconds after the first progress line, on any machine, so the
    # Ctrl-C lands while cases run (the 8 alone may all finish before it on many cores).
    example = (root / "docs" / "examples" / "sweep-hertz-map.toml").read_text()
    spec = tmp_path / "spec.toml"
    spec.write_text(example + '"mass" = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]\n')
    p = subprocess.Popen(
        [sys.executable, "-m", "reference_impl.cli", "sweep", str(spec), "--workers", "2",
         "--out", str(tmp_path / "out")],
        cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(root)}, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    seen = []  # what hcv wrote before it was ready, kept for the message
    while not (seen and seen[-1].startswith("sweep:")):  # the cluster is up and running
        line = p.stderr.readline()
        if not line:
            break
        seen.append(line)
    time.sleep(0.5)  # cases in flight on both workers
    ready = p.poll() is None and seen and seen[-1].startswith("sweep:")
    if not ready:
        p.kill()
        _, err = p.communicate(timeout=60)
        pytest.fail(
            f"got hcv sweep ended (exit {p.returncode}) before Ctrl-C, stderr "
            f"{(''.join(seen) + err)[-800:]!r}, should be running its cases [sweep, Ctrl-C]"
        )
    os.killpg(p.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole group
    _, err = p.communicate(timeout=120)
    err = "".join(seen) + err
    rest = [x for x in err.splitlines() if not x.startswith("sweep:")]
    assert_true(
        p.returncode == 130 and rest == ["interrupted"],
        got=f"exit {p.returncode}, stderr {err[-800:]!r}",
        should="exit 130 and the one line 'interrupted'",
        claim="sweep",
        call="Ctrl-C on hcv sweep",
    )
