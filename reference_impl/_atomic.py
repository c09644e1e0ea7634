"""Writing a file whole or not at all: a unique temporary name beside it, then a rename.

A leaf (standard library only), shared by the compile cache and the bench's reports, so that
a reader never sees half a file and two writers of one path never mix their bytes.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["atomic_write", "new_file_mode"]


def new_file_mode() -> int:
    """Mode of a new file under the current umask (0644 under umask 022)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write(path, text: str, *, public: bool = True) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file and ``os.replace``.

    ``public``: give the file the mode of a new file (`new_file_mode`) rather than
    mkstemp's 0600. The parent directory is created when missing. On any error (also
    Ctrl-C) the temporary file is removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        if public:
            os.fchmod(fd, new_file_mode())
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
