"""`benchmarks._numba_standin`: the numba stand-in of `benchmarks/bench_startup.py`'s row
"numba replaced by a stand-in (measured only)", written at run time, never in the tree.

The repository holds no package named ``numba`` (a structure tool that resolves imports by
path read every ``import numba`` of the package as an import of the former
``benchmarks/_no_numba/numba``: 31 arrows that ran back up); a new process started with
the stand-in first on its path imports the stand-in, not numba; its directory is gone after
the run; and the bench refuses to time a row whose ``import numba`` finds numba itself.
No timing here (the row's time is the bench's).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import _numba_standin, bench_startup
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
# What a new process reports of the numba it imported, and of what njit and overload return.
_PROBE = (
    "import numba, numba.extending\n"
    "f = lambda x: x\n"
    "print(numba.__version__, numba.njit(f) is f, numba.njit(cache=True)(f) is f,\n"
    "      numba.extending.overload(len)(f) is f, numba.get_num_threads())\n"
)


def test_the_tree_holds_no_package_named_numba():
    """Fails on 9d4f9ac, where ``benchmarks/_no_numba/numba`` was that package."""
    found = [
        str(p.relative_to(ROOT))
        for top in ("benchmarks", "reference_impl", "verification", "docs", "reports")
        for p in (ROOT / top).rglob("numba*")
        if p.name == "numba.py" or (p.name == "numba" and p.is_dir())
    ]
    assert_true(
        not found,
        got=f"folders named numba: {found}",
        should="none (the stand-in is written into a temporary directory at run time)",
        claim="bench",
        call="benchmarks tree",
    )


def test_a_process_with_the_standin_first_imports_it_and_it_is_removed_after():
    with _numba_standin.standin() as directory:
        env = {
            **os.environ,
            "PYTHONPATH": _numba_standin.pythonpath(directory, str(ROOT)),
        }
        r = subprocess.run(
            [sys.executable, "-c", _PROBE], env=env, cwd=ROOT, capture_output=True, text=True
        )
    got = r.stdout.split()
    want = [_numba_standin.VERSION, "True", "True", "True", "1"]
    assert_true(
        r.returncode == 0 and got == want,
        got=f"exit {r.returncode}, {got} {r.stderr.strip()[-300:]}",
        should=f"exit 0, {want} (the stand-in's version; njit and overload the function itself)",
        claim="bench",
        call="standin()",
    )
    assert_true(
        not directory.exists(),
        got=f"{directory} still there",
        should="removed on leaving standin()",
        claim="bench",
        call="standin()",
    )


def test_main_runs_a_command_with_the_standin_and_refuses_no_command():
    probe = [sys.executable, "-c", "import numba; print(numba.__version__)"]
    r = subprocess.run(
        [sys.executable, "-m", "benchmarks._numba_standin", *probe],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    empty = subprocess.run(
        [sys.executable, "-m", "benchmarks._numba_standin"], cwd=ROOT, capture_output=True
    )
    assert_true(
        (r.returncode, r.stdout.strip(), empty.returncode) == (0, _numba_standin.VERSION, 2),
        got=f"exit {r.returncode}, {r.stdout.strip()!r}; no command: exit {empty.returncode}",
        should=f"exit 0, {_numba_standin.VERSION!r}; no command: exit 2",
        claim="bench",
        call="python -m benchmarks._numba_standin",
    )


def test_bench_refuses_a_row_whose_import_finds_numba_itself(monkeypatch, tmp_path):
    """With nothing written, the probe's ``import numba`` finds numba itself: the row would
    time compiled code under the stand-in's name, so the bench raises before any row."""
    monkeypatch.setattr(_numba_standin, "SOURCES", {})
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    with pytest.raises(RuntimeError, match="should be '0\\+stand-in'"):
        bench_startup._standin_path(tmp_path / "standin", env)
    monkeypatch.undo()
    path = bench_startup._standin_path(tmp_path / "written", env)
    assert_true(
        path.split(os.pathsep) == [str(tmp_path / "written"), str(ROOT)],
        got=path,
        should="the stand-in's directory, then the repository",
        claim="bench",
        call="bench_startup._standin_path",
    )
