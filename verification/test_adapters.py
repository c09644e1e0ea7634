"""Adapter contract, registry, subprocess protocol, run isolation, the gate and its reports.

The third-party code is `verification/_adapter_script.py`: a standard-library
velocity Verlet speaking the JSON protocol, which can be told to hang, crash or
answer garbage, plus Python adapters that crash, hang or return malformed
output inside the benchmark's worker process.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from reference_impl.adapters import (
    AdapterOutputError,
    AdapterRunError,
    ContactAdapter,
    ImplementedLaw,
    PowerDamping,
    get_adapter,
    register,
    registered,
    trajectory_from_mapping,
)
from reference_impl.adapters.reference import ReferenceAdapter, verlet_trajectory
from reference_impl.adapters.registry import builtin_codes, parse_spec
from reference_impl.adapters.subprocess import SubprocessAdapter
from reference_impl.bench import load_tolerances, metric_names, run_bench
from reference_impl.bench.scorecard.metrics import exact_reference, measure
from reference_impl.errors import HCVInputError
from reference_impl.integrators.verlet import SCENE_IMPACT, LaneBatch, run_lanes
from reference_impl.potentials import PowerLaw
from reference_impl.scenes import parse_scene
from reference_impl.theory.damping import restitution_from_zeta
from verification._adapter_cases import FAST, HCV_BENCH, SCRIPT, ascene, cmd, scene, scene_text
from verification._adapter_cases import by as _by

from .assertions import assert_close, assert_true

ROOT = Path(__file__).resolve().parent.parent
CLAIM = "bench-adapters"  # not a paper claim: the benchmark machinery (no claim marker)


# ----------------------------------------------------------------------------
# the contract
# ----------------------------------------------------------------------------
def _good():
    return {
        "t": [0.0, 1.0, 2.0],
        "q": [0.0, 0.5, -0.1],
        "v": [1.0, 0.0, -1.0],
        "force": [0.0, 2.0, 0.0],
    }


def test_valid_output_becomes_a_trajectory():
    tr = trajectory_from_mapping({**_good(), "meta": {"code": "x"}})
    assert tr.t.dtype == float and tr.meta == {"code": "x"}
    # A blown-up run (non-finite values, written as null in JSON) is a result, not malformed.
    tr = trajectory_from_mapping({**_good(), "q": [0.0, None, float("inf")]})
    assert math.isnan(tr.q[1]) and math.isinf(tr.q[2])


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d.pop("force"), "no 'force'"),
        (lambda d: d.update(q=[0.0, 1.0]), "'q' has 2 samples but 't' has 3"),
        (lambda d: d.update(t=[0.0, 2.0, 1.0]), "must increase strictly"),
        (lambda d: d.update(t=[1.0, 2.0, 3.0]), "must start at 0"),
        (lambda d: d.update(v="fast"), "not an array of numbers"),
        (lambda d: d.update(t=[[0.0, 1.0, 2.0]]), "must be 1-D"),
        (lambda d: d.update(meta=[1]), "'meta' must be a mapping"),
    ],
)
def test_malformed_output_is_refused_in_one_line(change, message):
    d = _good()
    change(d)
    with pytest.raises(AdapterOutputError, match=message) as exc:
        trajectory_from_mapping(d, who="code")
    assert "\n" not in str(exc.value)


def test_public_impact_validates_what_the_hook_returns():
    class Bad(ContactAdapter):
        name = "bad"

        def _impact_impl(self, scene):
            return [1, 2, 3]

    with pytest.raises(AdapterOutputError, match="bad: returned list"):
        Bad().impact(ascene())


def test_implemented_law_takes_zeta_or_c_not_both():
    pot = PowerLaw(1e10, 1.5)
    with pytest.raises(HCVInputError, match="not both"):
        ImplementedLaw(pot, 1.0, zeta=0.1, C=PowerDamping(1.0))
    law = ImplementedLaw(pot, 1.0, C=PowerDamping(2.0, 0.25))
    assert law.zeta is None
    assert_close(
        law.damping_coefficient(np.array([16.0])),
        [4.0],
        rtol=1e-15,
        claim=CLAIM,
        call="ImplementedLaw.damping_coefficient",
    )


def test_tsuji_power_damping_is_the_universal_law():
    """C = c q^((p-1)/2) is solved with the exact solver, at zeta = c / (2 sqrt(m k (p+1)/2))."""
    pot, m, zeta = PowerLaw(1.0879e10, 1.5), 4.1103e-3, 0.1
    c = 2 * zeta * math.sqrt(m * pot.k * 2.5 / 2)
    ex = exact_reference(ImplementedLaw(pot, m, C=PowerDamping(c, 0.25)), 1.0)
    assert ex["method"].startswith("exact")
    assert_close(
        ex["restitution"],
        restitution_from_zeta(zeta),
        rtol=1e-13,
        claim=CLAIM,
        call="exact_reference(PowerDamping(c, 1/4))",
    )


# ----------------------------------------------------------------------------
# registry and specs
# ----------------------------------------------------------------------------
def test_unknown_adapter_lists_the_registered_ones():
    with pytest.raises(HCVInputError) as exc:
        get_adapter("nosuch")
    for name in ("reference", *builtin_codes(), "subprocess"):
        assert name in str(exc.value)


def test_import_path_and_constructor_arguments():
    a = get_adapter("verification._adapter_script:ScriptAdapter")
    assert type(a).__name__ == "ScriptAdapter"
    assert parse_spec("lammps[damping=tsuji,geometry=pair,radius=0.01,limit_damping=true]") == (
        "lammps",
        {"damping": "tsuji", "geometry": "pair", "radius": 0.01, "limit_damping": True},
    )
    assert parse_spec("cmd:./code --x") == ("subprocess", {"command": "./code --x"})
    sub = get_adapter(f"cmd:{sys.executable} {SCRIPT} --mode ok")
    assert isinstance(sub, SubprocessAdapter) and sub.label == "_adapter_script.py"


@pytest.mark.parametrize(
    "spec, message",
    [
        ("verification._adapter_script:NoSuch", "has no attribute 'NoSuch'"),
        ("verification.no_such_module:X", "cannot import module"),
        ("verification._adapter_script:integrate", "is not a ContactAdapter subclass"),
        ("reference[bogus=1]", "bad arguments"),
        ("reference[novalue]", "must be key=value"),
        ("cmd:", "needs a command"),
    ],
)
def test_bad_specs_are_usage_errors(spec, message):
    with pytest.raises(HCVInputError, match=message):
        get_adapter(spec)


def test_register_a_name():
    from verification._adapter_script import ScriptAdapter

    register("script-test", ScriptAdapter)
    assert "script-test" in registered()
    assert isinstance(get_adapter("script-test"), ScriptAdapter)
    with pytest.raises(HCVInputError):
        register("bad name!", ScriptAdapter)


# ----------------------------------------------------------------------------
# the reference adapter (our Verlet through the contract)
# ----------------------------------------------------------------------------
def test_reference_adapter_is_the_lane_engine():
    """Same scheme as run_lanes: the rebound energy agrees to round-off."""
    s = ascene(v0=1.0)
    tr = ReferenceAdapter().impact(s)
    batch = LaneBatch(dt=np.array([s.dt]), y0=0.0, v0=s.v0, e_limit=np.inf, max_steps=s.n_steps)
    res = run_lanes(s.potential, s.mass, SCENE_IMPACT, batch, zeta=s.zeta)
    e_lanes = math.sqrt(res.e_end[0] / (0.5 * s.mass * s.v0**2))
    assert int(res.steps[0]) == tr.t.size - 1
    assert_close(
        -tr.v[-1] / s.v0,
        e_lanes,
        rtol=1e-13,
        claim=CLAIM,
        call="ReferenceAdapter().impact vs run_lanes",
    )


def test_reference_adapter_converges_to_the_exact_solution():
    s = ascene(v0=1.0, n_per_contact=800)
    m = measure(ReferenceAdapter().impact(s), s.v0)
    ex = exact_reference(ReferenceAdapter().implemented_law(s), s.v0)
    for key, tol in (("restitution", 1e-4), ("contact_time", 3e-4), ("max_penetration", 2e-4)):
        assert_close(m[key], ex[key], rtol=tol, claim=CLAIM, call=f"measure(...)[{key!r}]")


def test_power_damping_and_clipping_in_the_reference_verlet():
    """C = c q^a and clip are the laws LAMMPS's models map onto; clip removes all tension."""
    pot, m = PowerLaw(1.0879e10, 1.5), 4.1103e-3
    t, q, v, f = verlet_trajectory(pot, m, 1.0, 2e-7, 5000, damping=PowerDamping(60.0, 0.0))
    assert f[1:-1].min() < 0  # a constant dashpot pulls at the end of contact
    t, q, v, f = verlet_trajectory(
        pot, m, 1.0, 2e-7, 5000, damping=PowerDamping(60.0, 0.0), clip=True
    )
    assert f.min() == 0.0


