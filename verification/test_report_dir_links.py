"""``hcv report --out DIR`` never reaches outside DIR (issue 29, "Files and code outside what
the user gave").

A cloned repository can carry symbolic links (git stores them), and the manifest that
decides which stale files a run deletes is a file in DIR like any other. With real links in
``tmp_path``: a link in DIR pointing outside is never followed, by the stale-file cleanup
nor by the writes; a manifest entry that leaves DIR (through a link, ``..`` or an absolute
path), holds a NUL byte or a name the file system cannot hold is refused in one line (exit
2) before anything runs, ``--force`` or not; and nothing outside DIR changes. The
measurements are replaced by a stub (`_fake_build`): only the file handling runs. The
expectations are the documented behaviour (reference_impl/report/_files.py), never a
value read back from the code under test.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

import reference_impl.campaign as report
from reference_impl.campaign import _environment, build_report
from reference_impl.cli import main
from reference_impl.errors import HCVInputError
from reference_impl.report._files import MANIFEST, _move_in

CALL = "hcv report --out DIR"


def _fake_build(out, quick, progress, adapters, env, workers=0, carried=None, repro=None):
    """Stand-in for the measurements: the report's files, one figure."""
    (out / "figures").mkdir()
    (out / "figures" / "fig1.png").write_bytes(b"new")
    results = {"claims": [], "environment": env, "mode": "quick"}
    for name in ("results.json", "index.md", "index.html"):
        (out / name).write_text(json.dumps(results))
    _fake_build.calls += 1
    return results


@pytest.fixture
def fake(monkeypatch):
    _fake_build.calls = 0
    monkeypatch.setattr(report, "_build", _fake_build)
    monkeypatch.setattr(
        _environment, "environment", lambda seeds: {"git_commit": "x", "git_dirty": False}
    )


def _snapshot(d: Path) -> dict[str, bytes]:
    """Every file and link under ``d`` (links by their target, never followed)."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(d):
        for name in filenames + [n for n in dirnames if os.path.islink(os.path.join(dirpath, n))]:
            p = Path(dirpath) / name
            out[str(p.relative_to(d))] = (
                b"-> " + os.readlink(p).encode() if p.is_symlink() else p.read_bytes()
            )
    return out


def _outside(tmp_path: Path) -> Path:
    """A directory of the user's outside DIR: a thesis and a folder."""
    home = tmp_path / "home"
    (home / "sub").mkdir(parents=True)
    (home / "thesis.tex").write_text("\\documentclass{article}")
    (home / "sub" / "data.csv").write_text("1,2,3")
    return home


def _report_dir(tmp_path: Path) -> Path:
    out = tmp_path / "rep"
    build_report(out, quick=True, readme=None)
    return out


def _set_manifest(out: Path, extra: list[str]) -> None:
    data = json.loads((out / MANIFEST).read_text())
    data["files"] = data["files"] + extra
    (out / MANIFEST).write_text(json.dumps(data))


def _refused(capsys, out: Path, needle: str, force: bool) -> str:
    argv = ["report", "--quick", "--out", str(out)] + (["--force"] if force else [])
    code = main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and needle in lines[0] and "Traceback" not in err, (
        f"got exit {code}, stderr {err!r}, should be 2 with one line naming {needle!r} "
        f"[issue 29, {CALL}{' --force' if force else ''}]"
    )
    return lines[0]


@pytest.mark.parametrize("force", [False, True])
def test_a_linked_subdirectory_in_the_manifest_is_refused_and_nothing_outside_changes(
    tmp_path, fake, capsys, force
):
    """The issue's case: DIR/evil -> ~ and a manifest listing evil/thesis.tex, evil/sub/data.csv."""
    home = _outside(tmp_path)
    out = _report_dir(tmp_path)
    os.symlink(home, out / "evil")
    _set_manifest(out, ["evil/thesis.tex", "evil/sub/data.csv"])
    before_home, before_out, calls = _snapshot(home), _snapshot(out), _fake_build.calls
    _refused(capsys, out, "evil/thesis.tex", force)
    assert _snapshot(home) == before_home, "got a file outside DIR changed, should be untouched"
    assert _snapshot(out) == before_out, "got DIR changed by a refused run, should be untouched"
    assert _fake_build.calls == calls, "got the report run, should be refused before any work"


