"""The ``hcv`` command line: outputs, JSON schema, and exit status 2 with one line on bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from verification.assertions import assert_close, assert_true

SOLVE_FIELDS = {
    "v0",
    "max_penetration",
    "max_force",
    "dt_safe",
    "dt_safe_shortcut",
    "geometry",
    "contact_time",
    "restitution",
    "action",
    "period",
}


def _hcv(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def test_solve_json_embedded_paper_scene():
    r = _hcv("solve", "paper-ellipsoid", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    rows = out["results"]
    assert_true(
        [row["v0"] for row in rows] == [0.5, 0.99, 1.5],
        got=str([row["v0"] for row in rows]),
        should="[0.5, 0.99, 1.5]",
        claim="table1",
        call="hcv solve paper-ellipsoid --json",
    )
    for row in rows:
        missing = SOLVE_FIELDS - set(row)
        assert_true(
            not missing,
            got=f"missing {missing}",
            should="all fields",
            claim="table1",
            call="hcv solve --json",
        )
        # Conservative: the paper's T is four quarter periods = twice the contact time
        # (both from independent quadratures: action.py in q, impact.py in virtual time).
        assert_close(
            row["period"],
            2 * row["contact_time"],
            rtol=1e-13,
            claim="thm1-period",
            call="hcv solve --json period vs contact_time",
        )


def test_solve_table_output():
    r = _hcv("solve", "hertz-damped")
    assert r.returncode == 0, r.stderr
    assert "restitution" in r.stdout and "dt_safe" in r.stdout


@pytest.mark.parametrize(
    "content, needle",
    [
        (
            "mass = nan\nvelocities = [1.0]\n[potential]\nfamily = 'power'\nk = 1.0\np = 1.5\n",
            "nan",
        ),
        ("mass = 1.0\nvelocities = [1.0\n", "TOML"),
        (
            "mass = 0.0\nvelocities = [1.0]\n[potential]\nfamily = 'power'\nk = 1.0\np = 1.5\n",
            "mass",
        ),
        ("mass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = 'banana'\n", "banana"),
        (
            "mass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = 'expression'\nU = 'q**2 - q**3'\n",
            "not > 0",
        ),
        (
            "mass = 1.0\nvelocities = [10.0]\n[potential]\nfamily = 'expression'\nU = '1 - exp(-q)'\n",
            "turning point",
        ),
        (
            "mass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = 'expression'\n"
            "U = \"__import__('os').system('touch SENTINEL')\"\n",
            "__import__",
        ),
    ],
    ids=[
        "nan-mass",
        "bad-toml",
        "zero-mass",
        "unknown-family",
        "non-monotone",
        "no-turning-point",
        "hostile-expression",
    ],
)
def test_bad_input_exit_2_one_line(tmp_path: Path, content, needle):
    scene = tmp_path / "scene.toml"
    scene.write_text(content)
    r = _hcv("solve", str(scene), cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert needle in lines[0], lines[0]
    assert not (tmp_path / "SENTINEL").exists()
    assert r.stdout == ""


def test_missing_file_exit_2(tmp_path: Path):
    r = _hcv("solve", str(tmp_path / "nope.toml"))
    assert r.returncode == 2 and "nope.toml" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_usage_error_exit_2():
    r = _hcv("solve")
    assert r.returncode == 2


def test_dt_crit_json_reports_each_velocity():
    r = _hcv("dt-crit", "hertz", "--json")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["results"]
    assert [row["v0"] for row in rows] == [0.1, 1.0, 5.0]
    for row in rows:
        for key in (
            "dt_safe",
            "dt_safe_shortcut",
            "dt_crit",
            "ratio",
            "criterion",
            "holds",
            "counterexample",
        ):
            assert key in row, key
        # Power laws are scale invariant: dt_crit/dt_safe cannot depend on v0. The
        # bisection resolves the ratio to 0.1 % of dt_safe.
        assert_close(
            row["ratio"],
            rows[0]["ratio"],
            rtol=2e-3,
            claim="sec6-dt-safe-bound",
            call="hcv dt-crit hertz --json",
        )


def test_dt_crit_bad_criterion_exit_2():
    r = _hcv("dt-crit", "hertz", "--criterion", "factor=abc")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_report_workers_out_of_range_is_refused_before_work(tmp_path):
    """``hcv report --workers`` is bounded and checked before anything is written."""
    out = tmp_path / "rep"
    r = _hcv("report", "--workers", "-1", "--out", str(out))
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "--workers -1" in lines[0], (
        f"got exit {r.returncode}, stderr {r.stderr!r}, should be exit 2 with one line "
        "naming --workers -1 [cli, hcv report --workers -1]"
    )
    assert not out.exists(), f"got {out} written, should be untouched [cli, hcv report]"


def test_the_readme_examples_leave_no_untracked_files():
    """The C example's binary, its JSON and the sweep example's output are ignored (issue 17)."""
    import shutil
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    if shutil.which("git") is None or not (root / ".git").exists():
        pytest.skip("not a git work tree")
    paths = ["pv", "power_verlet", "c.json", "out/results.parquet", "sweep-hertz-map/summary.md"]
    r = subprocess.run(["git", "check-ignore", *paths], cwd=root, capture_output=True, text=True)
    assert r.stdout.split() == paths, f"got ignored {r.stdout.split()}, should be {paths}"


def test_the_readme_cites_the_paper_by_its_arxiv_identifier():
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    assert "arXiv:2604.02533" in text and "../shared" not in text, (
        "got a path a clone does not have, should cite arXiv 2604.02533 [README]"
    )


def test_help_lists_every_sweep_task():
    """`hcv --help`'s line for sweep names each task a sweep spec accepts (issue 26 item 7:
    `calibrate:` was missing)."""
    import re

    from reference_impl.sweep._spec import TASKS

    r = _hcv("--help")
    line = re.search(r"^ +sweep +(.*?)\n {4}\S", r.stdout, re.M | re.S)
    text = " ".join(line.group(1).split()) if line else ""
    missing = [t.split(":")[0] for t in TASKS if t.split(":")[0] not in text]
    assert_true(
        r.returncode == 0 and text and not missing,
        got=f"exit {r.returncode}, sweep line {text!r}, {missing} not named",
        should=f"exit 0, every task of {TASKS} named",
        claim="tool",
        call="hcv --help",
    )