# ----------------------------------------------------------------------------
# the subprocess adapter
# ----------------------------------------------------------------------------
def test_subprocess_script_matches_the_reference_verlet():
    s = ascene(v0=1.0)
    tr = get_adapter(cmd()).impact(s)
    ref = ReferenceAdapter().impact(s)
    assert tr.t.size == ref.t.size
    assert_close(
        tr.q,
        ref.q,
        rtol=0,
        atol=1e-12 * ref.q.max(),
        claim=CLAIM,
        call="subprocess adapter q(t) vs reference",
    )


@pytest.mark.parametrize(
    "mode, error, message",
    [
        ("crash", AdapterRunError, "exit status 3"),
        ("abort", AdapterRunError, "killed by signal 6"),
        ("garbage", AdapterOutputError, "stdout is not one JSON object"),
        ("malformed", AdapterOutputError, "'force' has"),
        ("error", AdapterRunError, "mesh generation failed"),
    ],
)
def test_subprocess_failures_are_one_line_with_stderr(mode, error, message):
    with pytest.raises(error, match=message) as exc:
        get_adapter(cmd("--mode", mode)).impact(ascene())
    assert "\n" not in str(exc.value)
    if mode in ("crash", "abort"):
        assert "adapter-script:" in exc.value.stderr


def test_subprocess_timeout_kills_the_command():
    adapter = SubprocessAdapter([sys.executable, str(SCRIPT), "--mode", "hang"], timeout=1.0)
    t0 = time.perf_counter()
    with pytest.raises(AdapterRunError, match="timeout after 1 s"):
        adapter.impact(ascene())
    assert time.perf_counter() - t0 < 10


