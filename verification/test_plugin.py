"""The pytest plugin (``pytest --contact-adapter``) on a metric our reference cannot decide.

Issue 12, section 3: an error of ours must never count against the code under
test. In ``hcv bench`` such a metric has the status "error"; the plugin turns it
into a failed test whose message names our reference ("internal error of the
reference (ours ...)"), raised as `ContactReferenceError`, never as the code's
`ContactMetricFailure`. The reference is broken on purpose by a conftest.py in
the user's directory (the exact solver raising, as it did on ``abs(...)``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from .assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent
CLAIM = "bench-plugin"  # the benchmark machinery, not a paper claim

_SCENE = """
name = "tiny"
mass = 4.1103e-3
velocities = [1.0]
[potential]
family = "power"
k = 1.0879e10
p = 1.5
[damping]
law = "universal"
zeta = 0.1
"""
# Coarser critical-step bisection and a shorter speed table than the defaults (speed).
_FAST = "[dt_crit]\nresolution = 0.05\n[run]\nspeed_error_steps = [50, 100, 200]\n"
# The user's conftest: our exact solver raises (as sympy's DiracDelta did on abs(q));
# the exception type of each failed metric test is recorded in raised.txt.
_CONFTEST = """
import pytest

from reference_impl.bench.scorecard import runner


def _broken(law, v0, **kw):
    raise NameError("name 'DiracDelta' is not defined")


runner.exact_reference = _broken


def pytest_runtest_makereport(item, call):
    if call.when == "call" and call.excinfo is not None and not call.excinfo.errisinstance(pytest.skip.Exception):
        with open("raised.txt", "a") as fh:
            print(item.metric, call.excinfo.typename, file=fh)
"""
OURS = "internal error of the reference (ours"


def test_reference_error_fails_the_test_naming_our_reference(tmp_path):
    (tmp_path / "tiny.toml").write_text(_SCENE)
    (tmp_path / "fast.toml").write_text(_FAST)
    (tmp_path / "conftest.py").write_text(_CONFTEST)
    js = tmp_path / "bench.json"
    r = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-v", "-rf",
         "--contact-adapter=verification._adapter_script:ScriptAdapter",
         f"--contact-scenes={tmp_path / 'tiny.toml'}",
         f"--contact-tolerances={tmp_path / 'fast.toml'}", f"--contact-json={js}"],
        cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "400"},
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    out = r.stdout
    assert r.returncode == 1, out[-3000:] + r.stderr[-2000:]
    doc = json.loads(js.read_text())
    errors = {m["metric"] for m in doc["metrics"] if m["status"] == "error"}
    assert doc["status"] == "error" and "restitution_exact" in errors, doc["status"]
    assert not [m for m in doc["metrics"] if m["status"] == "fail"]
    failed = [line for line in out.splitlines() if line.startswith("FAILED ")]
    assert_true(
        sorted(line.split("::")[-1].split()[0] for line in failed) == sorted(errors)
        and all(OURS in line for line in failed),
        got="\n".join(failed) or out[-2000:],
        should=f"one failed test per metric our reference could not decide ({sorted(errors)}), "
        "each naming our reference",
        claim=CLAIM,
        call="pytest --contact-adapter (broken exact reference)",
    )
    assert "restitution_exact [script / tiny]: " + OURS in out
    raised = dict(line.split() for line in (tmp_path / "raised.txt").read_text().splitlines())
    assert raised == dict.fromkeys(errors, "ContactReferenceError"), raised
    passed = [line for line in out.splitlines() if "PASSED" in line]
    assert any("restitution_asked" in line for line in passed), out[-3000:]
