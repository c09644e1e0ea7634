"""The files a results document names, read only inside the report directory (issue 36).

A results.json names its figures (``figures/NAME.png``) and, through its codes, their
scorecards (``bench/NAME.json``); ``hcv report --from`` copies them and ``index.html``
embeds the figures. A results file is shared and may come from anyone (a pull request),
so every such read goes through `read_report_file`, which refuses, in one line naming the
field it came from:

* a path that is not ``DIR/NAME`` with DIR ``figures`` or ``bench`` and NAME of word
  characters, ``.`` and ``-`` (no ``/``, no ``..``, no absolute path, no leading dot);
* DIR or NAME a symbolic link (both are opened with ``O_NOFOLLOW``, the file relative to
  the directory's descriptor, so nothing outside the report is ever opened);
* anything but a regular file (``/dev/zero``, a FIFO: opened non-blocking, checked on the
  descriptor before a byte is read);
* a file over `MAX_BYTES`, or a figure without the PNG signature.
"""

from __future__ import annotations

import errno
import os
import re
import stat
from pathlib import Path

from reference_impl.errors import HCVInputError

__all__ = ["MAX_BYTES", "PNG_SIGNATURE", "figure_bytes", "read_report_file"]

# The eight bytes every PNG file starts with (PNG specification, section 5.2).
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# The largest file a report writes is a code's scorecard (bench/lammps.json, 0.66 MB; the
# figures are at most 0.25 MB): 20 MiB keeps a 30x margin and bounds what a planted file can
# make the report read and hold (index.html then holds 4/3 of each figure, as base64).
MAX_BYTES = 20 * 2**20
# A report's own sub-directories that a results document may name files in.
_DIRS = ("figures", "bench")
# NAME of DIR/NAME: the names the report writes (figures/fig1.png, bench/lammps.json): word
# characters (letters of any script, as an adapter's name keeps them), "." and "-", not
# starting with "." (so never "..", a hidden file or a path).
_NAME = re.compile(r"\w[\w.-]{0,99}")


def _refuse(field: str, rel: str, why: str, own: bool = True) -> HCVInputError:
    """One line: the field, the path, why; ``own``: say the rule that refused it."""
    rule = "; the report reads only its own files: figures/NAME.png, bench/NAME.json" if own else ""
    return HCVInputError(f"{field}: {rel[:120]!r} {why}{rule}")


def figure_bytes(fig_dir: Path, name: str, field: str, head_only: bool = False) -> bytes:
    """The bytes of the PNG figure ``fig_dir/name`` (see `read_report_file`)."""
    return _read(Path(fig_dir), name, f"figures/{name}", field, True, head_only)


def read_report_file(
    base: Path, rel: str, field: str, png: bool = True, head_only: bool = False
) -> bytes:
    """Read the file ``rel`` (``figures/NAME`` or ``bench/NAME``) of the report in ``base``.

    Parameters
    ----------
    base : Path
        The report directory (that of the results.json naming the file).
    rel : str
        The path as the results document gives it.
    field : str
        Where the path came from, named in a refusal (a JSON path such as
        ``$.figures[3]``, with the file it is in).
    png : bool
        The file must start with `PNG_SIGNATURE`.
    head_only : bool
        Check the file and return only its first bytes (its signature).

    Returns
    -------
    bytes
        The file's content (at most `MAX_BYTES`).

    Raises
    ------
    HCVInputError
        One line naming ``field`` and ``rel``: a path outside the rule, a link, a missing
        or non-regular file, a file over `MAX_BYTES`, a figure that is not a PNG.
    """
    parts = rel.split("/") if isinstance(rel, str) else []
    if len(parts) != 2 or parts[0] not in _DIRS or not _NAME.fullmatch(parts[1]):
        raise _refuse(field, str(rel), "is not figures/NAME or bench/NAME inside the report")
    return _read(Path(base) / parts[0], parts[1], rel, field, png, head_only)


def _read(folder: Path, name: str, rel: str, field: str, png: bool, head_only: bool) -> bytes:
    if not _NAME.fullmatch(name):
        raise _refuse(field, rel, "is not a plain file name of the report")
    nofollow = os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC
    try:
        dfd = os.open(folder, nofollow | os.O_DIRECTORY)
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.ENOTDIR):
            raise _refuse(
                field, rel, f"is in {folder.name}/, a symbolic link or not a directory"
            ) from None
        raise _refuse(field, rel, f"cannot be read ({folder}: {exc.strerror})", own=False) from None
    try:
        try:  # non-blocking: a FIFO planted as NAME.png must not hang the open
            fd = os.open(name, nofollow | os.O_NONBLOCK, dir_fd=dfd)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise _refuse(field, rel, "is a symbolic link") from None
            if exc.errno == errno.ENXIO:  # a socket: open() fails before fstat can tell
                raise _refuse(field, rel, "is not a regular file") from None
            why = f"is missing ({folder / name})" if exc.errno == errno.ENOENT else exc.strerror
            raise _refuse(field, rel, why, own=False) from None
        # Checked on the bare descriptor: os.fdopen itself fails on a directory, with a
        # message naming the descriptor, not the field.
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            os.close(fd)
            raise _refuse(field, rel, "is not a regular file")
        with os.fdopen(fd, "rb") as f:
            if st.st_size > MAX_BYTES:
                raise _refuse(field, rel, f"is {st.st_size} bytes, over the bound of {MAX_BYTES}")
            data = f.read(len(PNG_SIGNATURE) if head_only else MAX_BYTES + 1)
    finally:
        os.close(dfd)
    if len(data) > MAX_BYTES:  # grew since fstat
        raise _refuse(field, rel, f"is over the bound of {MAX_BYTES} bytes")
    if png and not data.startswith(PNG_SIGNATURE):
        raise _refuse(field, rel, "is not a PNG image (no PNG signature)")
    return data
