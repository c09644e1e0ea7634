"""Hostile input to ``hcv bench`` (issues 12 and 22): usage and configuration errors.

Bounds of scenes and tolerances, output paths, adapter specs and programs: each is
refused before any work, with one line on stderr and exit status 2 (`HCVInputError`),
never reported as a failure of the code. The expectation is the documented behaviour
(docs/adapter-protocol.md, the exit statuses of ``hcv bench``).
"""

from __future__ import annotations

import os
import re

import pytest

from reference_impl.adapters import get_adapter
from reference_impl.bench import run_bench
from reference_impl.cli import main
from reference_impl.errors import HCVInputError


# ----------------------------------------------------------------------------
# issue 12: bounds checked before any work
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "field, text, message",
    [
        ("velocities", "velocities = [" + ", ".join(["1.0"] * 40) + "]", "at most 32 per scene"),
        (
            "zeta",
            "velocities = [1.0]\n[damping]\nlaw = 'universal'\nzeta = 1.5",
            "needs damping zeta < 1",
        ),
    ],
)
def test_bench_bounds_are_checked_before_work(tmp_path, field, text, message):
    path = tmp_path / "s.toml"
    path.write_text(
        f"name = 's'\nmass = 1.0\n{text}\n".replace(
            "[damping]", "[potential]\nfamily = 'power'\nk = 1.0\np = 1.5\n[damping]"
        )
        + (
            ""
            if "[potential]" in text or "damping" in text
            else "[potential]\nfamily = 'power'\nk = 1.0\np = 1.5\n"
        )
    )
    with pytest.raises(HCVInputError, match=message):
        run_bench("reference", scenes=[str(path)])


@pytest.mark.parametrize(
    "override, message",
    [
        ({"run": {"sustained_steps": 10**12}}, "must be <= 1e+07"),
        ({"run": {"steps_per_contact": 10**9}}, "must be <= 100000"),
        ({"run": {"speed_error_steps": [2, 10**9]}}, "each <= 100000"),
        ({"run": {"speed_error_steps": list(range(2, 40))}}, "at most 12 values"),
        ({"run": {"timeout": 1e300}}, "must be <= 86400"),
        ({"dt_crit": {"resolution": 1e-12}}, "must be >= 0.0001"),
    ],
)
def test_tolerance_sizes_are_bounded(override, message):
    from reference_impl.bench import load_tolerances

    with pytest.raises(HCVInputError, match=re.escape(message)):
        load_tolerances(override)


def test_too_many_scenes_is_refused():
    with pytest.raises(HCVInputError, match="at most 64"):
        run_bench("reference", scenes=["hertz"] * 65)


# ----------------------------------------------------------------------------
# issue 12, section 4: one line and exit 2
# ----------------------------------------------------------------------------
def _one_line_exit_2(capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], err


@pytest.mark.parametrize("option", ["--json", "--junit", "--markdown", "--plot"])
def test_output_paths_are_checked_before_work(tmp_path, capsys, option):
    _one_line_exit_2(
        capsys, ["bench", "reference", option, str(tmp_path / "no" / "f")], "does not exist"
    )
    _one_line_exit_2(capsys, ["bench", "reference", option, str(tmp_path)], "is a directory")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into any directory")
def test_unwritable_output_directory(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    _one_line_exit_2(capsys, ["bench", "reference", "--json", str(ro / "b.json")], "not writable")


def test_report_out_checked_before_work(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    _one_line_exit_2(capsys, ["report", "--out", str(tmp_path / "file")], "not a directory")
    _one_line_exit_2(capsys, ["report", "--out", str(tmp_path / "a" / "b")], "does not exist")


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["bench", 'cmd:python "unbalanced'], "check its quotes"),
        (["bench", "subprocess"], "needs the argument(s) command; use cmd:COMMAND"),
        (["bench", "reference", "--scenes", ""], "names no scene"),
        (["bench", "reference", "--scenes", " , "], "names no scene"),
        (["bench", "cmd[timeout=1,timeout=2]:x"], "repeats"),
    ],
)
def test_bench_usage_errors_are_one_line(capsys, argv, needle):
    _one_line_exit_2(capsys, argv, needle)


# ----------------------------------------------------------------------------
# issue 22: adapter specs and programs refused before any work
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "spec, needle",
    [
        ("cmd[sustained=maybe]:yes", "sustained must be true or false"),
        ("cmd[sustained=1]:yes", "sustained must be true or false"),
        ("cmd[label=3]:yes", "label must be text"),
        ("cmd:/nonexistent/prog", "does not exist"),
        ("cmd:./no-such-program --flag", "does not exist"),
        ("cmd:no-such-program-hcv-22", "not found on PATH"),
    ],
)
def test_adapter_configuration_errors_are_exit_2_not_a_code_failure(capsys, spec, needle):
    with pytest.raises(HCVInputError, match=re.escape(needle)):
        get_adapter(spec)
    _one_line_exit_2(capsys, ["bench", spec, "--scenes", "hertz"], needle)