def test_subprocess_declared_law_is_used():
    s = ascene()
    adapter = get_adapter(cmd("--mode", "tsuji"))
    adapter.impact(s)
    law = adapter.implemented_law(s)
    assert_close(law.zeta, 0.5 * s.zeta, rtol=1e-15, claim=CLAIM, call="implemented_law")


# ----------------------------------------------------------------------------
# the benchmark: scorecard, isolation, reports, gate
# ----------------------------------------------------------------------------
def test_bench_of_the_subprocess_script_passes_and_writes_reports(tmp_path):
    res = run_bench(
        cmd(),
        scenes=[scene()],
        tolerances=FAST,
        json_path=tmp_path / "b.json",
        junit_path=tmp_path / "b.xml",
    )
    assert res.exit_status(gate=True) == 0, [m.explanation for m in res.failures]
    assert {m.metric for m in res.metrics} == set(metric_names())
    doc = json.loads((tmp_path / "b.json").read_text())
    assert doc["schema"] == "hcv-bench/1" and doc["status"] == "pass"
    assert {"commit", "python", "cpu_count", "packages"} <= set(doc["machine"])
    assert doc["speed_error"] and doc["records"][0]["speeds"][0]["exact"]["restitution"] > 0
    root = ET.parse(tmp_path / "b.xml").getroot()
    assert root.tag == "testsuites"
    cases = root.findall("./testsuite/testcase")
    assert len(cases) == int(root.get("tests")) == len(res.metrics)
    assert int(root.get("failures")) == 0
    assert int(root.get("skipped")) == len(root.findall("./testsuite/testcase/skipped"))


