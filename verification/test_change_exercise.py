"""Issue 37's change exercise, performed at runtime (tool tests, no claim mark).

A new damping law is one module (`reference_impl.theory.laws`): here a law class is
registered inside the test, and every place that is derived from the registry must see
it: the strategies (`law_cases`), ``hcv scenes --laws``, the docs table as Sphinx reads
the page, the scene parser and the solve of its strength from a restitution, the one
exact entry point (`solve`, routed by the class's ``route``), the adapter protocol's
``implemented_law``, and a law module dropped into the package's folder. Unregistered,
it must leave no trace (no cached solve, no row, a refusal in one line). A law
C(q, q') nonlinear in q' goes the generic route and is checked against an mpmath truth
on Hertz. The adapter half: a code registered as a built-in (one module, one registry
line) must reach the registry's lists, ``hcv bench``, the report's side-by-side and
calibrated variants, the chain codes and the pytest markers, and leave no trace after.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import mpmath
import numpy as np
import pytest

from reference_impl.adapters import AdapterScene
from reference_impl.adapters.subprocess import law_from_json
from reference_impl.cli import scenes as scenes_cmd
from reference_impl.errors import HCVInputError
from reference_impl.exact.api import prepare, solve
from reference_impl.potentials import PowerLaw
from reference_impl.scenes import parse_scene
from reference_impl.theory import laws as laws_pkg
from reference_impl.theory.laws import (
    LAWS,
    Decomposition,
    LawFamily,
    Param,
    law_family,
    register_law,
    unregister_law,
)
from reference_impl.theory.laws.docs_table import DOC_PAGES, fill_source
from verification._hcv_run import hcv
from verification._scratch_laws import QuarterPower, one_draw
from verification.assertions import assert_less, assert_true
from verification.strategies import law_cases

ROOT = Path(__file__).resolve().parents[1]
HERTZ, M, V0 = PowerLaw(1e9, 1.5), 0.01, 1.0
# A restitution solved from e at a speed: the root is accepted within 1e-9 of e
# (`reference_impl.scenes._law_restitution._E_TOL`).
E_SOLVE_TOL = 1e-9
# The generic route's estimated bound is ERROR_SAFETY (10) times the difference of its
# runs at rtol 1e-12 and 1e-10 (`reference_impl.exact._generic_law`): ~1e-9 on values of
# order 1. It must stay below this, so that a bound of any size cannot pass.
GENERIC_BOUND_MAX = 1e-7
# The truth below is computed at 20 digits (mpmath's tanh-sinh quadrature, nested for the
# time): against the same at 30 digits it agrees to 5e-16 relative on the contact time and
# to every digit printed on q_max and e (30 digits take 30 s an impact, 20 digits 1 s),
# far below the generic route's ~1e-9 bounds it is compared with.
TRUTH_DPS = 20
CALL = "a law registered at runtime"


class _Quarter(QuarterPower):
    """The exercise's law: C = c q^(1/4) (the route "general"), under its own name."""

    name = "exercise-quarter"


class _RateQuarter(LawFamily):
    """C(q, q') = c q^(1/4) |q'|: a force c q^(1/4) q'|q'|, nonlinear in q' (generic)."""

    name = "exercise-rate-quarter"
    params = (Param("c", "N s^2 m^-2.25"),)
    formula = "c q^(1/4) |q'|"
    strength = "c"
    route = "generic"

    @classmethod
    def C(cls, params, pot, m, q, qdot, ns=np):
        return params["c"] * q**0.25 * abs(qdot)


def _scene(name: str, extra: str = "c = 1000.0\n") -> str:
    return (
        f'name = "exercise"\nmass = {M}\nvelocities = [{V0}, 2.0]\n'
        '[potential]\nfamily = "power"\nk = 1e9\np = 1.5\n'
        f'[damping]\nlaw = "{name}"\n' + extra
    )


def _listed(capsys) -> list[str]:
    """The law names ``hcv scenes --laws`` prints, run in this process (a child process
    would not see a law registered here)."""
    scenes_cmd.run(argparse.Namespace(laws=True, show=None))
    return [line.split()[0] for line in capsys.readouterr().out.splitlines() if line.strip()]


