"""Guards for the user's files: path sizes, an output that is an input, one writer per directory.

Every ``hcv`` command checks the paths it is given before any work (issue 22):

* `check_path`: a path whose components exceed the file system's name limit
  (255 bytes on Linux) or whose whole exceeds the path limit is refused in one
  line instead of failing later with ``OSError: File name too long``;
* `refuse_output_onto_input`: an output file that is one of the command's inputs
  (or another of its outputs) is refused, so a report never overwrites a scene
  or tolerances file;
* `DirLock`: an exclusive advisory lock (``flock``) on a lock file inside an
  output directory, so two processes never write one directory at once.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from reference_impl.errors import HCVInputError

__all__ = [
    "DirLock",
    "check_path",
    "check_writable_dir",
    "refuse_output_onto_input",
    "same_path",
]

# POSIX defaults when the file system does not say (Linux: NAME_MAX 255, PATH_MAX 4096).
_NAME_MAX = 255
_PATH_MAX = 4096


def _limit(path: Path, name: str, default: int) -> int:
    """pathconf limit of the nearest existing directory of ``path`` (the default if unknown)."""
    p = path if path.is_absolute() else Path.cwd() / path
    while True:
        try:
            if p.is_dir():
                value = os.pathconf(p, name)
                return value if value and value > 0 else default
        except (OSError, ValueError):
            return default
        if p.parent == p:
            return default
        p = p.parent


def check_path(path, what: str) -> None:
    """Refuse (one line, `HCVInputError`) a path the file system cannot name.

    Parameters
    ----------
    path : str or os.PathLike
        The path as given by the user.
    what : str
        How the message names it (e.g. ``"--out"``, ``"scene file"``).
    """
    text = os.fspath(path)
    if "\0" in text:
        raise HCVInputError(f"{what} {text!r}: a path cannot contain a NUL character")
    p = Path(text)
    name_max = _limit(p.parent, "PC_NAME_MAX", _NAME_MAX)
    for part in p.parts:
        size = len(os.fsencode(part))
        if size > name_max:
            raise HCVInputError(
                f"{what} {text[:60]!r}...: the path component {part[:40]!r}... is {size} bytes; "
                f"the file system allows at most {name_max}"
            )
    size = len(os.fsencode(str(p.absolute())))
    path_max = _limit(p.parent, "PC_PATH_MAX", _PATH_MAX)
    if size >= path_max:
        raise HCVInputError(
            f"{what} {text[:60]!r}...: the path is {size} bytes; the file system allows "
            f"at most {path_max - 1}"
        )


def check_writable_dir(path, what: str) -> None:
    """``path`` is a writable directory or can be created (one-line `HCVInputError`).

    Permission bits do not tell everything (root, read-only or virtual file systems
    such as /sys), so the nearest existing directory is probed with a temporary
    entry, removed at once.
    """
    import tempfile

    check_path(path, what)
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise HCVInputError(f"{what} {path}: exists and is not a directory")
    base = p
    while not base.exists() and base.parent != base:
        base = base.parent
    if not base.is_dir():
        raise HCVInputError(f"{what} {path}: {str(base)!r} is not a directory")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".hcv-probe-", dir=base))
    except OSError as exc:
        raise HCVInputError(
            f"{what} {path}: directory {str(base)!r} is not writable ({exc.strerror})"
        ) from None


def same_path(a, b) -> bool:
    """True when ``a`` and ``b`` name the same file (symlinks and hard links followed)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist yet: compare the resolved names
        return os.path.realpath(a) == os.path.realpath(b)


def refuse_output_onto_input(outputs: dict[str, str], inputs: dict[str, str]) -> None:
    """Refuse an output path that is an input, or that another output also names.

    Parameters
    ----------
    outputs : dict
        Option -> path of every file the command will write (None entries ignored).
    inputs : dict
        Label -> path of every file the command reads (None entries ignored).
    """
    outs = [(k, v) for k, v in outputs.items() if v]
    ins = [(k, v) for k, v in inputs.items() if v]
    for i, (opt, path) in enumerate(outs):
        for label, src in ins:
            if same_path(path, src):
                raise HCVInputError(
                    f"{opt} {path}: is the input {label} {src}; writing it would destroy "
                    "the input; give another output file"
                )
        for opt2, path2 in outs[i + 1 :]:
            if same_path(path, path2):
                raise HCVInputError(
                    f"{opt} {path} and {opt2} {path2} name the same file; give two different files"
                )


class DirLock:
    """Exclusive lock on ``DIR/NAME`` held while a command writes into DIR.

    ``acquire`` raises `HCVInputError` naming the process that holds it. The lock
    is ``flock`` on an open file (released by the kernel when the process dies,
    so a killed run never leaves a stale lock). The lock file stays in DIR.
    """

    def __init__(self, directory, name: str, what: str):
        self.dir, self.path, self.what = Path(directory), Path(directory) / name, what
        self._fd: int | None = None

    def acquire(self) -> None:
        import fcntl

        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            try:
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
            finally:
                os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise HCVInputError(
                    f"{self.what} {self.dir}: another process (pid {holder}) is writing into "
                    "this directory; wait for it to finish or choose another directory"
                ) from None
            raise
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        self._fd = fd

    def release(self) -> None:
        if self._fd is not None:
            try:
                os.ftruncate(self._fd, 0)
            except OSError:
                pass
            os.close(self._fd)  # closing the descriptor releases the flock
            self._fd = None

    def __enter__(self):
        self.acquire()
        return self

    def __exit__(self, *exc):
        self.release()
        return False
