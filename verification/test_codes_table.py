"""The five-codes table (`reference_impl.bench.codes`, issue 28), on codes always present.

The reference adapter (textbook velocity Verlet of the universal law) stands in for
a code: its rows must deliver the asked restitution within the step's error, the
same at both speeds (Theorem 3), with the tensile pull of the unclipped law; a code
that cannot be built gives rows that say why instead of numbers. The rows of the
real codes are checked in test_liggghts.py and test_yade.py (the issue's table).
"""

from __future__ import annotations

import math

import pytest

from reference_impl.bench.codes import SPEEDS, codes_table
from reference_impl.theory.damping import zeta_from_restitution

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


# -- each asked e typed into the code as is (the table's point, docs/crosswalk.md) ------

# Why a code is not here: its one-line install (its cases skip with it).
_INSTALLED = {
    "lammps": ("reference_impl.adapters.lammps", "lammps_available"),
    "kratos": ("reference_impl.adapters.kratos", "kratos_available"),
    "liggghts": ("reference_impl.adapters.liggghts", "liggghts_available"),
    "yade": ("reference_impl.adapters.yade", "yade_available"),
    "mujoco": ("reference_impl.adapters.mujoco", "mujoco_available"),
    "drake": ("reference_impl.adapters.drake", "drake_available"),
    "pybullet": ("reference_impl.adapters.pybullet", "pybullet_available"),
}


def _missing(spec: str) -> str | None:
    import importlib

    from reference_impl.adapters.registry import parse_spec

    module, fn = _INSTALLED[parse_spec(spec)[0]]
    return getattr(importlib.import_module(module), fn)()


def _typed_input(law, p: float, e: float) -> list[tuple[str, float, float]]:
    """(input, value in the code's mapping, value a user types for e) of one variant.

    A user types e itself where the code's input is a restitution; YADE ViscElMat's
    tc / cn and MuJoCo's dampratio are the linear spring-dashpot's of that e at q = 0
    (Pournin 2001: tc = sqrt((pi^2 + ln^2 e) m / k), c = 2 zeta sqrt(m k), per material
    2 c in series).
    """
    from reference_impl.bench.codes import HERTZ_K, HOOKE_K, MASS

    par = law.params
    k = HERTZ_K if p == 1.5 else HOOKE_K
    zeta = zeta_from_restitution(e)
    if "coef" in par:  # LAMMPS pair_coeff
        return [("LAMMPS pair_coeff e", par["coef"], e)]
    if "coefficientRestitution" in par:
        return [("LIGGGHTS coefficientRestitution", par["coefficientRestitution"], e)]
    if "gamma" in par:
        return [("Kratos COEFFICIENT_OF_RESTITUTION", par["restitution"], e)]
    if "ip2" in par:
        return [("YADE Mindlin en", par["ip2"][1], e)] if par["ip2"][0] == "en" else []
    if par.get("input") == "tc":
        tc = math.sqrt((math.pi**2 + math.log(e) ** 2) * MASS / k)
        return [("YADE ViscElMat en", par["material"]["en"], e),
                ("YADE ViscElMat tc", par["material"]["tc"], tc)]  # fmt: skip
    if par.get("input") == "kn":
        return [("YADE ViscElMat cn", par["material"]["cn"], 4.0 * zeta * math.sqrt(MASS * k))]
    if "relaxation_time" in par:  # Drake SAP: the dashpot of e at q = 0 over the spring
        return [("Drake relaxation_time", par["relaxation_time"], 2.0 * zeta * math.sqrt(MASS / k))]
    if "contactDamping" in par:  # PyBullet soft: the dashpot of e at q = 0, half per body
        return [
            (
                "PyBullet contactDamping",
                sum(par["contactDamping"]),
                2.0 * zeta * math.sqrt(MASS * k),
            )
        ]
    return [("MuJoCo dampratio", par["solref"][1], zeta)]


def _specs_run(monkeypatch, codes, asked):
    """The adapter spec `codes_table` runs for each (code spec, asked e), without
    running anything (the executor is refused and the spec kept)."""
    from reference_impl.bench import codes as bc
    from reference_impl.errors import HCVInputError

    seen: list[str] = []

    def refuse(spec):
        seen.append(spec)
        raise HCVInputError("not run here")

    monkeypatch.setattr(bc, "make_executor", refuse)
    bc.codes_table(codes=codes, asked=asked, steps=(200,), speeds=(0.01,))
    return seen


