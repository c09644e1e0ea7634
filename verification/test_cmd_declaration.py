"""A ``cmd:`` program declares its time-stepping scheme (issue 40 leftovers, a): contract
item 12 for any language, ``cmd[time_scheme=implicit-euler,claimed_order=1]:COMMAND``,
checked before anything runs.

The program is verification/_implicit_script.py, backward Euler on a linear contact with
the universal law (standard library only; persistent mode, so a bench is ~1 s). On main
the bracket keys were options of the code, sent in every request, which the script
answers with ``{"error": "unknown option time_scheme"}``: every run failed, so
`test_declared_implicit_program_passes_implementation` failed there; the hostile
declarations were sent to the program instead of being refused with exit status 2.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from reference_impl.adapters.base import Scheme, scheme_of
from reference_impl.adapters.registry import get_adapter
from reference_impl.bench.scorecard.runner import run_bench
from reference_impl.errors import HCVInputError
from reference_impl.scenes import scene_from_dict
from verification._hcv_run import hcv

from .assertions import assert_true

_SCRIPT = Path(__file__).with_name("_implicit_script.py")
_PROGRAM = f"{sys.executable} {_SCRIPT}"
_SERVER = f"{_PROGRAM} --persistent"
# One speed, a linear contact, e = 0.5 (the scene of test_bench_schemes.py): a bench of
# the persistent script on it is ~1 s.
_SCENE = scene_from_dict(
    {
        "name": "hooke-one",
        "mass": 1.0,
        "velocities": [1.0],
        "kind": "impact",
        "potential": {"family": "power", "k": 1.0e4, "p": 1.0},
        "damping": {"law": "universal", "restitution": 0.5},
    }
)
_IMPLICIT = "persistent=true,time_scheme=implicit-euler,claimed_order=1"


def _failed(res) -> dict:
    """metric -> explanation of every implementation metric that neither passed nor is n/a."""
    return {
        m.metric: m.explanation
        for m in res.metrics
        if m.verdict == "implementation" and m.status not in ("pass", "n/a")
    }


def _bench(args: str, steps: int = 200):
    tol = {"run": {"steps_per_contact": steps}}
    return run_bench(f"cmd[{args}]:{_SERVER}", scenes=[_SCENE], tolerances=tol)


@pytest.mark.parametrize("steps", [10, 25, 200, 1000])
def test_declared_implicit_program_passes_implementation(steps):
    """A correct implicit-Euler program that declares its scheme passes implementation at
    every step (10 to 1000 steps per contact), judged by implicit Euler's own error."""
    res = _bench(_IMPLICIT, steps)
    assert_true(not _failed(res), got=_failed(res), should="every implementation metric pass or n/a",
                claim="issue 40 §1", call=f"cmd[{_IMPLICIT}] at {steps} steps per contact")  # fmt: skip
    assert_true(res.variants[0]["time_scheme"] == "implicit-euler", got=res.variants[0],
                should="the declared scheme in the run's record", claim="issue 40 §1",
                call="BenchResult.variants")  # fmt: skip


@pytest.mark.parametrize("steps", [25, 200])
def test_declared_program_damped_10pc_too_much_fails_implementation(steps):
    """The same program with its dashpot 10 % too strong fails implementation, on the
    force and on the extrapolated answer (an error the step does not shrink)."""
    bad = _failed(_bench(_IMPLICIT + ",damping_scale=1.1", steps))
    for metric in ("force_law", "extrapolated"):
        assert_true(metric in bad, got=sorted(bad), should=f"{metric} among the failures",
                    claim="issue 40 §1", call=f"10 % damping error at {steps} steps per contact")  # fmt: skip


def test_declared_program_reporting_twice_its_force_fails_implementation():
    """The same program reporting twice the force it integrates (a units bug) fails
    implementation on ``force_law``, naming the force."""
    tol = {"run": {"speed_error_steps": [50, 100, 200]}}  # the study is not what fails here
    res = run_bench(f"cmd[{_IMPLICIT},force_scale=2]:{_SERVER}", scenes=[_SCENE], tolerances=tol)
    m = next(m for m in res.metrics if m.metric == "force_law")
    assert_true(m.status == "fail" and m.explanation.startswith("force "),
                got=(m.status, m.explanation), should="fail, naming the force",
                claim="issue 40 §1", call="cmd[force_scale=2] force_law")  # fmt: skip


