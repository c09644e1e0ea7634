"""Output a person can read (issue 26, item 3): ``hcv solve`` off a terminal is plain
full-width text (no number cut to 80 columns); titles name every parameter that decides
the answer; the dt-crit counterexample is labelled lines, not raw JSON; ``hcv dt-crit
--gate`` exits 1 when the dt_safe bound fails."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from reference_impl.cli._tables import fmt
from reference_impl.scenes import scene_from_dict

from .assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent
CLAIM = "cli-output"  # the command line, not a paper claim
_ENV = {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "80"}


def _hcv(*args: str, cwd=ROOT) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", *args],
        cwd=cwd, env=_ENV, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_hcv_solve_piped_prints_every_number_whole_and_names_the_parameters(tmp_path):
    # six speeds: wider than 80 columns, where rich cut numbers ("1.850890221e…")
    f = tmp_path / "six.toml"
    f.write_text(
        'name = "hertz-damped"\nmass = 0.0041103\nvelocities = [0.1, 0.2, 0.5, 1, 2, 5]\n'
        '[potential]\nfamily = "power"\nk = 1.0879e10\np = 1.5\n'
        '[damping]\nlaw = "universal"\nzeta = 0.1\n'
    )
    text = _hcv("solve", str(f))
    doc = json.loads(_hcv("solve", str(f), "--json").stdout)
    values = [fmt(r[k]) for r in doc["results"] for k in ("contact_time", "max_penetration")]
    missing = [v for v in values if v not in text.stdout]
    title = text.stdout.splitlines()[0]
    assert_true(
        text.returncode == 0 and not missing and "…" not in text.stdout
        and "k = 1.0879e+10" in title and "p = 1.5" in title
        and "damping universal zeta = 0.1" in title,
        got=f"exit {text.returncode}, numbers not printed whole: {missing}; title {title!r}",
        should="every number at 10 digits, the title naming k, p, the law and zeta",
        claim=CLAIM,
        call="hcv solve hertz-damped | cat",
    )  # fmt: skip


def test_titles_name_the_law_and_its_parameters():
    from reference_impl.cli._tables import scene_title

    scene = scene_from_dict(
        {"name": "s", "mass": 0.01, "velocities": [1.0],
         "potential": {"family": "power", "k": 1e9, "p": 1.5},
         "damping": {"law": "power", "c": 2.0, "exponent": 0.25}}
    )  # fmt: skip
    title = scene_title("dt-crit", scene)
    assert title == (
        "hcv dt-crit: s (m = 0.01 kg; potential power k = 1000000000, p = 1.5; "
        "damping power c = 2, exponent = 0.25)"
    ), title


def test_dt_crit_gate_exits_1_when_the_bound_fails_and_labels_the_counterexample(tmp_path):
    f = tmp_path / "runaway.toml"
    f.write_text(
        'name = "runaway"\nmass = 0.01\nvelocities = [1.0]\nkind = "two-sided"\n'
        '[potential]\nfamily = "power"\nk = 1e6\np = 1.5\n'
    )
    r = _hcv("dt-crit", str(f), "--gate")
    out = r.stdout
    assert_true(
        r.returncode == 1 and "bound holds" in out
        and "counterexample at v0 = 1 m/s:" in out and "\n  status: over-limit\n" in out
        and '{"dt"' not in out and out.rstrip().splitlines()[-1].startswith("gate: FAIL"),
        got=f"exit {r.returncode}: {out[-900:]}{r.stderr[-300:]}",
        should="exit 1, labelled counterexample lines, 'gate: FAIL' last",
        claim=CLAIM,
        call="hcv dt-crit runaway.toml --gate",
    )  # fmt: skip


def test_dt_crit_gate_passes_when_the_bound_holds_everywhere(capsys):
    from reference_impl.cli.dt_crit import gate_status

    rows = [{"v0": 1.0, "holds": True, "ratio": 1.2}, {"v0": 2.0, "holds": True, "ratio": 1.1}]
    assert gate_status(rows) == 0 and "gate: pass" in capsys.readouterr().out
    rows[1]["holds"] = False
    assert gate_status(rows) == 1 and "fails at v0 = 2 m/s" in capsys.readouterr().out