def _code_cases():
    from reference_impl.bench.codes import CODES

    return [pytest.param(c, id=c[1]) for c in CODES]


@pytest.mark.parametrize("variant", _code_cases())
def test_codes_table_types_e_into_the_code_as_is(monkeypatch, variant):
    """Each variant of CODES gets each asked e in its own input unchanged, not the
    input the adapter maps to deliver e (protocol hcv-adapter/2): the table shows what
    the code does with e typed in. Checked on the adapter's mapping, no code run."""
    from reference_impl.adapters.registry import get_adapter
    from reference_impl.bench.codes import ASKED, _scene

    code, spec, p = variant
    reason = _missing(spec)
    if reason:
        pytest.skip(reason)
    specs = _specs_run(monkeypatch, [variant], ASKED)
    # one spec per asked e, or one for them all (the scene's e then goes through the
    # adapter's own mapping)
    assert len(specs) in (1, len(ASKED)), specs
    for e, run in zip(ASKED, specs * len(ASKED) if len(specs) == 1 else specs, strict=True):
        adapter = get_adapter(run)
        try:
            law = adapter.implemented_law(_scene(p, e, 0.01, 200))
        finally:
            adapter.close()
        typed = _typed_input(law, p, e)
        assert typed, f"got no e input in {law.params}, should have one [{CLAIM}, {run}]"
        for what, got, want in typed:
            # the value written as is: a float through the spec's repr, exactly
            assert_close(got, want, rtol=0.0, claim=CLAIM, call=f"{run}: {what} for e = {e}")


def _committed_row(spec: str, asked: float, n: int, v0: float) -> dict:
    import json
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "reports" / "results.json"
    rows = json.loads(path.read_text())["codes_side_by_side"]["rows"]
    return next(
        r for r in rows
        if (r["spec"], r["asked"], r["steps_per_contact"], r["v0"]) == (spec, asked, n, v0)
    )  # fmt: skip


@pytest.mark.liggghts
def test_liggghts_limit_force_delivers_its_own_e_for_e_typed():
    """LIGGGHTS with limitForce on, coefficientRestitution 0.5 typed: the clipped contact
    leaves at the zero-force end, e ~ 0.55 (the committed table's value), not the 0.5
    the adapter's own mapping would deliver."""
    from reference_impl.adapters.liggghts import liggghts_available

    reason = liggghts_available()
    if reason:
        pytest.skip(reason)
    spec = "liggghts[hertz,wall,limit_force=true]"
    (row,) = codes_table(codes=[("LIGGGHTS", spec, 1.5)], asked=(0.5,), steps=(200,),
                         speeds=(0.01,))  # fmt: skip
    assert not row.error, row.error
    want = _committed_row(spec, 0.5, 200, 0.01)["delivered"]
    # the same LIGGGHTS input and step as the committed run: equal to its stored digits
    # up to the text output's round-off (LIGGGHTS prints 17 significant digits)
    assert_close(row.delivered, want, rtol=1e-12, claim=CLAIM, call=f"{spec}, e = 0.5 typed")
    assert row.variant == "liggghts[hertz,wall,limit_force]", row.variant


def test_calibration_table_keeps_the_other_inputs_as_typed(monkeypatch):
    """`calibration_table` searches one option, which the adapters take over their own
    mapping of e; the code's other e input is typed as is by the adapter itself (YADE
    ViscElMat's tc of the asked e: `test_yade.py`), so every spec is searched unchanged.
    Checked on the specs the search is given, no code run."""
    from reference_impl.adapters.registry import parse_spec
    from reference_impl.bench import codes as bc
    from reference_impl.errors import HCVInputError

    seen: list[str] = []

    def refuse(spec, scene, **kw):
        seen.append(spec)
        raise HCVInputError("not run here")

    monkeypatch.setattr(bc, "calibrate", refuse)
    rows = bc.calibration_table(asked=(0.5,))
    assert len(seen) == len(bc.CALIBRATED) == len(rows), seen
    for (_code, spec, _p, param, *_), run in zip(bc.CALIBRATED, seen, strict=True):
        opts = parse_spec(run)[1]
        assert param not in opts, f"got {run}, should leave {param} to the search [{CLAIM}]"
        assert run == spec, f"got {run}, should be {spec} unchanged [{CLAIM}]"
