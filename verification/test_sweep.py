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
from reference_impl.sweep import (
    MAX_CASES,
    CaseTimeout,
    SweepSpecError,
    parse_spec,
    run_case,
    run_cases,
    run_sweep,
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
