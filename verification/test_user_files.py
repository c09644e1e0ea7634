"""Nothing of the user's is lost (issue 22, "The user's files").

``hcv report --out DIR`` writes only the files it owns (its manifest), refuses a
directory holding other files unless ``--force``, keeps the directory's mode,
follows a symlink, and leaves no temporary directory behind on SIGTERM.
``hcv sweep --out DIR`` never overwrites a user's spec.toml / summary.md /
results.parquet and never lets two sweeps write one DIR. ``hcv bench`` refuses
an output file that is one of its inputs. No test here starts a Dask cluster:
every refusal happens before one would start. The expectations are the
documented behaviour (README "Exit statuses", the module docstrings), never a
value read back from the code under test.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import reference_impl.campaign as report
from reference_impl.campaign import _environment, build_report
from reference_impl.cli import main
from reference_impl.errors import HCVInputError
from reference_impl.report._files import MANIFEST
from verification._sweeps import needs_dask

ROOT = Path(__file__).resolve().parents[1]


def _one_line_exit_2(capsys, argv, needle: str) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and needle in lines[0] and "Traceback" not in err, (
        f"got exit {code}, stderr {err!r}, should be 2 with one line naming {needle!r} "
        f"[issue 22, hcv {' '.join(argv[:2])}]"
    )
    return lines[0]


def _snapshot(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


# ----------------------------------------------------------------------------
# hcv report --out DIR
# ----------------------------------------------------------------------------
def _fake_build(out, quick, progress, adapters, env, workers=0, carried=None, repro=None):
    """Stand-in for the measurements: the report's files, two figures."""
    (out / "figures").mkdir()
    for name in ("fig1.png", "dt_crit_map.png"):
        (out / "figures" / name).write_bytes(b"new " + name.encode())
    results = {"claims": [], "environment": env, "mode": "quick"}
    for name in ("results.json", "index.md", "index.html"):
        (out / name).write_text(json.dumps(results))
    return results


@pytest.fixture
def fake(monkeypatch):
    monkeypatch.setattr(report, "_build", _fake_build)
    monkeypatch.setattr(
        _environment, "environment", lambda seeds: {"git_commit": "x", "git_dirty": False}
    )


def _users_dir(d: Path) -> dict[str, bytes]:
    """A directory of the user's: their own index.html, figures/ and notes."""
    (d / "figures").mkdir(parents=True)
    (d / "figures" / "mine.png").write_bytes(b"user figure")
    (d / "index.html").write_text("my homepage")
    (d / "results.json").write_text('{"mine": true}')
    (d / "notes.txt").write_text("notes")
    return _snapshot(d)


def test_report_refuses_a_directory_of_other_files_and_changes_nothing(tmp_path, fake, capsys):
    out = tmp_path / "mine"
    before = _users_dir(out)
    _one_line_exit_2(capsys, ["report", "--quick", "--out", str(out)], "--force")
    assert _snapshot(out) == before, "got the user's directory changed, should be untouched"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"], "temporary directory left"


def test_report_with_force_replaces_only_its_own_names(tmp_path, fake):
    out = tmp_path / "mine"
    _users_dir(out)
    build_report(out, quick=True, force=True, readme=None)
    snap = _snapshot(out)
    assert snap["figures/mine.png"] == b"user figure" and snap["notes.txt"] == b"notes", (
        f"got {sorted(snap)}, should keep figures/mine.png and notes.txt [issue 22, --force]"
    )
    assert snap["figures/fig1.png"] == b"new fig1.png"
    listed = set(json.loads((out / MANIFEST).read_text())["files"])
    assert listed == {
        "index.html",
        "index.md",
        "results.json",
        "figures/fig1.png",
        "figures/dt_crit_map.png",
    }, f"got manifest {sorted(listed)}, should list exactly the report's files"


def test_rerun_deletes_only_stale_report_files_and_keeps_the_mode(tmp_path, fake, monkeypatch):
    out = tmp_path / "rep"
    out.mkdir(mode=0o700)
    os.chmod(out, 0o700)  # whatever the umask
    build_report(out, quick=True, readme=None)
    (out / "bench").mkdir()
    (out / "bench" / "exact.json").write_text("{}")  # another tool's file (nox -s bench)

    def one_figure(tmp, *a, **k):
        res = _fake_build(tmp, *a, **k)
        (tmp / "figures" / "dt_crit_map.png").unlink()
        return res

    monkeypatch.setattr(report, "_build", one_figure)
    build_report(out, quick=True, readme=None)
    snap = _snapshot(out)
    assert "figures/dt_crit_map.png" not in snap, "got the stale figure kept, should be deleted"
    assert snap["bench/exact.json"] == b"{}", "got another tool's file deleted, should be kept"
    mode = stat.S_IMODE(out.stat().st_mode)
    assert mode == 0o700, f"got mode {oct(mode)}, should stay 0o700 [issue 22, hcv report]"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"], "temporary directory left"


