"""``hcv sweep``: spec validation, a real 2-worker LocalCluster end to end, failures, resume.

The cluster tests start real ``distributed.LocalCluster`` processes (2 workers)
and run cheap cases (single impacts with a loose criterion, about 10 ms each),
so the whole file takes well under a minute; they skip when dask is absent.
"""

from __future__ import annotations

import json
import os
import textwrap

import pytest
from hypothesis import given
from hypothesis import strategies as st

from reference_impl.cli import main as hcv_main
from reference_impl.cli.sweep import run_sweep
from reference_impl.sweep import (
    MAX_CASES,
    CaseTimeout,
    SweepSpecError,
    parse_spec,
    run_case,
    run_cases,
    spec_from_dict,
)
from reference_impl.sweep._runner import dask_available
from verification.assertions import assert_true

needs_dask = pytest.mark.skipif(
    not dask_available(), reason="dask.distributed not installed (pip install -e '.[sweep]')"
)

# Single impacts with a loose criterion: about 10 ms a case, so the cluster
# tests measure the sweep machinery, not the search.
_SPEC = textwrap.dedent(
    """
    task = "dt-crit"
    criterion = "tol=0.5,n_phases=2"
    [scene]
    name = "impact-map"
    mass = 1.0
    velocities = [1.0]
    kind = "impact"
    [scene.potential]
    family = "power"
    k = 1.0
    p = 1.5
    [sweep]
    "potential.p" = [1.0, 1.5, -1.0, 3.0]
    "mass" = [1.0, 2.0]
    """
)


def _cli(args, capsys):
    code = hcv_main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


# --------------------------------------------------------------------------
# spec validation (no cluster)
# --------------------------------------------------------------------------
def test_example_spec_expands_to_the_cartesian_product():
    spec = parse_spec(_SPEC, "t")
    params = [tuple(c.params.values()) for c in spec.cases]
    want = [(p, m) for p in (1.0, 1.5, -1.0, 3.0) for m in (1.0, 2.0)]
    assert_true(
        params == want,
        got=str(params),
        should=str(want),
        claim="sweep",
        call="parse_spec: last key varies fastest",
    )
    keys = {c.key for c in spec.cases}
    assert_true(
        len(keys) == 8,
        got=f"{len(keys)} distinct keys",
        should="8",
        claim="sweep",
        call="parse_spec keys",
    )
    again = [c.key for c in parse_spec(_SPEC, "other-name").cases]
    assert_true(
        again == [c.key for c in spec.cases],
        got="keys changed with the source name",
        should="keys depend on the parameters only",
        claim="sweep",
        call="parse_spec",
    )
    other = parse_spec(_SPEC.replace("tol=0.5", "tol=0.4"), "t")
    assert_true(
        not keys & {c.key for c in other.cases},
        got="same keys for another criterion",
        should="different keys",
        claim="sweep",
        call="parse_spec keys",
    )
    bad = [c for c in spec.cases if c.error]
    assert_true(
        [c.params["potential.p"] for c in bad] == [-1.0, -1.0],
        got=str([c.params for c in bad]),
        should="the two p = -1 cases invalid",
        claim="sweep",
        call="parse_spec",
    )
    assert_true(
        "potential.p" in bad[0].error and "-1" in bad[0].error,
        got=bad[0].error,
        should="an error naming potential.p = -1",
        claim="sweep",
        call="parse_spec",
    )


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda s: s.replace('task = "dt-crit"', 'task = "dtcrit"'), "task"),
        (lambda s: s.replace('task = "dt-crit"', 'task = "dt-crit"\nworkers = 3'), "workers"),
        (lambda s: s.replace('"mass" = [1.0, 2.0]', '"mass" = 2.0'), "mass"),
        (lambda s: s.replace('"mass" = [1.0, 2.0]', '"mass" = [1.0, 1.0]'), "repeats"),
        (lambda s: s.replace('"mass" = [1.0, 2.0]', '"mass" = []'), "mass"),
        (lambda s: s.replace("tol=0.5,n_phases=2", "factor=10"), "factor"),
        (lambda s: s.replace('task = "dt-crit"', 'task = "solve"'), "criterion"),
        (
            lambda s: s.replace('"potential.p" = [1.0, 1.5, -1.0, 3.0]', '"potential.q" = [1, 2]'),
            "potential.q",
        ),
        (
            lambda s: s + '"velocities" = [' + ", ".join(str(1 + i) for i in range(20_000)) + "]\n",
            str(MAX_CASES),
        ),
        (lambda s: s.replace("[sweep]", '[sweep]\n".." = [1]'), ".."),
        (lambda s: s.replace("criterion", "timeout = -1\ncriterion"), "timeout"),
    ],
)
def test_bad_specs_are_refused_with_one_line(edit, needle):
    with pytest.raises(SweepSpecError) as info:
        parse_spec(edit(_SPEC), "bad.toml")
    msg = str(info.value)
    assert_true(
        needle in msg and "\n" not in msg,
        got=msg,
        should=f"one line naming {needle!r}",
        claim="sweep",
        call="parse_spec",
    )