def _built_page(page: str) -> str:
    source = [(ROOT / page).read_text(encoding="utf-8")]
    fill_source(None, page, source)
    return source[0]


def _row(cls) -> str:
    return "| " + " | ".join(cls.docs_row()) + " |"


@pytest.fixture
def quarter():
    register_law(_Quarter)
    yield _Quarter
    unregister_law(_Quarter.name)


def test_every_derived_place_sees_a_law_registered_at_runtime(quarter, capsys):
    name = quarter.name
    pot, m, v0, drawn = one_draw(law_cases(name))
    scene = parse_scene(_scene(name, "restitution = 0.7\nrestitution_speed = 1.0\n"), "<t>")
    solved = solve(HERTZ, M, V0, law=scene.law.to_dict())
    # The same C written as the built-in power law: the route and the kernels are the
    # class's, so the two agree within their bounds (both ~1e-14).
    c = scene.law.params["c"]
    power = solve(HERTZ, M, V0, law={"law": "power", "c": c, "exponent": 0.25})
    as_power = (
        abs(solved.restitution - power.restitution)
        <= (solved.error_restitution + power.error_restitution)
        and abs(solved.contact_time - power.contact_time) <= solved.error_time + power.error_time
    )
    prepared = prepare(HERTZ, M, law=scene.law.to_dict())(V0)
    # the adapter protocol: the request carries the law, a code's implemented_law names it
    request = AdapterScene.from_scene(scene, V0, 1e-7, 100)
    declared = law_from_json({"damping": {"law": name, "c": c}}, request, "exercise")
    seen = {
        "LAWS holds the class": LAWS[name] is quarter and law_family(name) is quarter,
        "law_cases draws it": drawn["law"] == name and drawn["c"] > 0,
        "hcv scenes --laws lists it": name in _listed(capsys),
        "every docs page as built has its row": all(
            _row(quarter) in _built_page(p) for p in DOC_PAGES
        ),
        "the scene solves its strength c": scene.law.name == name
        and scene.calibration["parameter"] == "c",
        "solve reaches e = 0.7 at 1 m/s": abs(solved.restitution - 0.7) < E_SOLVE_TOL,
        "solve routes it as the power law": as_power,
        "prepare solves it bit for bit": prepared.restitution == solved.restitution,
        "the adapter request and protocol carry it": request.damping == name
        and declared.to_json()["damping"]["law"] == name,
    }
    assert_true(
        all(seen.values()),
        got=str({k: v for k, v in seen.items() if not v}),
        should="every derived place to see the law",
        claim="tool",
        call=CALL,
    )


def test_an_unregistered_law_leaves_no_trace(capsys):
    name = _Quarter.name
    law = {"law": name, "c": 1000.0}
    register_law(_Quarter)
    try:
        first = solve(HERTZ, M, V0, law=law)  # fills the one-shot caches
    finally:
        unregister_law(name)
    refusals = {
        "law_family": lambda: law_family(name),
        "solve (the one-shot cache)": lambda: solve(HERTZ, M, V0, law=law),
        "prepare": lambda: prepare(HERTZ, M, law=law),
        "law_cases": lambda: one_draw(law_cases(name)),
        "scene": lambda: parse_scene(_scene(name), "<t>"),
    }
    for where, call in refusals.items():
        with pytest.raises(HCVInputError) as info:
            call()
        text = str(info.value)
        assert_true(
            name in text and "\n" not in text,
            got=text,
            should=f"one line naming {name!r}",
            claim="tool",
            call=f"{where} after unregister_law",
        )
    gone = {
        "LAWS": name not in LAWS,
        "hcv scenes --laws": name not in _listed(capsys),
        "docs": all(f"`{name}`" not in _built_page(p) for p in DOC_PAGES),
    }
    assert_true(all(gone.values()), got=str(gone), should="no trace anywhere", claim="tool",
                call="unregister_law")  # fmt: skip

    # The class, not the name, is what the caches key on: another class under the same
    # name (C doubled) is solved as itself, not from the first one's cached plan.
    class Doubled(_Quarter):
        @classmethod
        def decompose(cls, params):
            return Decomposition(terms=((2 * params["c"], 0.25),))

    register_law(Doubled)
    try:
        second = solve(HERTZ, M, V0, law=law)
        twice = solve(HERTZ, M, V0, law={"law": "power", "c": 2000.0, "exponent": 0.25})
    finally:
        unregister_law(name)
    assert_true(
        second.restitution < first.restitution
        and abs(second.restitution - twice.restitution)
        <= second.error_restitution + twice.error_restitution,
        got=f"e = {second.restitution} (first class {first.restitution}, "
        f"c = 2000 power law {twice.restitution})",
        should="the second class's own law, as the power law at 2c",
        claim="tool",
        call="solve after re-registering the name",
    )


