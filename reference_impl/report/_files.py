"""Checking the arguments of ``hcv report`` before anything runs, and moving the new report in.

The new report is written into a temporary directory beside the output
directory and moved in only when complete: an error, Ctrl-C or SIGTERM mid-run
removes the temporary directory and leaves the old report as it was.

The output directory belongs to the user; the report owns only the files it
wrote, listed in its manifest (`MANIFEST`, one relative path per entry):

* a run replaces the files it writes and deletes the files of the previous
  run's manifest that it did not write again (stale figures); nothing else in
  the directory is touched (e.g. ``reports/bench/`` of ``nox -s bench``);
* a non-empty directory without a manifest, or one holding a file the report
  would overwrite that is not in the manifest, is refused before anything runs,
  unless ``force`` (``hcv report --force``);
* the directory itself is never replaced: its mode, owner and any symlink to it
  stay (a symlinked ``--out`` is followed, and its target written);
* nothing outside the directory is written or deleted (issue 29): a symbolic link
  inside it is never followed out (a report sub-directory such as ``figures`` that
  links outside is refused; a stale file is deleted only when its directory resolves
  inside the directory, and a link is removed, never followed), and a manifest entry
  that leaves the directory (absolute, ``..``, through a link), holds a NUL byte or a
  name the file system cannot hold is refused in one line before anything runs, with
  or without ``force``. The move-in checks again, so a link planted during the run is
  refused before any file moves.

Not guaranteed: another process of the same user changing the directory while the
files move in (a fraction of a second, after the last check) can still redirect a
write; the report is not a sandbox against its own user.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import signal
import stat
import tempfile
import threading
from pathlib import Path

from reference_impl._userfiles import check_path
from reference_impl.adapters.registry import get_adapter, parse_spec, resolve_class
from reference_impl.errors import HCVInputError

__all__ = ["MANIFEST", "REPORT_ENTRIES", "scripts_href", "swap_in", "validate_report_args"]

# The report's top-level files and directories (the names a run writes).
REPORT_ENTRIES = ("index.html", "index.md", "erratum.md", "results.json", "figures", "bench")
# The list of files the report wrote (JSON), kept in the output directory.
MANIFEST = ".hcv-report-manifest.json"
# Entries named in a refusal (the first few).
_SHOWN = 3
# Files looked at when listing a directory's content (a report directory holds ~20).
_MAX_LISTED = 100_000
# A manifest lists ~30 paths (~1 kB); a larger file was planted, not written by a report.
_MANIFEST_MAX_BYTES = 2**20


def read_manifest(out: Path) -> set[str] | None:
    """The relative paths a previous report wrote into ``out``, or None without a manifest.

    Every entry is checked before anything is run (`HCVInputError`, one line naming it): a
    NUL byte, a name the file system cannot hold, or a path that leaves ``out`` (absolute,
    ``..``, or through a symbolic link inside ``out`` that points outside it) is refused.
    The manifest is the report's own file: such an entry was not written by ``hcv report``.
    """
    path = out / MANIFEST
    if not path.is_file():
        return None
    try:
        if path.stat().st_size > _MANIFEST_MAX_BYTES:
            raise ValueError("too large")
        data = json.loads(path.read_text(encoding="utf-8"))
        files = data["files"]
        if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
            raise TypeError
    except (OSError, ValueError, KeyError, TypeError):
        raise HCVInputError(
            f"report directory {str(out)!r}: its manifest {MANIFEST} is unreadable; "
            "remove it (and the report files) or choose another directory"
        ) from None
    for rel in files:
        why = _leaves(out, rel)
        if why is not None:
            raise HCVInputError(
                f"report directory {str(out)!r}: its manifest {MANIFEST} lists {rel[:80]!r}, "
                f"{why}; it was not written by hcv report: remove that entry (or the manifest)"
            )
    return set(files)


def _leaves(out: Path, rel: str) -> str | None:
    """Why the manifest entry ``rel`` is not a file inside ``out`` (None when it is).

    The entry's directory is resolved (every symbolic link followed) and must lie inside
    the resolved ``out``; the entry itself may be a link (deleting a link never follows it).
    """
    if not rel or "\0" in rel:
        return "an empty name or one with a NUL byte"
    try:
        check_path(out / rel, "manifest entry")
    except HCVInputError as exc:
        return str(exc).split(": ", 1)[-1]
    p = Path(rel)
    if p.is_absolute() or ".." in p.parts or p.name in ("", "."):
        return "a path outside the directory"
    root = os.path.realpath(out)
    where = os.path.realpath(out / p.parent)
    if os.path.commonpath([root, where]) != root:
        return f"whose directory is {where!r} (through a symbolic link), outside the directory"
    return None


def _files(root: Path) -> list[str]:
    """Relative paths of the files and symlinks below ``root`` (not following links)."""
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        for name in filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]:
            out.append(os.path.relpath(os.path.join(dirpath, name), root))
            if len(out) >= _MAX_LISTED:
                return out
    return out


def _adapter_json(spec: str) -> str:
    """Where the report stores an adapter's scorecard (as `report._bench_adapter` names it)."""
    safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in str(spec))[:60]
    return f"bench/{safe}.json"