def test_cli_bad_spec_exit_2_nothing_written(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text(_SPEC.replace('"mass" = [1.0, 2.0]', '"mass" = "heavy"'), encoding="utf-8")
    out = tmp_path / "out"
    code, stdout, err = _cli(["sweep", str(spec), "--out", str(out)], capsys)
    lines = err.strip().splitlines()
    assert_true(
        code == 2 and len(lines) == 1 and "mass" in lines[0] and not out.exists(),
        got=f"exit {code}, stderr {err!r}, out exists {out.exists()}",
        should="exit 2, one line naming mass, no output",
        claim="sweep",
        call="hcv sweep",
    )
    spec.write_text(_SPEC, encoding="utf-8")
    code, _, err = _cli(["sweep", str(spec), "--out", str(out), "--workers", "0"], capsys)
    assert_true(
        code == 2 and "--workers" in err and not out.exists(),
        got=f"{code} {err!r}",
        should="exit 2 naming --workers",
        claim="sweep",
        call="hcv sweep --workers 0",
    )


def test_task_timeout_and_task_rows_in_process():
    """The dt-crit task honours its deadline; solve and bench give one row per speed."""
    scene = {
        "name": "h",
        "mass": 1.0,
        "velocities": [1.0, 2.0],
        "kind": "impact",
        "potential": {"family": "power", "k": 1.0, "p": 1.5},
    }
    with pytest.raises(CaseTimeout):
        run_case(
            {"key": "k", "task": "dt-crit", "criterion": None, "scene": scene, "timeout": 1e-9}
        )
    rows = run_case(
        {"key": "k", "task": "solve", "criterion": None, "scene": scene, "timeout": 60.0}
    )
    assert_true(
        [r["v0"] for r in rows] == [1.0, 2.0] and all("restitution" in r for r in rows),
        got=str(rows)[:200],
        should="one solve row per speed",
        claim="sweep",
        call="run_case solve",
    )
    rows = run_case(
        {
            "key": "k",
            "task": "bench:reference",
            "criterion": None,
            "scene": {**scene, "velocities": [1.0]},
            "timeout": 60.0,
        }
    )
    assert_true(
        len(rows) >= 1
        and rows[0]["status"] in ("pass", "fail")
        and "measured.restitution" in rows[0],
        got=str(rows)[:300],
        should="bench rows with flattened measurements",
        claim="sweep",
        call="run_case bench:reference",
    )


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
    spec_path.write_text(_SPEC, encoding="utf-8")
    out = tmp_path / "out"
    code, stdout, err = _cli(["sweep", str(spec_path), "--workers", "2", "--out", str(out)], capsys)
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
        code, stdout, _ = _cli(
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
        and (out / "spec.toml").read_text(encoding="utf-8") == _SPEC,
        got=summary[:300],
        should="a table with units and failure kinds, a figure and the spec",
        claim="sweep",
        call="summary.md",
    )
    # Without --resume an existing sweep is refused.
    code, _, err = _cli(["sweep", str(spec_path), "--out", str(out)], capsys)
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
    spec = parse_spec(_SPEC, str(spec_path))
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


def test_report_map_through_run_cases_equals_dt_crit_map():
    """The bridge the report's map uses gives dt_crit_map's table, and its cases pickle."""
    import pickle

    from reference_impl.studies.dtcrit_map import coverage, dt_crit_map
    from reference_impl.sweep import dt_crit_map_on_cluster

    cases = [c for c in coverage(quick=True) if c.family != "power"]
    pickle.loads(pickle.dumps(cases))  # what a worker receives
    want = dt_crit_map(cases, kinds=("impact",))
    got = dt_crit_map_on_cluster(cases, kinds=("impact",), workers=0)
    assert_true(
        got.equals(want),
        got=f"{len(got)} rows, columns {list(got.columns)[:4]}",
        should=f"the {len(want)} rows of dt_crit_map",
        claim="sweep",
        call="dt_crit_map_on_cluster(workers=0)",
    )


@given(
    st.lists(st.integers(1, 4), min_size=1, max_size=3),
    st.sampled_from(["impact", "two-sided"]),
)
def test_any_sweep_expands_to_its_product_with_unique_keys(sizes, kind):
    """For any list lengths: len = product, params as given, keys unique, TOML text round-trips."""
    import tomllib

    paths = ["potential.p", "mass", "velocities"][: len(sizes)]
    sweep = {p: [1.0 + 0.5 * i for i in range(n)] for p, n in zip(paths, sizes, strict=True)}
    data = {
        "task": "dt-crit",
        "scene": {
            "mass": 1.0,
            "velocities": [1.0],
            "kind": kind,
            "potential": {"family": "power", "k": 1.0, "p": 1.5},
        },
        "sweep": sweep,
    }
    spec = spec_from_dict(data, "prop")
    n = 1
    for s in sizes:
        n *= s
    keys = {c.key for c in spec.cases}
    scene_ok = all(
        c.scene["potential"]["p"] == c.params.get("potential.p", 1.5)
        and c.scene["velocities"] == [c.params.get("velocities", 1.0)]
        for c in spec.cases
    )
    ok = len(spec.cases) == n and len(keys) == n and scene_ok and not spec.invalid
    assert_true(
        ok and tomllib.loads(spec.text) == data,
        got=f"{len(spec.cases)} cases, {len(keys)} keys, scenes ok {scene_ok}",
        should=f"{n} valid cases, unique keys",
        claim="sweep",
        call=f"spec_from_dict(sweep={sweep})",
    )


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
    spec.write_text(_SPEC)
    server = _NotAScheduler(reply)
    try:
        t0 = time.monotonic()
        code, out, err = _cli(
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


def test_each_distinct_potential_is_validated_once(monkeypatch):
    """Issue 22: 1e5 cases of one expression took ~40 min to validate (25 ms each)."""
    from reference_impl.scenes import _scene

    built = []
    real = _scene._potential

    def counting(err, table, path, depth=0):
        if depth == 0:
            built.append(json.dumps(table, sort_keys=True))
        return real(err, table, path, depth)

    monkeypatch.setattr(_scene, "_potential", counting)
    masses = [round(0.5 + 0.01 * i, 4) for i in range(300)]
    spec_text = textwrap.dedent(
        f"""
        task = "solve"
        [scene]
        mass = 1.0
        velocities = [1.0]
        [scene.potential]
        family = "expression"
        U = "k*q**2/2 + q**4/4"
        params = {{ k = 1.0 }}
        [sweep]
        "potential.params.k" = [1.0, 2.0, -1.0]
        mass = {masses}
        """
    )
    seen = []
    spec = parse_spec(spec_text, "<many>", progress=lambda done, total: seen.append((done, total)))
    assert len(spec.cases) == 900 and len(spec.invalid) == 300
    assert sorted(built) == sorted(set(built)) and len(built) == 3, (
        f"got {len(built)} potential validations, should be 3 (one per distinct table)"
    )
    assert "potential.params.k" in spec.invalid[0].error or "k" in spec.invalid[0].error
    assert spec.invalid[0].error.startswith(f"scene case {spec.invalid[0].index} ("), (
        f"got {spec.invalid[0].error!r}, should name its own case"
    )
    assert seen[-1] == (900, 900) and len(seen) == 901, "got no progress while validating"


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
        pids = []
        for entry in Path("/proc").iterdir():
            if entry.name.isdigit():
                try:
                    line = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
                except OSError:
                    continue
                if line.startswith(f"sleep {marker}"):
                    pids.append(int(entry.name))
        return pids

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
        deadline = time.monotonic() + 120
        while not running() and time.monotonic() < deadline:
            time.sleep(0.2)
        assert running(), "the adapter never started"
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


def test_turning_points_are_searched_from_the_top_energy_down(monkeypatch):
    """One search per potential, plus one per case that has no turning point.

    U = 1 - exp(-q) never exceeds 1 J: the cases with E = m v0^2 / 2 >= 1 J have no
    turning point and must be invalid with their own reason; every lower energy is
    then known to have one (U rises continuously from 0), so it is not searched again.
    """
    from reference_impl.potentials import base

    calls = []
    real = base.Potential.turning_point

    def counting(self, E, **kw):
        calls.append(E)
        return real(self, E, **kw)

    monkeypatch.setattr(base.Potential, "turning_point", counting)
    # E = 0.275 ... 1.525 J, never exactly 1 J (where the turning point is at infinity)
    masses = [round(0.55 + 0.1 * i, 2) for i in range(26)]
    spec = spec_from_dict(
        {
            "task": "solve",
            "scene": {
                "mass": 1.0,
                "velocities": [1.0],
                "potential": {"family": "expression", "U": "1 - exp(-q)"},
            },
            "sweep": {"mass": masses},
        }
    )
    invalid = [c.params["mass"] for c in spec.cases if c.error]
    assert invalid == [m for m in masses if m / 2 > 1.0], (
        f"got invalid masses {invalid}, should be those with E >= 1 J [issue 22, validation]"
    )
    assert all("velocity 1 m/s" in c.error for c in spec.cases if c.error)
    assert len(calls) == len(invalid) + 1, (
        f"got {len(calls)} turning-point searches, should be {len(invalid) + 1}"
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


# what belongs to the code: adapter options, steps per contact, calibration
# --------------------------------------------------------------------------
_BENCH_SPEC = textwrap.dedent(
    """
    task = "bench:reference"
    [scene]
    name = "lin"
    mass = 0.01
    velocities = [1.0]
    kind = "impact"
    [scene.potential]
    family = "power"
    k = 1.0e4
    p = 1.0
    [scene.damping]
    law = "universal"
    zeta = 0.1
    [sweep]
    "run.steps_per_contact" = [10, 40, 160]
    """
)


def test_code_keys_are_kept_apart_from_the_scene():
    """run.* / adapter.* keys go to the case's code settings, never into the scene."""
    spec = parse_spec(
        _BENCH_SPEC.replace("bench:reference", "bench:lammps[damping=velocity]")
        .replace("[sweep]", '[sweep]\n"adapter.eta_n0" = [1.0, 2.0]')
    )  # the adapter's module is imported to check the option name; LAMMPS is not loaded
    assert len(spec.cases) == 6 and not spec.invalid
    c = spec.cases[1]
    assert c.code == {"adapter": {"eta_n0": 1.0}, "run": {"steps_per_contact": 40}}
    assert "run" not in c.scene and "adapter" not in c.scene
    assert c.params == {"adapter.eta_n0": 1.0, "run.steps_per_contact": 40}
    assert len({x.key for x in spec.cases}) == 6  # the code settings are part of the key
    assert c.payload()["code"] == c.code


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda s: s.replace('task = "bench:reference"', 'task = "solve"'), "bench:ADAPTER"),
        (lambda s: s.replace("run.steps_per_contact", "run.steps"), "run.steps"),
        (lambda s: s.replace("[sweep]", '[sweep]\n"calibrate.target" = [0.5]'), "calibrate"),
        (lambda s: s.replace('task = "bench:reference"', 'task = "calibrate:reference"'),
         "[calibrate]"),  # fmt: skip
        (lambda s: s + "[calibrate]\nparam = 'x'\n", "calibrate"),
    ],
)
def test_bad_code_keys_are_refused_with_one_line(edit, needle):
    with pytest.raises(SweepSpecError) as info:
        parse_spec(edit(_BENCH_SPEC), "bad.toml")
    msg = str(info.value)
    assert needle in msg and "\n" not in msg, msg


