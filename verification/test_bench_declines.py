"""hcv bench when a code declines scenes (issue 26 review, F6): one rule for every kind.

Whoever declines (a Python adapter's ``supports``, or a cmd: program's
``{"unsupported": reason}`` during the run), the declined scene is skipped with one line
naming the reason (not one per metric), and a run that declined everything measured
nothing: exit 1 with --gate, 0 without, never 2 (the input is valid).
"""

from __future__ import annotations

import sys

import pytest

from reference_impl.adapters.reference import ReferenceAdapter
from reference_impl.bench import run_bench
from reference_impl.bench.scorecard.report import scorecard_text
from verification._adapter_cases import FAST, scene

from .assertions import assert_true

CLAIM = "bench-laws"  # the benchmark machinery, not a paper claim

_PROGRAM = """import json, sys
json.load(sys.stdin)
print(json.dumps({"unsupported": "declines everything"}))
"""


class _SupportsNothing(ReferenceAdapter):
    """A Python adapter whose ``supports`` declines every scene (before any run)."""

    name = "supports-nothing"
    isolate = False

    def supports(self, scene):
        return "declines everything"


@pytest.mark.parametrize("kind", ["supports", "cmd"])
def test_a_code_declining_every_scene_measured_nothing_with_one_line_per_scene(tmp_path, kind):
    if kind == "cmd":
        prog = tmp_path / "decline.py"
        prog.write_text(_PROGRAM)
        adapter = f"cmd:{sys.executable} {prog}"
    else:
        adapter = _SupportsNothing()
    scenes = [scene("one", vels=(0.5,)), scene("two", vels=(0.5,))]
    try:
        res = run_bench(adapter, scenes=scenes, tolerances=FAST)
    except Exception as exc:  # main: HCVInputError "supports none of the scenes" (exit 2)
        res, err = None, f"{type(exc).__name__}: {exc}"
    else:
        err = ""
    lines = scorecard_text(res).splitlines() if res is not None else []
    declined = [ln for ln in lines if "declines everything" in ln]
    ok = (
        res is not None
        and res.measured_nothing
        and (res.exit_status(True), res.exit_status(False)) == (1, 0)
        and len(declined) == 2  # one per scene, not one per metric
        and all(ln.strip().startswith("SKIPPED") for ln in declined)
    )
    assert_true(
        ok,
        got=err
        or f"exit (gate, no gate) {(res.exit_status(True), res.exit_status(False))}; "
        f"lines naming the reason {declined}",
        should="nothing measured: exit 1 with --gate, 0 without; one SKIPPED line per "
        "declined scene by default",
        claim=CLAIM,
        call=f"run_bench({kind} adapter declining both scenes)",
    )