def _check_links(out: Path) -> None:
    """Refuse a report sub-directory (``figures``, ``bench``) that is a link out of ``out``.

    The report writes only inside the directory it was given; a symbolic link there (git
    stores them, so a cloned repository can carry one) is never followed out, even with
    ``force``.
    """
    root = os.path.realpath(out)
    for name in REPORT_ENTRIES:
        p = out / name
        if p.is_symlink():
            target = os.path.realpath(p)
            if os.path.commonpath([root, target]) != root:
                raise HCVInputError(
                    f"report directory {str(out)!r}: {name} is a symbolic link to {target!r}, "
                    "outside the directory; the report writes only inside it: remove the link "
                    "or choose another directory"
                )


def _check_owned(out: Path, adapters, force: bool) -> None:
    """Refuse a directory holding files the report does not own (unless ``force``).

    The manifest and the links are checked whatever ``force`` says (`read_manifest`,
    `_check_links`): they decide what a run deletes and where it writes.
    """
    if not out.is_dir():
        return
    _check_links(out)
    owned = read_manifest(out)
    if force:
        return
    if owned is None:
        with os.scandir(out) as it:  # the first few entries tell: no need to walk it all
            present = [e.name for _, e in zip(range(_SHOWN + 1), it, strict=False)]
        if present:
            more = ", ..." if len(present) > _SHOWN else ""
            raise HCVInputError(
                f"report directory {str(out)!r} holds files not written by hcv report "
                f"({', '.join(sorted(present)[:_SHOWN])}{more}); choose an empty or new "
                "directory, or give --force to write beside them (files of the same names "
                "as the report's are then replaced)"
            )
        return
    present = [f for f in _files(out) if f != MANIFEST]
    ours = {
        "index.html",
        "index.md",
        "erratum.md",
        "results.json",
        *(_adapter_json(a) for a in adapters),
    }
    clash = [f for f in present if f not in owned and (f in ours or Path(f).parts[0] == "figures")]
    if clash:
        raise HCVInputError(
            f"report directory {str(out)!r}: {', '.join(sorted(clash)[:_SHOWN])} "
            "would be overwritten but was not written by hcv report; move it away, "
            "choose another directory, or give --force"
        )


def scripts_href(out: Path) -> str | None:
    """The link from the report directory ``out`` to the referee's scripts, or None.

    The checkout's ``reports/`` holds them in ``repro/`` (``repro/run_all.py`` and one
    script per claim); a report written anywhere else names them without a link.
    """
    return "repro" if (Path(out) / "repro" / "run_all.py").is_file() else None


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists():
        if p.parent == p:
            break
        p = p.parent
    return p


