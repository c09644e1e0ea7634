"""The benchmark's scorecard output and the staggering declaration of the adapter contract.

Issue 10, points 6, 7 and 11: off a terminal (CI logs, pipes) the scorecard is
full-width plain text, never cut to 80 columns, and leads with a summary per
code (pass / fail counts, each failing metric with measured against expected
values); measured value, reference, error and tolerance are separate labelled
columns (the measured restitution is visible without the JSON); an adapter (or
a ``cmd:`` response) may declare staggered samples, which the suite re-aligns.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from reference_impl.adapters.base import (
    AdapterOutputError,
    ContactAdapter,
    Trajectory,
    trajectory_from_mapping,
)
from reference_impl.bench.scorecard.metrics import MetricResult, SceneContext, SpeedRecord
from reference_impl.bench.scorecard.report import (
    metric_columns,
    render_scorecard,
    scorecard_markdown,
    scorecard_text,
)
from reference_impl.bench.scorecard.runner import BenchResult

from .assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent
CLAIM = "bench-report"  # the benchmark machinery, not a paper claim
LONG = "lammps[viscoelastic,wall,limit_damping]"


def _result() -> BenchResult:
    """A scorecard with one failing restitution (0.70 measured, 0.7292 asked) and a pass."""
    recs = [
        SpeedRecord(v0=0.5, dt=1e-7, asked_e=0.7292, measured={"restitution": 0.71},
                    exact={"restitution": 0.7101}),
        SpeedRecord(v0=5.0, dt=1e-7, asked_e=0.7292, measured={"restitution": 0.70},
                    exact={"restitution": 0.7001}),
    ]  # fmt: skip
    ctx = SceneContext(LONG, "hertz-damped", "impact", True, speeds=recs)
    metrics = [
        MetricResult(LONG, "hertz-damped", "restitution_asked", "fail", value=0.04004,
                     reference=0.0, tolerance="rtol 0.01",
                     explanation="e = 0.7 at v0 = 5 m/s but 0.7292 was asked"),
        MetricResult(LONG, "hertz-damped", "restitution_v0_spread", "pass", value=0.0142,
                     reference=0.0141, tolerance="rtol 0.02"),
        MetricResult(LONG, "hertz-damped", "energy_drift", "skip", explanation="two-walls"),
    ]  # fmt: skip
    return BenchResult(adapter="lammps", metrics=metrics, contexts=[ctx])


def _piped(result) -> str:
    from rich.console import Console

    buf = io.StringIO()
    render_scorecard(result, console=Console(file=buf, force_terminal=False, width=80))
    return buf.getvalue()


def test_piped_scorecard_is_full_width_plain_text():
    out = _piped(_result())
    assert_true(
        LONG in out and "restitution_v0_spread" in out and "…" not in out,
        got=out[:400],
        should="full names, nothing cut at 80 columns",
        claim=CLAIM,
        call="render_scorecard(piped)",
    )
    assert max(len(line) for line in out.splitlines()) > 80
    assert "\x1b[" not in out and "┃" not in out  # plain text: no escapes, no box drawing


def test_summary_first_with_failing_metrics_measured_against_expected():
    lines = _piped(_result()).splitlines()
    assert lines[0] == "hcv bench lammps: 1 pass, 1 fail, 1 skipped"
    assert lines[1].strip() == (
        f"{LONG}: 1 pass, 1 fail, 1 skipped; implementation pass, delivery FAIL"
    )
    fail = lines[2].strip()
    assert fail.startswith(
        "FAIL hertz-damped / restitution_asked (delivery): measured 0.7, expected 0.7292"
    )
    assert "at v0 = 5 m/s" in fail and "tolerance rtol 0.01" in fail
    header = next(i for i, line in enumerate(lines) if line.startswith("adapter"))
    assert header > 2  # the details come after the summary


def test_columns_measured_reference_error_tolerance():
    res = _result()
    lines = scorecard_text(res).splitlines()
    header = next(line for line in lines if line.startswith("adapter"))
    assert header.split() == ["adapter", "scene", "verdict", "metric", "v0", "measured",
                              "expected", "error", "model", "err", "step", "err", "ratio",
                              "order", "tolerance", "result"]  # fmt: skip
    row = next(line for line in lines if "restitution_asked" in line and "FAIL" in line[-4:])
    assert row.split()[2:8] == ["delivery", "restitution_asked", "5", "0.7", "0.7292", "0.04"]
    cols = metric_columns(res, res.metrics[0])
    assert (cols["measured"], cols["reference"], cols["v0"]) == (0.70, 0.7292, 5.0)
    md = scorecard_markdown(res)
    assert "| measured | expected | error | model err | step err | ratio | order |" in md
    assert "| 0.7 | 0.7292 | 0.04 |  |  |  |  | rtol 0.01 | fail |" in md


def test_terminal_scorecard_is_a_table_with_the_same_columns():
    from rich.console import Console

    buf = io.StringIO()
    render_scorecard(_result(), console=Console(file=buf, force_terminal=True, width=200))
    out = buf.getvalue()
    for col in ("verdict", "measured", "expected", "error", "tolerance"):
        assert col in out
    assert out.index("hcv bench lammps") < out.index("measured")


# -- staggering (contract item 11) --------------------------------------------------
def _raw(n: int = 8, lag: int = 1):
    t = np.arange(n) * 0.1
    q = np.sin(np.pi * t / t[-2])  # in contact, then out at the last sample
    f = np.concatenate([np.zeros(lag), 3.0 * q[: n - lag]])  # force stored `lag` steps late
    return t, q, f


def test_declared_force_lag_is_realigned_for_python_and_cmd_forms():
    t, q, f = _raw()
    v = np.ones_like(t)

    class Lagged(ContactAdapter):
        name = "lagged"
        staggering = {"force": 1}

        def _impact_impl(self, scene):
            return Trajectory(t, q, v, f)

    tr = Lagged().impact(None)
    np.testing.assert_array_equal(tr.force[:-1], 3.0 * q[:-1])
    assert tr.force[-1] == 0.0  # out of contact at the last sample: no force
    data = {"t": list(t), "q": list(q), "v": list(v), "force": list(f),
            "staggering": {"force": 1}}  # fmt: skip
    tr2 = trajectory_from_mapping(data, who="cmd")
    np.testing.assert_array_equal(tr2.force, tr.force)
    assert tr2.meta["staggering_aligned"] == {"force": "force[n] <- force[n + 1]"}


def test_half_step_velocity_is_averaged():
    t = np.arange(5) * 0.5
    q = np.array([0.0, 1.0, 1.0, 0.5, -0.1])
    v_half = np.array([1.0, 0.5, 0.0, -0.5, -0.5])
    tr = trajectory_from_mapping(
        {"t": t, "q": q, "v": v_half, "force": np.zeros(5), "staggering": {"v": 0.5}}
    )
    np.testing.assert_allclose(tr.v, [0.75, 0.25, -0.25, -0.5, -0.5])


@pytest.mark.parametrize(
    "bad", [{"force": 1.5}, {"force": -1}, {"force": 9}, {"v": 0.25}, {"x": 1}, [1], "force"]
)
def test_bad_staggering_is_one_line_error(bad):
    t, q, f = _raw()
    with pytest.raises(AdapterOutputError) as err:
        trajectory_from_mapping({"t": t, "q": q, "v": q, "force": f, "staggering": bad}, who="c")
    assert "\n" not in str(err.value) and "staggering" in str(err.value)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(3, 40), lag=st.integers(1, 4), seed=st.integers(0, 2**16))
def test_force_realignment_shifts_every_sample(n, lag, seed):
    """For any length and lag: aligned[i] = stored[i + lag]; the tail is 0 out of contact."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1, 1, n)
    f = rng.uniform(0, 1, n)
    t = np.arange(n, dtype=float)
    tr = trajectory_from_mapping({"t": t, "q": q, "v": q, "force": f, "staggering": {"force": lag}})
    k = min(lag, n)
    np.testing.assert_array_equal(tr.force[: n - k], f[k:])
    tail = tr.force[n - k :]
    expect = np.where(q[n - k :] <= 0, 0.0, np.nan)
    np.testing.assert_array_equal(np.isnan(tail), np.isnan(expect))
    np.testing.assert_array_equal(tail[~np.isnan(tail)], 0.0)


