"""Start-up (issue 20): what a new process imports, and the lazy public names.

Times are measured by ``benchmarks/bench_startup.py``, never here; these tests check the
cause of a slow start instead: which modules a command imports before it has work to do.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from verification.assertions import assert_true

# Numerical libraries whose import costs 0.3-2 s each; none may load while parsing arguments.
HEAVY = ("numba", "sympy", "scipy", "numpy", "mpmath", "pandas", "matplotlib", "rich")

_PROBE = """
import json, sys, runpy
sys.argv = ["hcv", *json.loads(sys.argv[1])]
code = 0
try:
    runpy.run_module("reference_impl.cli", run_name="__main__")
except SystemExit as exc:
    code = exc.code
heavy = json.loads({heavy!r})
print(json.dumps({{"code": code, "loaded": sorted(m for m in heavy if m in sys.modules)}}), file=sys.stderr)
"""


def _probe(*args: str) -> tuple[int, list[str]]:
    """Run ``hcv ARGS`` in a new process; its exit status and the heavy modules it loaded."""
    script = _PROBE.format(heavy=json.dumps(HEAVY))
    r = subprocess.run(
        [sys.executable, "-c", script, json.dumps(list(args))],
        capture_output=True,
        text=True,
        timeout=120,
    )
    last = r.stderr.strip().splitlines()[-1]
    out = json.loads(last)
    return out["code"], out["loaded"]


@pytest.mark.parametrize(
    "args, status",
    [
        (("--help",), 0),
        (("--version",), 0),
        (("scenes",), 0),
        (("solve", "--help"), 0),
        # `hcv bench --help` is left out: its page lists every adapter's keys and values
        # (issue 17), read from the adapter classes (see the test below); parsing and
        # refusing bench arguments stay light:
        (("bench", "reference", "--no-such-option"), 2),
        (("sweep", "--help"), 0),
        (("report", "--help"), 0),
        (("no-such-command",), 2),
        (("solve",), 2),
        (("dt-crit", "hertz", "--no-such-option"), 2),
    ],
)
def test_parsing_and_refusing_import_nothing_numerical(args, status):
    code, loaded = _probe(*args)
    assert_true(
        code == status and not loaded,
        got=f"exit {code}, loaded {loaded}",
        should=f"exit {status}, none of {HEAVY} loaded",
        claim="tool",
        call=f"hcv {' '.join(args)}",
    )


def test_version_is_the_package_version():
    from reference_impl._version import version

    r = subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", "--version"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert_true(
        r.returncode == 0 and r.stdout.strip() == f"hcv {version()}",
        got=f"exit {r.returncode}, {r.stdout!r}",
        should=f"exit 0, 'hcv {version()}'",
        claim="tool",
        call="hcv --version",
    )


def test_import_reference_impl_loads_no_numerical_library():
    script = (
        "import json, sys, reference_impl; "
        f"print(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
    )
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    loaded = json.loads(r.stdout)
    assert_true(
        not loaded,
        got=f"loaded {loaded}",
        should="none loaded",
        claim="tool",
        call="import reference_impl",
    )


def test_every_public_name_resolves_and_is_listed():
    import reference_impl

    unresolved = [n for n in reference_impl.__all__ if getattr(reference_impl, n, None) is None]
    unlisted = sorted(set(reference_impl.__all__) - set(dir(reference_impl)))
    assert_true(
        not unresolved and not unlisted,
        got=f"unresolved {unresolved}, not in dir() {unlisted}",
        should="every name of __all__ resolved and listed",
        claim="tool",
        call="reference_impl.__all__",
    )
    from reference_impl import solve_impact
    from reference_impl.exact.solve import solve_impact as defined

    assert_true(
        solve_impact is defined,
        got=repr(solve_impact),
        should=repr(defined),
        claim="tool",
        call="from reference_impl import solve_impact",
    )
    with pytest.raises(AttributeError):
        reference_impl.no_such_name  # noqa: B018


def test_scenes_package_names_resolve():
    import reference_impl.scenes as scenes
    from reference_impl.scenes._scene import load_scene

    unresolved = [n for n in scenes.__all__ if getattr(scenes, n, None) is None]
    assert_true(
        not unresolved and scenes.load_scene is load_scene,
        got=f"unresolved {unresolved}",
        should="every name of reference_impl.scenes.__all__ resolved",
        claim="tool",
        call="reference_impl.scenes.__all__",
    )


def test_readme_startup_block_is_the_committed_benchmark():
    """The README's start-up figures are rendered from reports/bench/startup.json, never typed."""
    from pathlib import Path

    from reference_impl.report.readme_table import (
        STARTUP_END,
        STARTUP_START,
        readme_block,
        startup_table,
    )

    root = Path(__file__).resolve().parent.parent
    bench_json = root / "reports" / "bench" / "startup.json"
    assert_true(
        bench_json.is_file(),
        got=f"no {bench_json.relative_to(root)}",
        should="the benchmark JSON behind the README's start-up block (nox -s bench)",
        claim="report",
        call="readme_table",
    )
    want = startup_table(json.loads(bench_json.read_text()))
    got = readme_block((root / "README.md").read_text(), STARTUP_START, STARTUP_END)
    assert_true(
        got == want,
        got="README start-up block differs from reports/bench/startup.json",
        should="identical (run python -m reference_impl.report.readme_table)",
        claim="report",
        call="readme_table",
    )