def validate_report_args(out_dir, adapters=(), force: bool = False) -> tuple[Path, list[str]]:
    """Check the output directory and every adapter spec; write nothing.

    Returns
    -------
    (Path, list of str)
        The absolute output directory and the adapter specs.

    Raises
    ------
    HCVInputError
        One line naming the offending value: an unknown or malformed adapter, an
        output path that is a file, or a directory that cannot be written.
    """

    if out_dir is None or not str(out_dir).strip():
        raise HCVInputError(f"report directory must be a non-empty path, got {out_dir!r}")
    check_path(os.path.expanduser(str(out_dir)), "report directory")
    # A symlink is followed: its target is the directory written (the link stays).
    out = Path(os.path.realpath(Path(out_dir).expanduser()))
    if out.exists() and not out.is_dir():
        raise HCVInputError(f"report directory {str(out_dir)!r} exists and is not a directory")
    base = _nearest_existing(out.parent)
    if not base.is_dir():
        raise HCVInputError(f"report directory {str(out_dir)!r}: {str(base)!r} is not a directory")
    if not os.access(base, os.W_OK | os.X_OK) or (out.exists() and not os.access(out, os.W_OK)):
        raise HCVInputError(f"report directory {str(out_dir)!r} is not writable")
    specs = [] if adapters is None else list(adapters)
    for spec in specs:
        if isinstance(spec, str):
            target, _ = parse_spec(spec)  # raises HCVInputError naming the spec
            if target != "subprocess":
                resolve_class(target)  # unknown name or import path: HCVInputError
            else:  # cheap (no process started): a missing program is refused now
                get_adapter(spec).close()
    _check_owned(out, [s for s in specs if isinstance(s, str)], force)
    return out, specs


@contextlib.contextmanager
def swap_in(out: Path):
    """Yield a fresh directory beside ``out``; on success its files are moved into ``out``.

    Files of the previous report's manifest that the new run did not write are
    deleted; everything else in ``out`` stays. ``out`` is created if missing, never
    replaced. On any exception (KeyboardInterrupt, SIGTERM handled as it, included)
    the temporary directory is removed and ``out`` is left untouched.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.new-", dir=out.parent))
    try:
        yield tmp
        with _signals_held():
            _move_in(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT and SIGTERM while the files move in (delivered right after)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _move_in(tmp: Path, out: Path) -> None:
    """Move the new report's files into ``out``; delete the stale ones; write the manifest.

    Nothing is moved before every path is checked (a link planted since the arguments
    were checked is refused here, before any file moves); a stale file is deleted only
    when it is a file or link whose directory lies inside ``out`` (`_leaves`).
    """
    if out.exists():
        _check_links(out)
        old = read_manifest(out) or set()
    else:
        out.mkdir()  # mode from the umask, as any new directory
        old = set()
    new = sorted(_files(tmp))
    for rel in new:
        why = _leaves(out, rel)
        if why is not None:
            raise HCVInputError(
                f"report directory {str(out)!r}: {rel!r} is {why}; nothing was moved in"
            )
    umask = os.umask(0)
    os.umask(umask)
    for rel in new:
        target = out / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        if target.is_dir() and not target.is_symlink():
            shutil.rmtree(target)  # only with --force: a directory where a file goes
        _move(tmp / rel, target)
    # Another run's scorecards (``hcv report --adapter lammps`` writes figures/bench_lammps.png
    # and bench/lammps.json): a run without that adapter keeps them, still owned (issue 17).
    kept = {rel for rel in old - set(new) if _other_runs(rel) and (out / rel).is_file()}
    for rel in sorted(old - set(new) - kept):
        if _leaves(out, rel) is not None:
            continue  # changed since it was checked: never delete outside ``out``
        path = out / rel
        with contextlib.suppress(OSError):
            if not stat.S_ISDIR(path.lstat().st_mode):
                path.unlink()  # a link is removed, never followed
        _prune(out, path.parent)
    data = {"written_by": "hcv report", "files": sorted(set(new) | kept)}
    tmp_manifest = out / (MANIFEST + ".tmp")
    tmp_manifest.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    os.chmod(tmp_manifest, 0o666 & ~umask)
    os.replace(tmp_manifest, out / MANIFEST)


def _other_runs(rel: str) -> bool:
    """A file an adapter's report run writes: figures/bench_*.png and steps_*.png, bench/*.json."""
    parts = Path(rel).parts
    return len(parts) == 2 and (
        (parts[0] == "figures" and parts[1].startswith(("bench_", "steps_"))) or parts[0] == "bench"
    )


def _move(src: Path, dst: Path) -> None:
    """Rename ``src`` onto ``dst``; across file systems (DIR a mount point) copy, then rename."""
    try:
        os.replace(src, dst)
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise
        part = dst.with_name(f".{dst.name}.hcv-part")
        shutil.copy2(src, part)
        os.replace(part, dst)


def _prune(out: Path, d: Path) -> None:
    """Remove directories the deletion of stale files left empty (up to ``out``)."""
    while d != out and out in d.parents:
        if d.is_symlink():
            return  # a link is not a directory the deletion emptied
        try:
            d.rmdir()
        except OSError:
            return
        d = d.parent
