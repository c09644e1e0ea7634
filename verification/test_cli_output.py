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


class _Stdout:
    """A stdout whose ``isatty`` answers ``tty`` (or raises, as a closed file does)."""

    def __init__(self, tty):
        self.tty = tty

    def isatty(self):
        if self.tty is None:
            raise ValueError("I/O operation on closed file")
        return self.tty

    def write(self, text):
        return len(text)

    def flush(self):
        pass


def test_rich_is_skipped_only_where_it_would_find_no_terminal(monkeypatch):
    """`_tables._may_be_terminal` says no only where rich's own ``Console().is_terminal``
    says no, over its environment variables and the tty (a closed stdout included): a pipe
    skips rich's import (issue 38 goal 7), a terminal still gets rich's table."""
    from rich.console import Console

    from reference_impl.cli import _tables

    seen = []
    for tty_compatible in (None, "0", "1", "x"):
        for force_color in (None, "", "1"):
            for tty in (False, True, None):
                for name, value in (
                    ("TTY_COMPATIBLE", tty_compatible),
                    ("FORCE_COLOR", force_color),
                ):
                    if value is None:
                        monkeypatch.delenv(name, raising=False)
                    else:
                        monkeypatch.setenv(name, value)
                monkeypatch.setattr(sys, "stdout", _Stdout(tty))
                ours, rich = _tables._may_be_terminal(), Console().is_terminal
                seen.append((tty_compatible, force_color, tty, ours, rich))
    wrong = [s for s in seen if s[4] and not s[3]]  # rich a terminal, ours skipping it
    skipped = [s for s in seen if not s[3]]
    assert_true(not wrong and len(skipped) >= 6,
                got=f"wrong {wrong}, skipped {len(skipped)} of {len(seen)}",
                should="no terminal skipped, the pipes without overrides skipped",
                claim=CLAIM, call="_may_be_terminal()")  # fmt: skip


def test_a_piped_table_imports_no_rich():
    """Off a terminal the table is plain text and rich is not imported (on main it was,
    only to learn that stdout is no terminal: ~0.05 s of hcv solve's CPU)."""
    code = (
        "import sys; from reference_impl.cli._tables import print_transposed; "
        "print_transposed('t', [{'v0': 1.0, 'a': 2.5}], [('a', 'A [s]')], 'v0', 'v0 [m/s]'); "
        "print('rich' in sys.modules, file=sys.stderr)"
    )
    env = {k: v for k, v in _ENV.items() if k not in ("FORCE_COLOR", "TTY_COMPATIBLE")}
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=60)  # fmt: skip
    lines = r.stdout.splitlines()
    assert_true(r.returncode == 0 and r.stderr.strip() == "False" and lines[0] == "t"
                and lines[1].split() == ["v0", "[m/s]", "1"] and lines[3].split() == ["A", "[s]", "2.5"],
                got=f"exit {r.returncode}, stdout {r.stdout!r}, stderr {r.stderr[-200:]!r}",
                should="the plain table, rich not imported", claim=CLAIM,
                call="print_transposed(...) piped")  # fmt: skip