def test_a_law_module_in_the_package_folder_registers_with_no_other_line(tmp_path, monkeypatch):
    """A module saved beside the built-in laws is imported by the package (its folder is
    searched), so a new built-in law is one file."""
    mod = "exercise_dropped_law"
    (tmp_path / f"{mod}.py").write_text(
        "from reference_impl.theory.laws._registry import Decomposition, LawFamily, Param,"
        " register_law\n\n\n@register_law\nclass Dropped(LawFamily):\n"
        '    name = "exercise-dropped"\n    params = (Param("c", "N s/m"),)\n'
        '    formula = "c"\n    strength = "c"\n\n    @classmethod\n'
        "    def decompose(cls, params):\n"
        '        return Decomposition(terms=((params["c"], 0.0),))\n',
        encoding="utf-8",
    )
    monkeypatch.setattr(laws_pkg, "__path__", [*laws_pkg.__path__, str(tmp_path)])
    try:
        found = laws_pkg._import_law_modules()
        fam = LAWS.get("exercise-dropped")
        assert_true(
            found == (mod,) and fam is not None and fam.__module__.endswith(mod),
            got=f"imported {found}, LAWS {list(LAWS)}",
            should=f"({mod!r},) imported and its law registered",
            claim="tool",
            call="reference_impl.theory.laws._import_law_modules",
        )
    finally:
        unregister_law("exercise-dropped")
        sys.modules.pop(f"{laws_pkg.__name__}.{mod}", None)