def test_a_user_file_among_the_report_s_names_is_refused_even_in_a_report_dir(tmp_path, fake):
    out = tmp_path / "rep"
    build_report(out, quick=True, readme=None)
    (out / "figures" / "mine.png").write_bytes(b"user figure")
    with pytest.raises(HCVInputError, match="figures/mine.png"):
        build_report(out, quick=True, readme=None)
    (out / "figures" / "mine.png").unlink()
    build_report(out, quick=True, readme=None)  # only the manifest's files: ours to replace


def test_symlinked_out_is_followed_not_replaced(tmp_path, fake):
    target = tmp_path / "real"
    target.mkdir()
    (target / "keep.txt").write_text("kept")
    build_report(target, quick=True, readme=None, force=True)
    link = tmp_path / "link"
    link.symlink_to(target)
    build_report(link, quick=True, readme=None)
    assert link.is_symlink() and os.readlink(link) == str(target), (
        "got the symlink replaced, should still point at its target [issue 22, --out link]"
    )
    assert (target / "keep.txt").read_text() == "kept" and (target / "index.html").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]


def test_sigterm_to_report_leaves_no_temporary_directory(tmp_path):
    """SIGTERM mid-run (CI's cancel): exit 143, no ``.OUT.new-*``, nothing written."""
    out = tmp_path / "rep"
    proc = subprocess.Popen(
        [sys.executable, "-m", "reference_impl.cli", "report", "--quick", "--out", str(out)],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(tmp_path.glob(".rep.new-*")):
        time.sleep(0.1)
    assert list(tmp_path.glob(".rep.new-*")), "the report never started"
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, f"got exit {proc.returncode} ({err[-500:]}), should be 143"
    assert err.strip().splitlines()[-1] == "hcv: terminated (SIGTERM)", err[-500:]
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [], f"got {left} left behind, should be nothing [issue 22, SIGTERM report]"


def test_a_sigterm_whose_interrupt_was_swallowed_still_ends_the_report(tmp_path, monkeypatch):
    """The handler's KeyboardInterrupt, raised inside a finaliser, is printed and lost; a
    second SIGTERM is ignored by design. The flag it set must end the run at the next
    stage, with nothing written (CI run of 5fb9875: SIGTERM at 0.5 s, exit 0 at 46 s).
    """
    from reference_impl import _procs

    monkeypatch.setitem(_procs._state, "terminated", signal.SIGTERM)  # as _on_term leaves it
    out = tmp_path / "rep"
    messages: list[str] = []
    with pytest.raises(KeyboardInterrupt):
        build_report(out, quick=True, progress=messages.append)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [], f"got {left} left behind, should be nothing [SIGTERM flag, build_report]"
    assert not any("stage" in m for m in messages), f"got {messages}, should stop before stage 1"


# ----------------------------------------------------------------------------
# hcv sweep --out DIR
# ----------------------------------------------------------------------------
_SPEC = textwrap.dedent(
    """
    task = "solve"
    [scene]
    name = "s"
    mass = 1.0
    velocities = [1.0]
    [scene.potential]
    family = "power"
    k = 1.0
    p = 1.5
    [sweep]
    "mass" = [1.0, 2.0]
    """
)


@pytest.fixture
def spec(tmp_path) -> Path:
    p = tmp_path / "spec.toml"
    p.write_text(_SPEC)
    return p


def test_sweep_never_overwrites_a_user_s_files(tmp_path, spec, capsys):
    out = tmp_path / "analysis"
    out.mkdir()
    for name in ("spec.toml", "summary.md", "results.parquet"):
        (out / name).write_text(f"the user's {name}")
    before = _snapshot(out)
    _one_line_exit_2(capsys, ["sweep", str(spec), "--out", str(out)], "would overwrite")
    assert _snapshot(out) == before, "got the user's files changed [issue 22, sweep --out]"


@needs_dask  # without Dask, hcv sweep refuses (one line) before it reaches what this tests
def test_second_sweep_into_a_locked_directory_is_refused(tmp_path, spec, capsys):
    from reference_impl._userfiles import DirLock
    from reference_impl.cli.sweep import LOCK_NAME

    out = tmp_path / "run"
    out.mkdir()
    with DirLock(out, LOCK_NAME, "--out"):  # another sweep is writing here
        line = _one_line_exit_2(capsys, ["sweep", str(spec), "--out", str(out)], "another process")
    assert str(os.getpid()) in line, f"got {line!r}, should name the holder's pid"
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME], "got files written"