def test_declared_law_separates_asked_from_implemented():
    """A code that halves the damping fails restitution_asked but not restitution_exact."""
    res = run_bench(cmd("--mode", "tsuji"), scenes=[scene(vels=(1.5,))], tolerances=FAST)
    asked, exact = _by(res, "small", "restitution_asked"), _by(res, "small", "restitution_exact")
    assert_true(
        asked.status == "fail" and exact.status == "pass",
        got=f"{asked.status}/{exact.status}",
        should="fail/pass",
        claim=CLAIM,
        call="run_bench(--mode tsuji)",
    )
    assert "was asked" in asked.explanation and "\n" not in asked.explanation
    assert res.exit_status(gate=True) == 1 and res.exit_status(gate=False) == 0


def test_crashing_command_fails_its_scene_and_the_run_goes_on(tmp_path):
    scenes = [scene("slow", vels=(0.5,)), scene("fast", vels=(2.0,)), scene("slow2", vels=(0.7,))]
    res = run_bench(
        cmd("--mode", "crash", "--above", "1"),
        scenes=scenes,
        tolerances=FAST,
        json_path=tmp_path / "b.json",
        junit_path=tmp_path / "b.xml",
    )
    fast = _by(res, "fast", "restitution_exact")
    assert fast.status == "fail" and "exit status 3" in fast.explanation
    for name in ("slow", "slow2"):  # scenes before and after the crash are unaffected
        assert _by(res, name, "restitution_exact").status == "pass"
    doc = json.loads((tmp_path / "b.json").read_text())
    rec = next(r for r in doc["records"] if r["scene"] == "fast")["speeds"][0]
    assert "simulated crash" in rec["stderr"]
    failure = (
        ET.parse(tmp_path / "b.xml")
        .getroot()
        .find(
            "./testsuite/testcase[@classname='hcv.bench._adapter_script.py.fast']"
            "[@name='restitution_exact']/failure"
        )
    )
    assert failure is not None and "exit status 3" in failure.get("message")
    assert "simulated crash" in failure.text


@pytest.mark.parametrize(
    "cls, message",
    [
        ("CrashAdapter", "crashed (worker exited with status 139)"),
        ("HangAdapter", "timeout after 2 s"),
        ("MalformedAdapter", "'q' has"),
    ],
)
def test_python_adapter_isolated_in_a_worker(cls, message):
    """A Python adapter that dies, hangs or returns garbage fails that run only."""
    tol = {**FAST, "run": {**FAST["run"], "timeout": 2.0}}
    res = run_bench(
        f"verification._adapter_script:{cls}",
        scenes=[scene("ok", vels=(0.5,)), scene("bad", vels=(2.0,))],
        tolerances=tol,
    )
    bad = _by(res, "bad", "restitution_exact")
    assert bad.status == "fail" and message in bad.explanation, bad.explanation
    assert _by(res, "ok", "restitution_exact").status == "pass"
    if cls != "MalformedAdapter":
        rec = next(c for c in res.contexts if c.scene == "bad").speeds[0]
        assert "-adapter:" in rec.stderr


def test_tolerances_override_and_validation(tmp_path):
    tol = load_tolerances({"restitution_exact": {"rtol": 1e-9}})
    assert tol["restitution_exact"]["rtol"] == 1e-9 and tol["contact_time"]["rtol"] == 1e-3
    bad = tmp_path / "bad.toml"
    for text, message in (
        ("[restitution_exakt]\nrtol = 1", "did you mean 'restitution_exact'"),
        ("[contact_time]\nrtoll = 1", "unknown key contact_time.rtoll"),
        ("[contact_time]\nrtol = -1", "must be a finite number > 0"),
        ("[run]\nspeed_error_steps = [10]", "at least two integers"),
        ("[run\n", "TOML syntax error"),
    ):
        bad.write_text(text)
        with pytest.raises(HCVInputError, match=message):
            load_tolerances(bad)
    with pytest.raises(HCVInputError, match="not found"):
        load_tolerances(tmp_path / "missing.toml")


