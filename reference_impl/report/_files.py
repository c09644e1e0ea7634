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
  stay (a symlinked ``--out`` is followed, and its target written).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import signal
import tempfile
import threading
from pathlib import Path

from reference_impl._userfiles import check_path
from reference_impl.errors import HCVInputError

__all__ = ["MANIFEST", "REPORT_ENTRIES", "swap_in", "validate_report_args"]

# The report's top-level files and directories (the names a run writes).
REPORT_ENTRIES = ("index.html", "index.md", "erratum.md", "results.json", "figures", "bench")
# The list of files the report wrote (JSON), kept in the output directory.
MANIFEST = ".hcv-report-manifest.json"
# Entries named in a refusal (the first few).
_SHOWN = 3
# Files looked at when listing a directory's content (a report directory holds ~20).
_MAX_LISTED = 100_000


def read_manifest(out: Path) -> set[str] | None:
    """The relative paths a previous report wrote into ``out``, or None without a manifest."""
    path = out / MANIFEST
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        files = data["files"]
        if not all(isinstance(f, str) for f in files):
            raise TypeError
    except (OSError, ValueError, KeyError, TypeError):
        raise HCVInputError(
            f"report directory {str(out)!r}: its manifest {MANIFEST} is unreadable; "
            "remove it (and the report files) or choose another directory"
        ) from None
    return {f for f in files if _inside(f)}


def _inside(rel: str) -> bool:
    """A manifest entry that stays inside the directory (no absolute path, no '..')."""
    p = Path(rel)
    return bool(rel) and not p.is_absolute() and ".." not in p.parts


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


def _check_owned(out: Path, adapters, force: bool) -> None:
    """Refuse a directory holding files the report does not own (unless ``force``)."""
    if force or not out.is_dir():
        return
    owned = read_manifest(out)
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
    ours = {"index.html", "index.md", "erratum.md", "results.json", *(_adapter_json(a) for a in adapters)}
    clash = [f for f in present if f not in owned and (f in ours or Path(f).parts[0] == "figures")]
    if clash:
        raise HCVInputError(
            f"report directory {str(out)!r}: {', '.join(sorted(clash)[:_SHOWN])} "
            "would be overwritten but was not written by hcv report; move it away, "
            "choose another directory, or give --force"
        )


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
    from reference_impl.adapters.registry import get_adapter, parse_spec, resolve_class

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
    """Move the new report's files into ``out``; delete the stale ones; write the manifest."""
    if out.exists():
        old = read_manifest(out) or set()
    else:
        out.mkdir()  # mode from the umask, as any new directory
        old = set()
    new = sorted(_files(tmp))
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
        with contextlib.suppress(FileNotFoundError, IsADirectoryError, NotADirectoryError):
            (out / rel).unlink()
        _prune(out, (out / rel).parent)
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
        try:
            d.rmdir()
        except OSError:
            return
        d = d.parent