@pytest.mark.parametrize(
    ("entry", "needle"),
    [
        ("../home/thesis.tex", "outside the directory"),
        ("ABS", "outside the directory"),
        ("figures/a\0b.png", "NUL"),
        ("figures/" + "x" * 300 + ".png", "bytes"),
        ("figures/" + "/".join(["d" * 200] * 25) + "/f.png", "bytes"),
    ],
    ids=["dotdot", "absolute", "nul", "long-name", "long-path"],
)
@pytest.mark.parametrize("force", [False, True])
def test_a_manifest_entry_that_is_not_a_file_in_dir_is_refused_before_any_work(
    tmp_path, fake, capsys, entry, needle, force
):
    home = _outside(tmp_path)
    out = _report_dir(tmp_path)
    entry = str(home / "thesis.tex") if entry == "ABS" else entry
    _set_manifest(out, [entry])
    before_home, before_out, calls = _snapshot(home), _snapshot(out), _fake_build.calls
    _refused(capsys, out, needle, force)
    assert _snapshot(home) == before_home, "got a file outside DIR changed"
    assert _snapshot(out) == before_out, "got DIR changed by a refused run"
    assert _fake_build.calls == calls, "got the report run, should be refused before any work"


@pytest.mark.parametrize("force", [False, True])
def test_a_report_subdirectory_linked_outside_is_never_written_through(
    tmp_path, fake, capsys, force
):
    """DIR/figures -> ~/sub: the report would write its figures outside DIR."""
    home = _outside(tmp_path)
    out = _report_dir(tmp_path)
    for f in (out / "figures").iterdir():
        f.unlink()
    (out / "figures").rmdir()
    os.symlink(home / "sub", out / "figures")
    before_home = _snapshot(home)
    _refused(capsys, out, "figures is a symbolic link", force)
    assert _snapshot(home) == before_home, "got the report written outside DIR"


def test_a_link_planted_after_the_check_is_not_followed_by_the_move_in(tmp_path):
    """The move-in checks again: a link planted while the report ran is refused before any
    file moves, and the stale-file cleanup never deletes through it."""
    home = _outside(tmp_path)
    out = tmp_path / "rep"
    out.mkdir()
    (out / "index.html").write_text("old")
    (out / MANIFEST).write_text(json.dumps({"files": ["index.html", "evil/thesis.tex"]}))
    os.symlink(home, out / "evil")  # after the arguments were checked
    new = tmp_path / "new"
    new.mkdir()
    (new / "index.html").write_text("new")
    before_home = _snapshot(home)
    with pytest.raises(HCVInputError, match="evil/thesis.tex"):
        _move_in(new, out)
    assert _snapshot(home) == before_home, "got a file outside DIR deleted"
    assert (out / "index.html").read_text() == "old", "got a file moved in before the refusal"


def test_a_link_inside_dir_is_resolved_and_a_stale_file_through_it_deleted(tmp_path, fake):
    """Not over-refusing: an entry whose link stays inside DIR is the report's to delete."""
    out = _report_dir(tmp_path)
    (out / "figures" / "stale.png").write_bytes(b"old")
    os.symlink(out / "figures", out / "figs")
    _set_manifest(out, ["figs/stale.png"])
    # --force: figures/stale.png is listed under its other name, figs/stale.png.
    build_report(out, quick=True, readme=None, force=True)
    assert not (out / "figures" / "stale.png").exists(), "got the stale figure kept"
    assert (out / "figures" / "fig1.png").read_bytes() == b"new"


def test_a_stale_entry_that_became_a_link_is_removed_not_followed(tmp_path, fake):
    """A stale file replaced by a link to a file outside: the link goes, the file stays."""
    home = _outside(tmp_path)
    out = _report_dir(tmp_path)
    os.symlink(home / "thesis.tex", out / "figures" / "old.png")
    _set_manifest(out, ["figures/old.png"])
    before_home = _snapshot(home)
    build_report(out, quick=True, readme=None)
    assert _snapshot(home) == before_home, "got the link's target deleted"
    assert not os.path.lexists(out / "figures" / "old.png"), "got the stale link kept"
