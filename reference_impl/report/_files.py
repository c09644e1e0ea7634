"""Checking the arguments of ``hcv report`` before anything runs, and swapping the new report in.

The new report is written into a temporary directory beside the old one and
replaces it only when complete: an error or Ctrl-C mid-run leaves the old
report as it was, and no half-written report is ever visible.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from reference_impl.errors import HCVInputError

__all__ = ["REPORT_ENTRIES", "swap_in", "validate_report_args"]

# What a report run replaces as a whole; anything else in the directory (e.g. the
# benchmark JSON that ``nox -s bench`` writes into reports/bench/) is kept, file by
# file, unless the new run wrote a file of the same name.
REPORT_ENTRIES = ("index.html", "index.md", "results.json", "figures")


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists():
        if p.parent == p:
            break
        p = p.parent
    return p


def validate_report_args(out_dir, adapters=()) -> tuple[Path, list[str]]:
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
    from reference_impl.adapters.registry import parse_spec, resolve_class

    if out_dir is None or not str(out_dir).strip():
        raise HCVInputError(f"report directory must be a non-empty path, got {out_dir!r}")
    out = Path(out_dir).expanduser().absolute()
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
    return out, specs


@contextlib.contextmanager
def swap_in(out: Path):
    """Yield a fresh directory beside ``out``; on success it replaces ``out``.

    Entries of the old directory outside `REPORT_ENTRIES` that the new run did not
    write are carried into the new one. On any exception (KeyboardInterrupt included)
    the temporary directory is removed and ``out`` is left untouched.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.new-", dir=out.parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes it private; a report directory is not
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if not out.exists():
        tmp.rename(out)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
    old.rmdir()
    out.rename(old)
    try:
        tmp.rename(out)
    except BaseException:
        old.rename(out)  # put the previous report back
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    _carry_over(old, out)
    shutil.rmtree(old, ignore_errors=True)


# Figures another run wrote (``hcv report --adapter lammps`` writes bench_lammps.png):
# a run without that adapter keeps them rather than deleting them (issue 17).
_OTHER_RUNS_FIGURES = "bench_"


def _carry_over(old: Path, new: Path, top: bool = True) -> None:
    """Move what the new report did not write from the old directory into the new one."""
    for entry in old.iterdir():
        if top and entry.name == "figures" and entry.is_dir():
            for fig in entry.iterdir():
                target = new / "figures" / fig.name
                if fig.name.startswith(_OTHER_RUNS_FIGURES) and not target.exists():
                    target.parent.mkdir(exist_ok=True)
                    fig.rename(target)
            continue
        if top and entry.name in REPORT_ENTRIES:
            continue
        target = new / entry.name
        if not target.exists():
            entry.rename(target)
        elif entry.is_dir() and target.is_dir():
            _carry_over(entry, target, top=False)