def test_undeclared_program_is_judged_as_velocity_verlet():
    """Without the declaration the program is judged as today: against velocity Verlet's
    error, which a correct first-order code exceeds at 200 steps per contact."""
    adapter = get_adapter(f"cmd:{_PROGRAM}")
    assert_true(scheme_of(adapter) == Scheme("velocity-verlet", 2.0), got=scheme_of(adapter),
                should="velocity Verlet, order 2", claim="issue 40 §1", call="scheme_of(cmd:)")  # fmt: skip
    bad = _failed(_bench("persistent=true"))
    assert_true("restitution_exact" in bad, got=sorted(bad),
                should="restitution_exact failed (held to 3 x Verlet's error)",
                claim="issue 40 §1", call="cmd[persistent=true] undeclared")  # fmt: skip


@pytest.mark.parametrize(
    "args, scheme",
    [
        ("time_scheme=implicit-euler", Scheme("implicit-euler", 1.0)),
        ("time_scheme=rk4,claimed_order=3.5", Scheme("rk4", 3.5)),
        ("time_scheme=variable-step,scheme_rtol=1e-8", Scheme("variable-step", None, 1e-8)),
    ],
)
def test_declaration_is_read_in_one_shot_mode(args, scheme):
    """The declaration is the adapter's, in one-shot mode as in persistent mode, and is
    no option of the code (never sent in a request)."""
    adapter = get_adapter(f"cmd[{args}]:{_PROGRAM}")
    assert_true(scheme_of(adapter) == scheme and not adapter.options, got=(scheme_of(adapter), adapter.options),
                should=(scheme, {}), claim="issue 40 §1", call=f"cmd[{args}]")  # fmt: skip


_HUGE = "x" * 3000


@pytest.mark.parametrize(
    "args, needle",
    [
        ("time_scheme=leapfrog2", "'leapfrog2'"),
        ("time_scheme=implicit-euler,claimed_order=nan", "nan"),
        ("time_scheme=implicit-euler,claimed_order=-1", "-1"),
        ("time_scheme=implicit-euler,claimed_order=0", "got 0"),
        ("time_scheme=implicit-euler,claimed_order=inf", "inf"),
        ("time_scheme=implicit-euler,claimed_order=true", "True"),
        ("time_scheme=rk4,claimed_order=fourth", "'fourth'"),
        ("time_scheme=variable-step", "scheme_rtol"),
        ("time_scheme=variable-step,scheme_rtol=2", "got 2"),
        ("time_scheme=variable-step,scheme_rtol=1e-8,claimed_order=4", "claimed_order=4"),
        ("time_scheme=implicit-euler,scheme_rtol=1e-8", "scheme_rtol=1e-08"),
        ("claimed_order=1", "need time_scheme"),
        (f"time_scheme={_HUGE}", "'xxxxxxxx"),
        ("time_schem=rk4", "'time_schem'"),
    ],
)
def test_bad_declarations_are_refused_in_one_line(args, needle):
    """Unknown scheme, an order NaN / negative / zero / infinite / not a number, a
    tolerance missing or given to a fixed-step scheme, a huge string: one line naming the
    value (cut short), raised when the adapter is made, before any run."""
    with pytest.raises(HCVInputError) as exc:
        get_adapter(f"cmd[{args}]:{_PROGRAM}")
    text = str(exc.value)
    assert_true(needle in text and "\n" not in text and len(text) < 300, got=text[:400],
                should=f"one short line naming {needle!r}", claim="issue 40 §1",
                call=f"get_adapter(cmd[{args[:40]}])")  # fmt: skip


def test_cli_refuses_a_bad_declaration_with_exit_2(tmp_path):
    """``hcv bench`` with a bad declaration: one line on stderr naming it, exit status 2,
    nothing run (no JSON report written)."""
    out = tmp_path / "r.json"
    spec = f"cmd[time_scheme=implicit-euler,claimed_order=nan]:{_PROGRAM}"
    run = hcv(["bench", spec, "--scenes", "hooke-damped", "--json", str(out)], cwd=tmp_path)
    err = run.stderr.strip()
    assert_true(run.returncode == 2 and len(err.splitlines()) == 1 and "nan" in err and not out.exists(),
                got=(run.returncode, err, out.exists()), should="exit 2, one line naming nan, no file",
                claim="issue 40 §1", call="hcv bench cmd[claimed_order=nan]")  # fmt: skip


def test_a_huge_label_is_cut_in_the_error_line():
    """The label (``label=`` of 3000 characters) is named, not echoed whole."""
    with pytest.raises(HCVInputError) as exc:
        get_adapter(f"cmd[label={_HUGE},time_scheme=leapfrog2]:{_PROGRAM}")
    text = str(exc.value)
    assert_true("'leapfrog2'" in text and len(text) < 300, got=text[:400],
                should="one short line naming 'leapfrog2'", claim="issue 40 §1",
                call="get_adapter(cmd[label=3000 x, time_scheme=leapfrog2])")  # fmt: skip
