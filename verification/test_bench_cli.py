"""``hcv bench``'s command line as a user meets it (issue 41, section 3).

``--steps-per-contact N`` (as ``hcv calibrate`` has) sets the main runs' step; a bad
option is refused with the bench sub-command's usage, not hcv's; ``--help`` lists the
adapters' options that are not variant keys (``dampratio``, ``en``, ``tc``, ...).
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from reference_impl.cli import main
from verification.assertions import assert_true


def _hcv(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_steps_per_contact_sets_the_main_runs_step(tmp_path):
    out = tmp_path / "b.json"
    code = main(["bench", "reference", "--scenes", "hooke-damped", "--steps-per-contact",
                 "50", "--json", str(out)])  # fmt: skip
    data = json.loads(out.read_text())
    speeds = data["records"][0]["speeds"]
    # dt = t_c / 50: one division of the exact contact time, so equal to a few ulps
    ratios = [s["asked"]["contact_time"] / s["dt"] for s in speeds]
    assert_true(
        code == 0
        and data["tolerances"]["run"]["steps_per_contact"] == 50
        and all(r == pytest.approx(50.0, rel=1e-13) for r in ratios),
        got=f"exit {code}, run table {data['tolerances']['run']}, t_c/dt {ratios}",
        should="exit 0, steps_per_contact 50, t_c/dt = 50 at every speed",
        claim="tool",
        call="hcv bench reference --scenes hooke-damped --steps-per-contact 50",
    )


@pytest.mark.parametrize("n", ["1", "1000000"])
def test_a_bad_steps_per_contact_is_one_line_exit_2(n, tmp_path):
    r = _hcv("bench", "reference", "--steps-per-contact", n, "--json", str(tmp_path / "b.json"))
    lines = r.stderr.strip().splitlines()
    assert_true(
        r.returncode == 2
        and len(lines) == 1
        and f"--steps-per-contact {n}" in lines[0]
        and not (tmp_path / "b.json").exists(),
        got=f"exit {r.returncode}, stderr {lines}",
        should=f"exit 2, one line naming --steps-per-contact {n}, nothing written",
        claim="tool",
        call=f"hcv bench reference --steps-per-contact {n}",
    )


def test_a_bad_option_prints_the_bench_usage():
    r = _hcv("bench", "reference", "--no-such-option")
    err = r.stderr
    assert_true(
        r.returncode == 2
        and err.startswith("usage: hcv bench ADAPTER")
        and "hcv bench: error: unrecognized arguments: --no-such-option" in err,
        got=f"exit {r.returncode}, stderr {err!r}",
        should="exit 2, bench's usage and 'hcv bench: error: unrecognized arguments'",
        claim="tool",
        call="hcv bench reference --no-such-option",
    )


def test_bench_help_lists_the_adapters_options():
    """The options the adapters take besides their variant keys, each on its adapter's
    line (read from the constructors: MuJoCo's dampratio, YADE's en and tc, ...)."""
    r = _hcv("bench", "--help")
    lines = {
        ln.split(":")[0].strip(): ln for ln in r.stdout.split("other options", 1)[-1].splitlines()
    }
    want = {
        "mujoco": ("dampratio=X", "damping=X", "width=X"),
        "yade": ("en=X", "tc=X", "betan=X", "cn=X"),
        "lammps": ("eta_n0=X", "restitution=X"),
        "kratos": ("restitution=X",),
        "liggghts": ("restitution=X",),
    }
    missing = {n: [o for o in opts if o not in lines.get(n, "")] for n, opts in want.items()}
    missing = {n: m for n, m in missing.items() if m}
    assert_true(
        r.returncode == 0 and not missing,
        got=f"missing {missing}; {r.stdout[-700:]}",
        should=f"the options {want} on their adapters' lines",
        claim="tool",
        call="hcv bench --help",
    )