def test_resume_with_cases_jsonl_a_directory_is_one_line(tmp_path, spec, capsys):
    out = tmp_path / "run"
    (out / "cases.jsonl").mkdir(parents=True)
    _one_line_exit_2(
        capsys, ["sweep", str(spec), "--out", str(out), "--resume"], "not a regular file"
    )


def test_unwritable_sweep_out_is_one_line(tmp_path, spec, capsys):
    if os.geteuid() == 0:
        if not Path("/sys").is_dir():
            pytest.skip("root without /sys: no directory it cannot write")
        target = Path("/sys/hcv-issue-22-out")  # not writable even for root
    else:
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        target = ro / "out"
    _one_line_exit_2(capsys, ["sweep", str(spec), "--out", str(target)], "not writable")


@needs_dask  # without Dask, hcv sweep refuses (one line) before it reaches what this tests
def test_refused_sweep_leaves_nothing_behind(tmp_path, spec, capsys, monkeypatch):
    """Refused after the lock was taken (no scheduler at the address): DIR removed again."""
    from reference_impl.sweep import _runner

    monkeypatch.setattr(_runner, "_CONNECT_TIMEOUT", 1.0)
    out = tmp_path / "new"
    _one_line_exit_2(
        capsys,
        ["sweep", str(spec), "--out", str(out), "--scheduler", "tcp://127.0.0.1:9"],
        "scheduler",
    )
    assert not out.exists(), f"got {sorted(os.listdir(out))} in --out, should be nothing"


# ----------------------------------------------------------------------------
# hcv bench: an output that is an input
# ----------------------------------------------------------------------------
_SCENE = (
    'name = "s"\nmass = 1.0\nvelocities = [1.0]\n[potential]\nfamily = "power"\nk = 1.0\np = 1.5\n'
)


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--scenes", "my.toml", "--json", "my.toml"], "is the input --scenes"),
        (["--scenes", "hertz,my.toml", "--junit", "./my.toml"], "is the input"),
        (["--tolerances", "tol.toml", "--markdown", "tol.toml"], "is the input --tolerances"),
        (["--json", "x.out", "--junit", "x.out"], "name the same file"),
        (["--scenes", "my.toml", "--plot", "link.toml"], "is the input"),
    ],
)
def test_bench_refuses_an_output_that_is_an_input(tmp_path, monkeypatch, capsys, argv, needle):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my.toml").write_text(_SCENE)
    (tmp_path / "tol.toml").write_text("[run]\ntimeout = 10\n")
    (tmp_path / "link.toml").symlink_to(tmp_path / "my.toml")
    _one_line_exit_2(capsys, ["bench", "reference", *argv], needle)
    assert (tmp_path / "my.toml").read_text() == _SCENE
    assert (tmp_path / "tol.toml").read_text() == "[run]\ntimeout = 10\n"
    assert not (tmp_path / "x.out").exists()


@pytest.mark.skipif(not Path("/sys").is_dir(), reason="needs /sys (not writable, even for root)")
@pytest.mark.parametrize("option", ["--json", "--junit", "--markdown", "--plot"])
def test_bench_output_on_a_file_system_nobody_can_write_is_refused_first(capsys, option):
    """/sys refuses new files even to root, whose permission bits say yes."""
    _one_line_exit_2(
        capsys, ["bench", "reference", option, "/sys/hcv-issue-22.out"], "not writable"
    )


def test_a_run_without_adapters_keeps_other_runs_figures(tmp_path):
    """Issue 17 point 3: ``hcv report`` (no --adapter) keeps the scorecards, figures and
    steps figures another run wrote with ``--adapter``, and still owns them; a stale figure
    of its own is deleted."""
    import json

    from reference_impl.report._files import MANIFEST, _move_in

    out = tmp_path / "reports"
    (out / "figures").mkdir(parents=True)
    (out / "bench").mkdir()
    old = ["index.html", "figures/bench_lammps.png", "figures/steps_lammps.png",
           "bench/lammps.json", "figures/gone.png"]  # fmt: skip
    for rel in old:
        (out / rel).write_text("old")
    (out / MANIFEST).write_text(json.dumps({"written_by": "hcv report", "files": old}))
    new = tmp_path / "new"
    new.mkdir()
    (new / "index.html").write_text("new")
    _move_in(new, out)
    kept = {"figures/bench_lammps.png", "figures/steps_lammps.png", "bench/lammps.json"}
    owned = set(json.loads((out / MANIFEST).read_text())["files"])
    assert all((out / rel).read_text() == "old" for rel in kept), sorted(kept)
    assert not (out / "figures" / "gone.png").exists(), "a stale figure of the report stays"
    assert owned == kept | {"index.html"}, f"got manifest {sorted(owned)}"