def test_adapter_supporting_no_scene_measured_nothing():
    """Valid input (issue 26 review F6): every scene skipped with its reason, exit 1 with
    --gate (nothing measured), never a configuration error (verification/test_bench_declines.py)."""
    walls = parse_scene(
        'name = "w"\nmass = 1.0\nvelocities = [1.0]\nkind = "two-walls"\n'
        'gap = 0.1\n[potential]\nfamily = "power"\nk = 1.0\np = 1.5\n'
    )
    res = run_bench(cmd(), scenes=[walls])
    assert res.measured_nothing and res.exit_status(gate=True) == 1, res.counts()
    assert res.contexts[0].skipped.startswith("declined by the code: "), res.contexts[0].skipped


# ----------------------------------------------------------------------------
# exit statuses of the command, and the pytest plugin
# ----------------------------------------------------------------------------
def _run(args, cwd, extra_env=None, timeout=120):
    env = {**os.environ, "PYTHONPATH": str(ROOT), **(extra_env or {})}
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def test_gate_exit_statuses(tmp_path):
    (tmp_path / "s.toml").write_text(scene_text("s", [1.0]))
    fast = tmp_path / "fast.toml"
    fast.write_text("[dt_crit]\nresolution = 0.05\n[run]\nspeed_error_steps = [50, 100, 200]\n")
    strict = tmp_path / "strict.toml"
    # the limit is base + factor x textbook Verlet's error: both made strict
    strict.write_text(
        fast.read_text() + "[restitution_exact]\nrtol = 1e-9\n[allowance]\ntextbook_verlet = 1e-9\n"
    )
    base = [*HCV_BENCH, cmd(), "--scenes", str(tmp_path / "s.toml"), "--gate"]
    ok = _run([*base, "--tolerances", str(fast), "--junit", str(tmp_path / "ok.xml")], tmp_path)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "gate: pass" in ok.stdout and (tmp_path / "ok.xml").exists()
    bad = _run([*base, "--tolerances", str(strict), "--json", str(tmp_path / "bad.json")], tmp_path)
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert "FAIL" in bad.stdout and "restitution_exact" in bad.stdout
    assert json.loads((tmp_path / "bad.json").read_text())["status"] == "fail"
    nogate = _run([c for c in base if c != "--gate"] + ["--tolerances", str(strict)], tmp_path)
    assert nogate.returncode == 0
    for args, message in (
        ([*HCV_BENCH, "nosuch", "--gate"], "unknown adapter"),
        ([*base, "--tolerances", str(tmp_path / "none.toml")], "not found"),
        ([*HCV_BENCH, "--gate"], ""),
    ):
        r = _run(args, tmp_path)
        assert r.returncode == 2, r.stdout + r.stderr
        assert message in r.stderr


def test_pytest_plugin_makes_one_test_per_scene_and_metric(tmp_path):
    (tmp_path / "s.toml").write_text(scene_text("s", [1.0]))
    strict = tmp_path / "strict.toml"
    strict.write_text(
        "[dt_crit]\nresolution = 0.05\n[run]\nspeed_error_steps = [50, 100, 200]\n"
        "[restitution_exact]\nrtol = 1e-9\n[allowance]\ntextbook_verlet = 1e-9\n"
    )
    # The plugin arrives through its pytest11 entry point (pyproject), as in a user's CI.
    r = _run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-p",
            "no:cacheprovider",
            "-q",
            "-rf",
            "--contact-adapter=verification._adapter_script:ScriptAdapter",
            f"--contact-scenes={tmp_path / 's.toml'}",
            f"--contact-tolerances={strict}",
        ],
        tmp_path,
    )
    n = len(metric_names())
    assert r.returncode == 1, r.stdout + r.stderr
    # one speed: restitution_v0_spread, energy_balance (damped) and energy_drift are skipped
    assert f"1 failed, {n - 4} passed, 3 skipped" in r.stdout, r.stdout
    assert "ScriptAdapter" not in r.stderr
    assert "restitution_exact [script / s]: restitution" in r.stdout