def test_json_metrics_carry_the_separate_columns():
    from reference_impl.bench.scorecard._json import result_to_dict

    doc = result_to_dict(_result())
    m = doc["metrics"][0]
    assert (m["measured"], m["expected"], m["at_v0"]) == (0.70, 0.7292, 5.0)
    assert m["error"] == pytest.approx(0.04004) and m["tolerance"] == "rtol 0.01"


# -- the second-language example of the protocol (issue 10, point 12) -------------------
EXAMPLE_C = ROOT / "docs" / "examples" / "power_verlet.c"


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
def test_c_example_adapter_reaches_a_passing_scorecard(tmp_path):
    """docs/examples/power_verlet.c compiles warning-free and passes ``hcv bench --gate``."""
    exe = tmp_path / "power_verlet"
    cc = subprocess.run(
        ["gcc", "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror", "-o", str(exe),
         str(EXAMPLE_C), "-lm"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert cc.returncode == 0, cc.stderr
    js = tmp_path / "c.json"
    r = subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", "bench", f"cmd:{exe}", "--gate",
         "--scenes", "hooke-damped", "--json", str(js)],
        env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    doc = json.loads(js.read_text())
    asked = next(m for m in doc["metrics"] if m["metric"] == "restitution_asked")
    assert asked["status"] == "pass" and asked["expected"] == pytest.approx(0.5, rel=1e-12)
    assert "restitution_asked" in r.stdout and "measured" in r.stdout.splitlines()[3]
    # A scene it has no model for is declined (a skip); a malformed request is an error.
    for request, answer in (
        ('{"request": "impact", "scene": {"potential": {"family": "sphere"}}}',
         {"unsupported": "only power-law potentials"}),
        ('{"request": "sustained", "scene": {"potential": {"family": "power"}}}',
         {"unsupported": "single impacts only"}),
        ('{"request": "impact", "scene": {"potential": {"family": "power", "k": 1}}}',
         {"error": "request lacks k, p, mass, v0, dt or n_steps"}),
    ):  # fmt: skip
        bad = subprocess.run([str(exe)], input=request, capture_output=True, text=True,
                             timeout=30)  # fmt: skip
        assert json.loads(bad.stdout) == answer, (request, bad.stdout)


def test_side_by_side_puts_codes_in_columns():
    """Two codes' JSON scorecards become one table, a column per variant (for the report)."""
    from reference_impl.bench.scorecard._json import result_to_dict
    from reference_impl.bench.scorecard.report import side_by_side, side_by_side_markdown

    a = result_to_dict(_result())
    b = result_to_dict(_result())
    for m in b["metrics"]:
        m["variant"] = "kratos[hertz,euler]"
    header, rows = side_by_side([a, b])
    assert header == ["scene", "metric", "reference", LONG, "kratos[hertz,euler]"]
    assert rows[0] == ["hertz-damped", "restitution_asked", "0.7292", "0.7 FAIL", "0.7 FAIL"]
    assert rows[1][1] == "restitution_v0_spread" and rows[1][3] == "0.0142 pass"
    assert len(rows) == 2  # the skipped metric has no row
    assert side_by_side_markdown([a, b]).splitlines()[0].startswith("| scene | metric |")


# -- the status "error": our reference failed (issue 12 §3), one home in report.py ---------
OURS = "internal error of the reference (ours, not the code's): exact solver raised"


def _result_with_error() -> BenchResult:
    """`_result` without its failure, plus one metric our reference could not decide."""
    res = _result()
    res.metrics = [m for m in res.metrics if m.status != "fail"]
    res.metrics.append(
        MetricResult(LONG, "hertz-damped", "restitution_exact", "error", tolerance="rtol 0.01",
                     explanation=OURS)
    )  # fmt: skip
    return res


def test_error_status_in_every_scorecard_output():
    from rich.console import Console

    from reference_impl.bench.scorecard._json import result_to_dict
    from reference_impl.bench.scorecard._junit import junit_tree

    res = _result_with_error()
    lines = _piped(res).splitlines()
    assert lines[0] == "hcv bench lammps: 1 pass, 0 fail, 1 skipped, 1 ERROR (ours)"
    assert lines[1].strip() == (
        f"{LONG}: 1 pass, 0 fail, 1 skipped, 1 ERROR (ours); implementation ERROR (ours)"
    )
    assert lines[2].strip() == f"ERROR (ours) hertz-damped / restitution_exact: {OURS}"
    row = next(line for line in lines if "restitution_exact" in line and "rtol" in line)
    assert row.endswith("ERROR (ours)")
    assert "FAIL" not in "\n".join(lines)  # never counted against the code
    buf = io.StringIO()  # the rich table knows the status (no KeyError, no patch needed)
    render_scorecard(res, console=Console(file=buf, force_terminal=True, width=250))
    assert "ERROR (ours)" in buf.getvalue()
    md = scorecard_markdown(res)
    assert "1 ERROR (ours)" in md and f"| ERROR (ours) | {OURS} |" in md
    assert result_to_dict(res)["status"] == "error"
    res.metrics[0].status = "fail"  # a real failure outranks our error
    assert result_to_dict(res)["status"] == "fail"
    res.metrics[0].status = "pass"
    root = junit_tree(res).getroot()
    (err,) = root.findall("./testsuite/testcase/error")
    assert err.get("message") == OURS and err.get("type") == "ReferenceError"
    assert root.get("errors") == "1" and root.get("failures") == "0"
    assert root.find("./testsuite").get("errors") == "1"
    assert not root.findall("./testsuite/testcase/failure")


@pytest.mark.parametrize("umask", [0o022, 0o027])
def test_report_files_get_the_mode_of_a_new_file(tmp_path, umask):
    """--json / --junit / --markdown: 0666 less the umask, not mkstemp's 0600 (issue 10 §8)."""
    import stat

    from reference_impl.bench.scorecard._json import write_json
    from reference_impl.bench.scorecard._junit import write_junit
    from reference_impl.bench.scorecard.report import write_markdown

    old = os.umask(umask)
    try:
        for write, name in ((write_json, "r.json"), (write_junit, "r.xml"),
                            (write_markdown, "r.md")):  # fmt: skip
            write(_result_with_error(), tmp_path / name)
    finally:
        os.umask(old)
    for name in ("r.json", "r.xml", "r.md"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o666 & ~umask, name
    assert json.loads((tmp_path / "r.json").read_text())["status"] == "error"


def test_package_data_ships_every_toml_and_every_pattern_matches():
    """pyproject's package-data: each data file of the package is matched (a wheel ships the
    scenes and tolerances the code loads) and no pattern is stale (matches nothing)."""
    import tomllib

    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    patterns = data["package-data"]
    shipped = set()
    for package, globs in patterns.items():
        pkg_dir = ROOT.joinpath(*package.split("."))
        for g in globs:
            hits = {p.relative_to(ROOT) for p in pkg_dir.glob(g) if p.is_file()}
            assert hits, f"package-data {package!r}: pattern {g!r} matches nothing"
            shipped |= hits
    data_files = {
        p.relative_to(ROOT)
        for p in (ROOT / "reference_impl").rglob("*")
        if p.is_file() and p.suffix in (".toml", ".json", ".csv") and "__pycache__" not in p.parts
    }
    assert data_files <= shipped, sorted(map(str, data_files - shipped))


def test_protocol_documents_u_of_every_family_with_units():
    """Issue 10, point 3: docs/adapter-protocol.md gives U(q) of every family a scene can name.

    The family list comes from the scene loader, so a family added there without its
    documented law fails here.
    """
    import re
    from pathlib import Path

    from reference_impl.potentials import FAMILIES as _FAMILIES

    doc = (Path(__file__).resolve().parents[1] / "docs" / "adapter-protocol.md").read_text()
    rows = dict(re.findall(r"^\| `([a-z]+)` \| ([^\n]*)$", doc, re.M))
    missing = [f for f in _FAMILIES if f not in rows]
    assert not missing, (
        f"got no U(q) row for {missing}, should document every family of the scene "
        "loader [issue 10 point 3, docs/adapter-protocol.md]"
    )
    no_units = [f for f in _FAMILIES if "(" not in rows[f]]
    assert not no_units, (
        f"got rows without units for {no_units}, should give the keys' SI units "
        "[issue 10 point 3, docs/adapter-protocol.md]"
    )


# -- issue 28: a failed run's reason in its summary line, JUnit measured/expected, n/a -----
def _run_failed() -> BenchResult:
    """restitution_asked failed because the run failed: nothing was measured."""
    rec = SpeedRecord(v0=0.5, dt=1e-7, error="adapter crashed (exit 139)")
    ctx = SceneContext("code", "hertz-damped", "impact", True, speeds=[rec])
    why = "run failed at v0 = 0.5 m/s: adapter crashed (exit 139)"
    m = MetricResult("code", "hertz-damped", "restitution_asked", "fail", tolerance="rtol 0.02",
                     explanation=why)  # fmt: skip
    return BenchResult(adapter="code", metrics=[m], contexts=[ctx])


def test_a_failed_runs_summary_line_says_why():
    lines = _piped(_run_failed()).splitlines()
    fail = next(line.strip() for line in lines if line.strip().startswith("FAIL hertz-damped"))
    assert_true(
        "adapter crashed (exit 139)" in fail and "measured -" not in fail,
        got=fail,
        should="the reason in the FAIL line, no 'measured -, expected -'",
        claim=CLAIM,
        call="scorecard_text(run failed)",
    )


def test_junit_failure_text_shows_measured_and_expected():
    from reference_impl.bench.scorecard._junit import junit_tree

    res = _result()
    res.metrics[0].measured, res.metrics[0].expected, res.metrics[0].at_v0 = 0.70, 0.7292, 5.0
    res.metrics[0].error, res.metrics[0].rule = 0.04004, "|e - asked| / asked <= rtol"
    fail = junit_tree(res).getroot().find(".//failure")
    assert_true(
        "measured: 0.7, expected: 0.7292 at v0 = 5 m/s" in fail.text and "value: " not in fail.text,
        got=fail.text,
        should="measured and expected in the failure text (not the error against 0)",
        claim=CLAIM,
        call="junit_tree",
    )


def test_metrics_that_do_not_apply_are_na_not_skipped():
    from reference_impl.bench.scorecard.metrics import METRICS
    from reference_impl.bench.scorecard.tolerances import default_tolerances

    ctx = SceneContext("code", "hertz", "impact", False, speeds=[SpeedRecord(v0=1.0)])
    by = {m.name: m.evaluate(ctx, default_tolerances()) for m in METRICS}
    got = {k: v.status for k, v in by.items() if k in ("energy_drift", "restitution_v0_spread")}
    assert_true(
        got == {"energy_drift": "n/a", "restitution_v0_spread": "n/a"},
        got=got,
        should="n/a (two-walls metric; needs two speeds)",
        claim=CLAIM,
        call="Metric.evaluate(impact scene, one speed)",
    )


def test_a_failed_row_names_the_same_v0_as_its_fail_line():
    """Issue 26: with two codes the table reads rows at a common speed (the worst over the
    codes: B's 0.5 m/s here), but a failed row keeps its own worst speed (A's 5 m/s), the
    one its FAIL line names."""
    rows = {
        "A": [(0.5, 0.70, 0.0101), (5.0, 0.65, 0.11)],  # fails, worst at 5 m/s
        "B": [(0.5, 0.60, 0.18), (5.0, 0.729, 0.0003)],  # fails worse, at 0.5 m/s
    }
    metrics, ctxs = [], []
    for code, per in rows.items():
        worst = max(per, key=lambda r: r[2])
        status = "fail" if worst[2] > 0.1 else "pass"
        metrics.append(
            MetricResult(
                code, "s", "restitution_asked", status, value=worst[2], tolerance="rtol 0.02",
                explanation="off" if status == "fail" else "", error=worst[2], limit=0.1,
                at_v0=worst[0], measured=worst[1], expected=0.7292, rule="rule",
                per_v0=[{"v0": v, "measured": g, "expected": 0.7292, "error": e, "limit": 0.1}
                        for v, g, e in per],
            )
        )  # fmt: skip
        ctxs.append(SceneContext(code, "s", "impact", True))
    text = scorecard_text(BenchResult(adapter="x", metrics=metrics, contexts=ctxs))
    fail_line = next(
        line for line in text.splitlines() if line.strip().startswith("FAIL s / restitution_asked")
        and "0.65" in line
    )  # fmt: skip
    row = next(line for line in text.splitlines() if line.startswith("A ") and "FAIL" in line)
    assert_true(
        "at v0 = 5 m/s" in fail_line and row.split()[4] == "5",
        got=f"{fail_line!r} / {row!r}",
        should="both at v0 = 5",
        claim=CLAIM,
        call="scorecard_text(two codes)",
    )