def test_an_unknown_law_in_a_scene_is_one_line_and_exit_2_from_the_cli(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(_scene("hunt_crossley", "alpha = 0.3\n"), encoding="utf-8")
    r = hcv(["solve", str(path)], tmp_path)
    err = r.stderr.strip()
    assert_true(
        r.returncode == 2 and "hunt_crossley" in err and "hunt-crossley" in err
        and "\n" not in err and r.stdout == "",
        got=f"exit {r.returncode}, stderr {err!r}, stdout {r.stdout[:80]!r}",
        should="exit 2, one line naming 'hunt_crossley' and the near name, nothing printed",
        claim="tool",
        call=f"hcv solve {path.name}",
    )  # fmt: skip


# -- a law nonlinear in q' on the generic route, against an mpmath truth --------------------


def _rate_quarter_truth(k: float, p: float, m: float, v0: float, c: float) -> dict:
    """q_max, e and the contact time of m q'' + c q^(1/4) q'|q'| + k q^p = 0 (`TRUTH_DPS`).

    u = q'^2 as a function of q is linear: du/dq = -a q^(1/4) u - (2/m) U'(q) on the way
    in and du/dq = +a q^(1/4) u - (2/m) U'(q) on the way out (a = 2c/m). With
    E(q) = exp(0.8 a q^(5/4)): u_in E = v0^2 - (2/m) int_0^q U' E and
    u_out / E = (2/m) int_q^q_max U' / E, so q_max solves int_0^q_max U' E = m v0^2 / 2,
    e = sqrt(u_out(0)) / v0 and the time is int dq / sqrt(u) over both halves.
    """
    with mpmath.workdps(TRUTH_DPS):
        k, p, m, v0, c = (mpmath.mpf(x) for x in (k, p, m, v0, c))
        a = 2 * c / m

        def E(q):
            return mpmath.exp(mpmath.mpf(4) / 5 * a * q ** mpmath.mpf(1.25))

        def inner_in(q):
            return mpmath.quad(lambda s: k * s**p * E(s), [0, q])

        # the energy bounds q_max from above: k q^(p+1)/(p+1) <= m v0^2 / 2
        q_hi = ((p + 1) * m * v0**2 / (2 * k)) ** (1 / (p + 1))
        # ... and from below by E's growth; a bracketing solver keeps it in between
        q_max = mpmath.findroot(
            lambda q: inner_in(q) - m * v0**2 / 2, (q_hi / 1000, q_hi), solver="anderson"
        )

        def u_in(q):
            return (v0**2 - 2 / m * inner_in(q)) / E(q)

        def u_out(q):
            return 2 / m * E(q) * mpmath.quad(lambda s: k * s**p / E(s), [q, q_max])

        e = mpmath.sqrt(u_out(0)) / v0
        t = mpmath.quad(lambda q: 1 / mpmath.sqrt(u_in(q)), [0, q_max]) + mpmath.quad(
            lambda q: 1 / mpmath.sqrt(u_out(q)), [0, q_max]
        )
        return {"max_penetration": float(q_max), "restitution": float(e),
                "contact_time": float(t)}  # fmt: skip


@pytest.mark.parametrize("v0, c", [(1.0, 2e3), (0.3, 5e3), (3.0, 500.0)])
def test_a_law_nonlinear_in_the_speed_is_within_its_bound_of_an_mpmath_truth(v0, c):
    k, p = 1e9, 1.5
    law = {"law": _RateQuarter.name, "c": c}
    register_law(_RateQuarter)
    try:
        sol = solve(PowerLaw(k, p), M, v0, law=law)
    finally:
        unregister_law(_RateQuarter.name)
    tr = _rate_quarter_truth(k, p, M, v0, c)
    call = f"solve(Hertz k = {k:g}, {M}, {v0}, law={law})"
    assert_less(abs(sol.restitution - tr["restitution"]), sol.error_restitution, claim="tool",
                call=call, what="|restitution error|")  # fmt: skip
    assert_less(abs(sol.contact_time - tr["contact_time"]), sol.error_time, claim="tool",
                call=call, what="|contact time error|")  # fmt: skip
    # q_max at the event q' = 0 is located to the integrator's tolerance: its time's bound
    # times the speed scale v0 bounds its error (|dq/dt| <= v0), plus round-off on q_max.
    assert_less(abs(sol.max_penetration - tr["max_penetration"]),
                sol.error_time * v0 + 1e-12 * tr["max_penetration"], claim="tool", call=call,
                what="|q_max error|")  # fmt: skip
    assert_less(sol.error_restitution, GENERIC_BOUND_MAX, claim="tool", call=call,
                what="the generic route's bound on e")  # fmt: skip
    assert_true(
        0.2 < tr["restitution"] < 0.95,
        got=f"e = {tr['restitution']}",
        should="a damped impact, so the law's q' dependence is exercised",
        claim="tool",
        call=call,
    )


# -- the adapter half: a new built-in code is one module + its registry entry ----------------

_ADAPTER_MODULE = '''
from reference_impl.adapters._declaration import CodeInfo
from reference_impl.adapters.reference import ReferenceAdapter


class ExerciseAdapter(ReferenceAdapter):
    """A new code for the exercise: the suite's Verlet under another name."""

    name = "exercise_code"
    supports_assembly = True  # declared only, so that the chain codes' list must see it
    code_info = CodeInfo.pip(
        name,
        code="Exercise",
        restitution_input="the restitution e, typed as is",
        report_variants=(("exercise_code", 1.0),),
        calibrated=(("exercise_code", 1.0, "zeta"),),
    )
'''
_NAME = "exercise_code"


def _register_exercise_code(registry, tmp: Path) -> None:
    """The one registry line of a new built-in code (its module written to ``tmp``)."""
    (tmp / "exercise_adapter.py").write_text(_ADAPTER_MODULE, encoding="utf-8")
    if str(tmp) not in sys.path:
        sys.path.insert(0, str(tmp))
    registry._REGISTRY[_NAME] = "exercise_adapter:ExerciseAdapter"
    registry._BUILTIN = (*registry._BUILTIN, _NAME)


# What is derived at import (the side-by-side and calibrated variants, the chain codes,
# the pytest markers) is read in a child process that registers the code (the module
# `_register_exercise_code` wrote) first, as a built-in is registered before anything
# imports the registry's lists.
_CHILD = """
import json, sys
sys.path.insert(0, {root!r})
sys.path.insert(0, {tmp!r})
from reference_impl.adapters import registry
registry._REGISTRY[{name!r}] = "exercise_adapter:ExerciseAdapter"
registry._BUILTIN = (*registry._BUILTIN, {name!r})
from reference_impl.bench import assembly_codes, codes
from reference_impl.campaign import _codes
import pytest
seen = {{
    "side-by-side variants": list(codes.CODES),
    "calibrated variants": list(codes.CALIBRATED),
    "hcv report --adapter NAME": _codes.select([{name!r}]),
    "chain codes": list(assembly_codes.CODES),
}}
print("JSON", json.dumps(seen))
pytest.main(["--markers", "-p", "no:cacheprovider", "-q"])
"""


def test_every_derived_place_sees_an_adapter_registered_as_a_built_in(tmp_path, monkeypatch):
    from reference_impl.adapters import registry

    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    monkeypatch.setattr(registry, "_BUILTIN", registry._BUILTIN)
    monkeypatch.setattr(sys, "path", list(sys.path))
    _register_exercise_code(registry, tmp_path)
    try:
        live = {
            "builtin_codes": _NAME in registry.builtin_codes(),
            "install_extras (.ci/run, nox)": _NAME in registry.install_extras(),
            "hcv bench NAME": registry.get_adapter(_NAME).name == _NAME,
            "hcv bench --help": f"  {_NAME}" in registry.adapter_help().splitlines(),
        }
    finally:
        sys.modules.pop("exercise_adapter", None)
    child = subprocess.run(
        [sys.executable, "-c", _CHILD.format(root=str(ROOT), tmp=str(tmp_path), name=_NAME)],
        capture_output=True, text=True, cwd=ROOT, timeout=120,
    )  # fmt: skip
    line = next((ln for ln in child.stdout.splitlines() if ln.startswith("JSON ")), "JSON {}")
    seen = json.loads(line[5:])
    want = ["Exercise", _NAME, 1.0]
    derived = {
        "side-by-side variants": want in seen.get("side-by-side variants", []),
        "calibrated variants": [*want, "zeta"] in seen.get("calibrated variants", []),
        "hcv report --adapter NAME": want in (seen.get("hcv report --adapter NAME") or [[]])[0],
        "chain codes": _NAME in seen.get("chain codes", []),
        "pytest marker": f"@pytest.mark.{_NAME}: needs Exercise" in child.stdout,
    }
    assert_true(
        all(live.values()) and all(derived.values()),
        got=f"{live}; {derived}; child stderr {child.stderr[-300:]!r}",
        should="every derived place to see the code",
        claim="tool",
        call="an adapter registered as a built-in",
    )


def test_an_adapter_unregistered_leaves_no_trace():
    from reference_impl.adapters import registry

    with pytest.raises(HCVInputError) as info:
        registry.get_adapter(_NAME)
    gone = {
        "builtin_codes": _NAME not in registry.builtin_codes(),
        "registered": _NAME not in registry.registered(),
        "one line naming it": _NAME in str(info.value) and "\n" not in str(info.value),
    }
    assert_true(all(gone.values()), got=str(gone), should="no trace of the exercise's code",
                claim="tool", call="the registry after the exercise")  # fmt: skip
