"""CI runs the README's commands as a user meets them (issue 41).

``.ci/run`` runs the README's test command twice: (a) first, verbatim, in a fresh venv
with only ``[test]`` (nothing else installed before it), and (b) after the extras and the
README's main job, verbatim, in the same checkout. Read from the files, so a README
edit that CI does not follow fails here.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
CI = ROOT / ".ci" / "run"
CALL = ".ci/run against README.md"


def _readme_command(lead: str) -> str:
    """The one-line command of the first ``bash`` block after the README line starting
    with ``lead``."""
    text = (ROOT / "README.md").read_text()
    m = re.search(rf"^{re.escape(lead)}.*?\n```bash\n(.+?)\n```", text, re.S | re.M)
    assert m is not None and "\n" not in m.group(1), f"got no one-line bash block after {lead!r}"
    return m.group(1)


def _steps() -> list[str]:
    """The commands of .ci/run, one a line (comments and blank lines left out)."""
    lines = [ln.strip() for ln in CI.read_text().splitlines()]
    return [ln for ln in lines if ln and not ln.startswith("#")]


def test_ci_runs_the_readme_test_command_first_with_only_test_then_after_the_main_job():
    tests = _readme_command("Tests (")
    main_job = _readme_command("Main job (")
    steps = _steps()
    at = [i for i, s in enumerate(steps) if s.startswith(tests)]
    job = [i for i, s in enumerate(steps) if s.startswith(main_job)]
    extras = [i for i, s in enumerate(steps) if re.search(r"pip install .*-e '\.\[test,\w", s)]
    fresh = [i for i, s in enumerate(steps) if s == "rm -rf .venv"]
    installs_before = [s for s in steps[: at[0] if at else 0] if re.search(r"\bpip\b", s)]
    ok = (
        len(at) == 2
        and len(job) == 1
        and extras
        and fresh
        and fresh[0] < at[0] < extras[0] < job[0] < at[1]
        and not installs_before
        and "-n 2" in tests
        and "'.[test]'" in tests
    )
    assert_true(
        bool(ok),
        got=f"README test command at steps {at}, main job at {job}, extras at {extras}, "
        f"fresh venv at {fresh}, installs before (a): {installs_before}",
        should="rm -rf .venv, the README's test command (a), the extras, the README's main "
        "job, the README's test command (b), in this order, each verbatim",
        claim="tool",
        call=CALL,
    )


def test_a_failed_step_of_a_readme_command_stops_ci():
    """`set -e` ignores a failure inside `a && b && c` but for c: each README command is
    followed by `|| fail`, which exits with that status."""
    tests, main_job = _readme_command("Tests ("), _readme_command("Main job (")
    unguarded = [
        s
        for s in _steps()
        if s.startswith((tests, main_job)) and not re.search(r"\|\| fail \$\? ", s)
    ]
    assert_true(
        not unguarded,
        got=f"unguarded: {unguarded}",
        should="every README command followed by `|| fail $? ...`",
        claim="tool",
        call=CALL,
    )


@pytest.mark.skipif(shutil.which("bash") is None, reason="no bash (apt-get install -y bash)")
def test_ci_run_is_valid_bash():
    r = subprocess.run(["bash", "-n", str(CI)], capture_output=True, text=True, timeout=60)
    assert_true(
        r.returncode == 0,
        got=f"exit {r.returncode}: {r.stderr.strip()}",
        should="exit 0",
        claim="tool",
        call="bash -n .ci/run",
    )