def test_a_program_that_is_not_executable_is_a_configuration_error(tmp_path, capsys):
    prog = tmp_path / "code.sh"
    prog.write_text("#!/bin/sh\n")
    prog.chmod(0o644)
    _one_line_exit_2(capsys, ["bench", f"cmd:{prog}", "--scenes", "hertz"], "not executable")


def test_scenes_given_twice_are_all_run(capsys):
    """``--scenes a --scenes b`` names both (argparse's default kept only b)."""
    from reference_impl import cli
    from reference_impl.cli.bench import _scene_args

    args = cli._parser().parse_args(
        ["bench", "reference", "--scenes", "hertz", "--scenes", "hooke-damped,hertz-damped"]
    )
    got = _scene_args(args.scenes)
    assert got == ["hertz", "hooke-damped", "hertz-damped"], (
        f"got {got}, should be all three scenes [issue 22, --scenes twice]"
    )


def test_a_missing_program_is_refused_by_report_and_sweep_before_any_work(tmp_path, capsys):
    """``cmd:/nonexistent/prog`` through ``hcv report --adapter`` and a ``bench:`` sweep."""
    out = tmp_path / "rep"
    _one_line_exit_2(
        capsys,
        ["report", "--quick", "--out", str(out), "--adapter", "cmd:/nonexistent/prog"],
        "does not exist",
    )
    spec = tmp_path / "spec.toml"
    spec.write_text(
        'task = "bench:cmd:/nonexistent/prog"\n[scene]\nmass = 1.0\nvelocities = [1.0]\n'
        '[scene.potential]\nfamily = "power"\nk = 1.0\np = 1.5\n[sweep]\nmass = [1.0, 2.0]\n'
    )
    pytest.importorskip("distributed")
    _one_line_exit_2(capsys, ["sweep", str(spec), "--out", str(tmp_path / "sw")], "does not exist")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"], "got files written"


# ----------------------------------------------------------------------------
# issue 26: `hcv bench --gate ADAPTER` (the order before --gate took a value)
# ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv, adapter, gate",
    [
        (["--gate", "reference"], "reference", "both"),
        (["--gate", "cmd:./code", "--scenes", "hertz"], "cmd:./code", "both"),
        (["--scenes", "hertz", "--gate", "reference"], "reference", "both"),
        (["--gate", "delivery", "reference"], "reference", "delivery"),
        (["reference", "--gate"], "reference", "both"),
        (["reference", "--gate", "implementation"], "reference", "implementation"),
    ],
)
def test_gate_before_the_adapter_parses(argv, adapter, gate):
    from reference_impl import cli
    from reference_impl.cli.bench import _adapter

    args = cli._parser().parse_args(["bench", *argv])
    got = (_adapter(args), args.gate)
    assert got == (adapter, gate), (
        f"got {got}, should be {(adapter, gate)} [issue 26, hcv bench {' '.join(argv)}]"
    )


def test_gate_before_the_adapter_runs_the_gate(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(
        "name = 's'\nmass = 0.01\nvelocities = [0.5]\n"
        "[potential]\nfamily = 'power'\nk = 2e5\np = 1.0\n"
    )
    code = main(["bench", "--gate", "reference", "--scenes", str(scene)])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert code == 0 and last.startswith("gate: pass"), (
        f"got exit {code}, last line {last!r}, should be 0 and 'gate: pass ...' "
        "[issue 26, hcv bench --gate reference]"
    )


@pytest.mark.parametrize(
    "argv, needle",
    [
        # after the adapter (issue 26 review F12: it said "write --gate KIND after the
        # adapter", where it was) and before it: the value and the kinds, either order
        (
            ["bench", "reference", "--gate", "hertz"],
            "'hertz' is not one of both|implementation|delivery",
        ),
        (
            ["bench", "--gate", "hertz", "reference"],
            "'hertz' is not one of both|implementation|delivery",
        ),
        (["bench", "--gate"], "hcv bench needs an ADAPTER"),
        (["bench"], "hcv bench needs an ADAPTER"),
    ],
)
def test_a_gate_value_that_is_no_verdict_is_one_line(capsys, argv, needle):
    _one_line_exit_2(capsys, argv, needle)


def test_the_gate_kinds_of_the_parser_are_the_verdicts():
    from reference_impl.bench.scorecard._records import GATES
    from reference_impl.cli.bench import _GATE_KINDS

    assert set(_GATE_KINDS) == set(GATES), (
        f"got {_GATE_KINDS}, should be {GATES} [issue 26, hcv bench --gate KIND]"
    )
