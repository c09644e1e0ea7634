"""The five-codes table (`reference_impl.bench.codes`, issue 28), on codes always present.

The reference adapter (textbook velocity Verlet of the universal law) stands in for
a code: its rows must deliver the asked restitution within the step's error, the
same at both speeds (Theorem 3), with the tensile pull of the unclipped law; a code
that cannot be built gives rows that say why instead of numbers. The rows of the
real codes are checked in test_liggghts.py and test_yade.py (the issue's table).
"""

from __future__ import annotations

import math

from reference_impl.bench.codes import SPEEDS, codes_table

from .assertions import assert_close, assert_true

CLAIM = "bench-codes-table"  # the benchmark machinery, not a paper claim


def test_codes_table_rows_and_missing_codes():
    rows = codes_table(
        codes=[("reference", "reference", 1.5), ("nowhere", "nocode", 1.5)],
        asked=(0.5,),
        steps=(200, 20),
    )
    assert len(rows) == 2 * 2 * len(SPEEDS)
    ref = [r for r in rows if r.code == "reference"]
    for r in ref:
        assert not r.error, r.error
        # Verlet with a half-step dashpot velocity: first order, measured 0.05 % at 200
        # steps per contact and 0.5 % at 20 for e = 0.5 (x 2 margin)
        tol = 1e-3 if r.steps_per_contact == 200 else 1e-2
        assert_close(r.delivered, 0.5, rtol=tol, claim=CLAIM, call=f"reference {r}")
        assert_close(r.declared_exact, 0.5, rtol=1e-9, claim=CLAIM, call="declared law's exact e")
        assert_true(
            0.0 < r.tensile < 0.2,
            got=f"tensile {r.tensile:.4g}",
            should="a pull of a few % of the peak (unclipped universal law)",
            claim=CLAIM,
            call="reference tensile",
        )
    for n in (200, 20):
        a, b = (r.delivered for r in ref if r.steps_per_contact == n)
        assert_close(a, b, rtol=1e-9, claim=CLAIM, call=f"e at {SPEEDS} m/s, N = {n}")
    missing = [r for r in rows if r.code == "nowhere"]
    assert all("unknown adapter 'nocode'" in r.error and math.isnan(r.delivered) for r in missing)


def test_calibration_table_finds_the_input_or_says_out_of_reach():
    """A cmd: program whose option scales the damping it integrates: the option that
    delivers the asked e is 1 (to the step's first-order error, 3e-3 at 200 steps per
    contact); over a range of at least twice the damping the target is out of reach, with
    the span delivered (below it); a missing code is a row saying why."""
    import sys
    from pathlib import Path

    from reference_impl.bench.codes import calibration_table

    script = f"{sys.executable} {Path(__file__).resolve().parent / '_persistent_script.py'}"
    spec = f"cmd[persistent=true]:{script}"
    rows = calibration_table(
        codes=[
            ("script", spec, 1.5, "zeta_scale", (0.2, 3.0)),
            ("narrow", spec, 1.5, "zeta_scale", (2.0, 3.0)),  # twice the damping at least
            ("nowhere", "nocode", 1.5, "x"),
        ],
        asked=(0.5,),
    )
    by = {(r["code"], r["asked"]): r for r in rows}
    assert by[("script", 0.5)]["found"], by[("script", 0.5)]
    assert_close(by[("script", 0.5)]["value"], 1.0, rtol=3e-3, claim=CLAIM, call="zeta_scale")
    out = by[("narrow", 0.5)]
    assert not out["found"] and "out of reach" in out["message"] and out["delivered"][1] < 0.5
    assert "unknown adapter" in by[("nowhere", 0.5)]["error"]