def test_unknown_adapter_option_is_an_invalid_case():
    spec = parse_spec(_BENCH_SPEC.replace('task = "bench:reference"', 'task = "bench:cmd:true"')
                      .replace("[sweep]", '[sweep]\n"adapter.timeout" = [5, 10]'))  # fmt: skip
    assert not spec.invalid
    with pytest.raises(SweepSpecError) as info:  # every case invalid: the spec is refused
        parse_spec(_BENCH_SPEC.replace("[sweep]", '[sweep]\n"adapter.nosuch" = [1]'))
    assert "nosuch" in str(info.value)


def test_bad_steps_per_contact_is_an_invalid_case():
    spec = parse_spec(_BENCH_SPEC.replace("[10, 40, 160]", "[1, 40, 2.5]"))
    bad = [c for c in spec.cases if c.error]
    assert [c.params["run.steps_per_contact"] for c in bad] == [1, 2.5]
    assert all("steps_per_contact" in c.error for c in bad)


def test_bench_task_sweeps_the_step_and_keeps_measured_columns():
    """run.steps_per_contact sets dt = t_c / N; rows carry both restitutions and errors.

    The reference velocity Verlet's restitution error falls with N (its order is at
    least 1 with the half-step dashpot, README tolerances note), so the swept step
    must show a falling error, and dt must be the exact contact time over N.
    """
    spec = parse_spec(_BENCH_SPEC)
    rows = [run_case(c.payload())[0] for c in spec.cases]
    ns = [c.code["run"]["steps_per_contact"] for c in spec.cases]
    t_c = rows[0]["exact.contact_time"]
    for n, r in zip(ns, rows, strict=True):
        assert abs(r["dt"] * n - t_c) <= 1e-12 * t_c, (n, r["dt"], t_c)
        for col in ("measured.restitution", "measured.restitution_zero_force",
                    "measured.contact_time", "measured.max_penetration",
                    "rel_error.restitution", "rel_error.contact_time",
                    "rel_error.restitution_asked"):  # fmt: skip
            assert isinstance(r.get(col), float), (col, r.get(col))
    errs = [r["rel_error.restitution"] for r in rows]
    assert_true(
        errs[0] > errs[1] > errs[2],
        got=str(errs),
        should="falling with steps per contact 10, 40, 160",
        claim="sweep",
        call="run_case bench:reference with run.steps_per_contact",
    )