def test_calibrate_parser_names_the_restitution_ends_of_the_theory():
    """cli.calibrate keeps its own copy of the end names (parsing imports nothing numerical)."""
    from reference_impl.cli.calibrate import _ENDS
    from reference_impl.theory.damping import RESTITUTION_ENDS

    assert _ENDS == RESTITUTION_ENDS, f"got {_ENDS}, should be {RESTITUTION_ENDS}"


def test_bench_help_lists_each_adapters_keys():
    """The one help page that reads the adapter classes: each adapter's keys and values."""
    r = subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", "bench", "--help"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    for needle in ("kratos: law = hertz | linear", "lammps: damping =", "mujoco: solref = "):
        assert_true(
            r.returncode == 0 and needle in r.stdout,
            got=r.stdout[-600:],
            should=f"a line {needle!r}",
            claim="tool",
            call="hcv bench --help",
        )


_SOLVE_PROBE = """
import json, sys, runpy
names = json.loads(sys.argv[1])
sys.argv = ["hcv", "solve", "hertz-damped"]
try:
    runpy.run_module("reference_impl.cli", run_name="__main__")
except SystemExit as exc:
    assert not exc.code, exc.code
print(json.dumps(sorted(m for m in names if m in sys.modules)), file=sys.stderr)
"""