def test_builtin_adapter_classes_are_exported_without_loading_the_codes():
    """``from reference_impl.adapters import KratosAdapter, LammpsAdapter, MujocoAdapter``
    loads neither Kratos, LAMMPS nor MuJoCo (nor their adapter modules until asked): the
    codes load at run time."""
    code = (
        "import sys\n"
        "import reference_impl.adapters as a\n"
        "early = sorted(m for m in sys.modules if m.endswith(('adapters.kratos', 'adapters.lammps', "
        "'adapters.mujoco')))\n"
        "from reference_impl.adapters import KratosAdapter, LammpsAdapter, MujocoAdapter\n"
        "assert 'KratosAdapter' in a.__all__ and 'KratosAdapter' in dir(a)\n"
        "assert 'MujocoAdapter' in a.__all__ and 'MujocoAdapter' in dir(a)\n"
        "codes = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('KratosMultiphysics', 'lammps', 'mpi4py', 'mujoco'))\n"
        "print(early, KratosAdapter.__name__, LammpsAdapter.__name__, MujocoAdapter.__name__, "
        "codes)\n"
    )
    r = _run([sys.executable, "-c", code], ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == [
        "[]", "KratosAdapter", "LammpsAdapter", "MujocoAdapter", "[]"
    ], r.stdout  # fmt: skip


def test_measure_reads_the_restitution_at_both_ends():
    """restitution at q = 0 (first sample out of contact) and at the first zero of the
    total force after the deepest overlap, interpolated linearly in the force."""
    import numpy as np

    from reference_impl.adapters.base import Trajectory
    from reference_impl.bench.measure import measure

    t = np.arange(5.0)
    q = np.array([0.0, 1.0, 2.0, 1.0, -0.5])
    v = np.array([1.0, 0.5, 0.0, -0.4, -0.6])
    pulls = measure(Trajectory(t, q, v, np.array([0.0, 2.0, 1.0, -1.0, 0.0])), 1.0)
    assert pulls["restitution"] == 0.6
    assert abs(pulls["restitution_zero_force"] - 0.2) < 1e-15  # halfway between 0 and -0.4
    never = measure(Trajectory(t, q, v, np.array([0.0, 2.0, 1.0, 0.5, 0.0])), 1.0)
    assert never["restitution_zero_force"] == never["restitution"] == 0.6  # ends coincide


def test_third_party_adapter_registers_by_entry_point(tmp_path):
    """``pip install mycode-hcv`` then ``hcv bench mycode``: the ``hcv.adapters`` group.

    A distribution's metadata (a ``*.dist-info`` with ``entry_points.txt``) on the path
    is what pip leaves; the bench in a new process finds the adapter by its name.
    """
    dist = tmp_path / "mycode_hcv-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: mycode-hcv\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[hcv.adapters]\nmycode = mycode_adapter:MyCode\n")
    (tmp_path / "mycode_adapter.py").write_text(
        "from reference_impl.adapters.reference import ReferenceAdapter\n\n\n"
        "class MyCode(ReferenceAdapter):\n    name = 'mycode'\n"
    )
    probe = (
        "from reference_impl.adapters.registry import get_adapter, registered\n"
        "print('mycode' in registered(), type(get_adapter('mycode')).__name__)\n"
    )
    env = {"PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    r = _run([sys.executable, "-c", probe], tmp_path, env)
    assert_true(
        r.returncode == 0 and r.stdout.split() == ["True", "MyCode"],
        got=r.stdout + r.stderr,
        should="True MyCode",
        claim="tool",
        call="registered() / get_adapter('mycode') with an hcv.adapters entry point",
    )
    r = _run([*HCV_BENCH, "--help"], tmp_path, env)
    assert_true(
        "mycode" in r.stdout,
        got=r.stdout[-400:],
        should="the entry point's name among the adapters in hcv bench --help",
        claim="tool",
        call="hcv bench --help",
    )