def test_spec_with_options_composes_adapter_specs():
    from reference_impl.adapters.registry import parse_spec as parse_adapter
    from reference_impl.bench.calibrate import spec_with_options

    s = spec_with_options("mujoco[solref=direct]", {"dampratio": 0.25, "integrator": "RK4"})
    assert parse_adapter(s) == ("mujoco", {"solref": "direct", "dampratio": 0.25,
                                           "integrator": "RK4"})  # fmt: skip
    s = spec_with_options("cmd[timeout=5]:python x.py", {"label": "a"})
    assert parse_adapter(s) == ("subprocess", {"command": "python x.py", "timeout": 5,
                                               "label": "a"})  # fmt: skip
    assert spec_with_options("lammps", {}) == "lammps"
    with pytest.raises(SweepSpecError.__mro__[1]):  # HCVInputError
        spec_with_options("lammps", {"damping": "a,b"})


@needs_dask
def test_a_bench_sweep_whose_metrics_fail_says_so_and_exits_1(tmp_path, capsys):
    """Runs that all break (a flipped sign) are cases that ran but failed their
    scorecard: not "2 cases ok" and exit 0 (issue 17)."""
    spec = tmp_path / "bench.toml"
    spec.write_text(
        textwrap.dedent(
            """
            task = "bench:verification._wrong_codes:FlippedSign"
            [scene]
            name = "s"
            mass = 0.01
            velocities = [1.0]
            kind = "impact"
            [scene.potential]
            family = "power"
            k = 1e6
            p = 1.0
            [sweep]
            "potential.p" = [1.0, 1.5]
            """
        ),
        encoding="utf-8",
    )
    out = tmp_path / "out"
    code, stdout, err = _cli(["sweep", str(spec), "--workers", "1", "--out", str(out)], capsys)
    assert_true(
        code == 1 and "2 of 2 benchmarked cases did not pass" in stdout,
        got=f"exit {code}: {stdout}{err}",
        should="exit 1, both scorecards failed",
        claim="sweep",
        call="hcv sweep bench:FlippedSign",
    )
    summary = (out / "summary.md").read_text()
    assert_true(
        "scorecards: 0 of 2 (case, variant) passed; 2 fail" in summary,
        got=summary[:600],
        should="the summary counts the failed scorecards",
        claim="sweep",
        call="summary.md",
    )



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
    p = subprocess.Popen(
        [sys.executable, "-m", "reference_impl.cli", "sweep",
         str(root / "docs" / "examples" / "sweep-hertz-map.toml"), "--workers", "2",
         "--out", str(tmp_path / "out")],
        cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(root)}, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    while True:  # the cluster is up once progress is printed
        line = p.stderr.readline()
        if line.startswith("sweep:") or not line:
            break
    time.sleep(0.5)
    os.killpg(p.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole group
    _, err = p.communicate(timeout=120)
    rest = [x for x in err.splitlines() if not x.startswith("sweep:")]
    assert_true(
        p.returncode == 130 and rest == ["interrupted"],
        got=f"exit {p.returncode}, stderr {err[-800:]!r}",
        should="exit 130 and the one line 'interrupted'",
        claim="sweep",
        call="Ctrl-C on hcv sweep",
    )