def test_a_float_solve_loads_no_truth_or_optimiser_library():
    """`hcv solve hertz-damped`, second run on one cache: numba and numpy, and nothing that
    only the mpmath truth (mpmath), the mixed-geometry refinement (scipy.optimize), the
    Gauss-Jacobi rules' first computation (scipy.special) need. (The bench's entry-point
    scan cannot be seen this way: numba imports importlib.metadata itself.)"""
    # and nothing of the report's or the sweep's libraries (issue 38, goal 7: numba and
    # numpy are most of its second of CPU; these would add 0.3-2 s each)
    not_needed = [
        "mpmath",
        "scipy.optimize",
        "scipy.special",
        "scipy.integrate",
        "sympy",
        "pandas",
        "matplotlib",
        "dask",
    ]
    # The suite's own cache (HCV_CACHE_DIR or the user's), which the other tests fill: the
    # first run compiles and stores only what no test has yet (a fresh cache of its own
    # made this test compile every kernel of the solve again, 35-60 s), the second is warm.
    loaded = None
    for _ in range(2):  # the first run computes and stores the rules and compiles
        r = subprocess.run(
            [sys.executable, "-c", _SOLVE_PROBE, json.dumps(not_needed)],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert r.returncode == 0, r.stderr[-2000:]
        loaded = json.loads(r.stderr.strip().splitlines()[-1])
    assert_true(
        loaded == [],
        got=f"loaded {loaded}",
        should="none of them loaded",
        claim="tool",
        call="hcv solve hertz-damped (warm cache)",
    )


def test_quick_report_help_states_the_benchmarked_time():
    """`hcv report`'s help states the times of reports/bench/startup.json (--quick),
    rounded to the second, not typed guesses: re-run the benchmark, then update the help.
    It states no other time: a figure of the last full run (reports/results.json) goes
    stale with the next `hcv report`, which rewrites that file (issue 41)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    bench = json.loads((root / "reports" / "bench" / "startup.json").read_text())
    (row,) = [c for c in bench["cases"] if c["name"] == "hcv report --quick"]
    r = subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", "report", "--help"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    text = " ".join(r.stdout.split())
    figures = (row["warm_wall_s"], row["warm_cpu_s"], row["cold_wall_s"])
    want = (
        f"{figures[0]:.0f} s wall and {figures[1]:.0f} s CPU once compiled, "
        f"{figures[2]:.0f} s wall the first time"
    )
    stated = re.findall(r"(\d+(?:\.\d+)?) ?(?:s|min)\b", text)
    other = [x for x in stated if x not in {f"{f:.0f}" for f in figures}]
    assert_true(
        want in text and re.search(r"--quick", text) is not None and not other,
        got=f"{text[text.find('--quick') :][:200]!r}; times stated: {stated}",
        should=f"the benchmark's figures {want!r} and no other time",
        claim="tool",
        call="hcv report --help",
    )


_COMMANDS_PROBE = """
import json, sys, runpy
sys.argv = ["hcv", *json.loads(sys.argv[1])]
try:
    runpy.run_module("reference_impl.cli", run_name="__main__")
except SystemExit:
    pass
from reference_impl.cli import COMMANDS
print(json.dumps(sorted(m for _, m, _ in COMMANDS if m in sys.modules)), file=sys.stderr)
"""


@pytest.mark.parametrize(
    "args, modules",
    [
        (("--help",), []),
        (("no-such-command",), []),
        (("solve", "--help"), ["reference_impl.cli.solve"]),
        (("--help", "sweep"), ["reference_impl.cli.sweep"]),
        (("calibrate", "--no-such-option"), ["reference_impl.cli.calibrate"]),
    ],
)
def test_only_the_chosen_commands_module_is_imported(args, modules):
    """`hcv ARGS` imports the module of the command it names and no other command's."""
    r = subprocess.run(
        [sys.executable, "-c", _COMMANDS_PROBE, json.dumps(list(args))],
        capture_output=True,
        text=True,
        timeout=120,
    )
    loaded = json.loads(r.stderr.strip().splitlines()[-1])
    assert_true(
        loaded == modules,
        got=f"imported {loaded}",
        should=f"imported {modules}",
        claim="tool",
        call=f"hcv {' '.join(args)}",
    )


def test_the_command_table_gives_each_commands_own_help():
    """`hcv --help` reads the help of the commands from `cli.COMMANDS` (no module imported):
    the same page as when every command module builds its own sub-parser."""
    from reference_impl import cli

    listed = cli._parser(()).format_help()
    built = cli._parser().format_help()
    assert_true(
        listed == built,
        got=listed,
        should=built,
        claim="tool",
        call="hcv --help (cli.COMMANDS against each command's add_parser)",
    )


_FREEZE_PROBE = """
import gc, sys
from reference_impl.cli import main
sys.argv = ["hcv", *sys.argv[1:]]
code = main()
print("FROZEN", gc.get_freeze_count(), code, file=sys.stderr)
"""


@pytest.mark.parametrize(
    "args, frozen",
    [(("scenes",), True), (("solve", "--rtol", "x", "hertz"), True),
     (("report", "--from", "no-such.json"), False)],
)  # fmt: skip
def test_a_command_process_freezes_its_heap_before_it_exits(args, frozen, tmp_path):
    """``hcv solve``, ``dt-crit`` and ``scenes`` freeze their heap as they return, a
    refusal included (the interpreter's final collections then skip numba's registries,
    `cli._FROZEN_AT_EXIT`); a command that starts processes (``report``) does not. On main
    no command froze anything (the count stayed 0)."""
    r = subprocess.run([sys.executable, "-c", _FREEZE_PROBE, *args], capture_output=True,
                       text=True, timeout=120, cwd=tmp_path)  # fmt: skip
    line = next((s for s in r.stderr.splitlines() if s.startswith("FROZEN")), None)
    ok = line is not None and (int(line.split()[1]) > 0) == frozen
    assert_true(ok, got=f"{line!r} (stderr {r.stderr[-200:]!r})",
                should=f"frozen {frozen}", claim="startup",
                call=f"hcv {' '.join(args)}")  # fmt: skip


def test_main_with_argv_leaves_the_callers_heap_alone(capsys):
    """`main(argv)` (tests, scripts: the process goes on) never freezes its caller's heap."""
    import gc

    from reference_impl.cli import main

    before = gc.get_freeze_count()
    code = main(["scenes"])
    capsys.readouterr()
    assert_true(code == 0 and gc.get_freeze_count() == before,
                got=f"exit {code}, freeze count {before} -> {gc.get_freeze_count()}",
                should="exit 0, the count unchanged", claim="startup",
                call="main(['scenes'])")  # fmt: skip
