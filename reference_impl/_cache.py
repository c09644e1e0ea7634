"""Where compiled code is kept between processes: the cache directory, numba's disk cache in it.

**Location.** ``$HCV_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/hidden-harmonic-verification``,
else ``~/.cache/hidden-harmonic-verification``. numba's own disk cache goes to its
``numba/key-<digest>`` sub-directory (``NUMBA_CACHE_DIR`` is set there when the user did not
set it; a user's ``NUMBA_CACHE_DIR`` is left alone), the user expressions' generated modules
to ``expressions/``.

**Fresh code, fresh cache.** numba checks a cached function only against the stamp of its
own source file, so a caller kept a changed callee's old machine code. The sub-directory is
therefore named by `reference_impl._numba_dir.numba_key`, a digest of the versions and of the
content of every compiled source (and the modules they import): any change there selects a
fresh directory. It is chosen when numba is imported (`_select_numba_dir`, from the import
hook below; 1-3 ms, nothing for a command that never imports numba), made 0700 and checked
like the cache; old ones are pruned then (`reference_impl._numba_dir.prune_numba_dirs`:
the 3 most recently used and any used within the hour stay, a symbolic link is never
followed). A ``NUMBA_CACHE_DIR`` the user set gets numba's rule only (a stale callee is
possible after an edit); one this package set is marked in ``_HCV_NUMBA_CACHE_DIR``, so a
child process does not take the value it inherits for the user's.

**Degrading.** A cache directory that cannot be created or written, or whose file system
has less than `MIN_FREE_BYTES` free, is not an error: numba then compiles into a private
temporary directory removed at exit (nothing is kept between processes), and one
`CacheWarning` says so, once per process.

**Who may write it (issue 29).** numba's cache files are pickles, and unpickling runs code:
whoever can write the cache can run code in every later hcv process. The directory is
therefore created 0700, and one that is owned by another user, or writable by group or
others (itself or its ``numba/``, ``tables/``, ``expressions/``), is refused like an
unusable one: one `CacheWarning`, a private temporary cache. A ``NUMBA_CACHE_DIR`` the user
set is the user's choice and is not checked.

**Damaged files.** A numba file that cannot be loaded (a truncated ``.nbc``, a garbage
``.nbi``) is removed and the function compiled afresh, with one `CacheWarning` per process,
instead of raising on every later run: `_guard_numba_loader` wraps numba's loader the
moment ``numba.core.caching`` is imported (an import hook: importing this module does not
import numba). A file that loads but was written by someone else is not detected: that is
what the ownership rule is for.

**User expressions.** Their compiled modules are kept in ``expressions/`` by
`reference_impl._expr_cache`.
"""

from __future__ import annotations

import os
import stat
import sys
import warnings
from pathlib import Path

__all__ = [
    "CacheWarning",
    "MIN_FREE_BYTES",
    "cache_dir",
    "configure_numba_cache",
    "expressions_dir",
]

_APP = "hidden-harmonic-verification"
# Below this free space the cache counts as full: one expression's kernels take 1-5 MB,
# and numba's writes fail mid-file (an error, not a miss) when the disk fills.
MIN_FREE_BYTES = 64 * 2**20


class CacheWarning(UserWarning):
    """The compile cache cannot be used; code is compiled for this process only."""


_state: dict = {"usable": None, "warned": False, "tmp": None, "numba_root": None}
# Set beside NUMBA_CACHE_DIR to the value this package gave it (`_numba_dir_is_ours`).
_MARK = "_HCV_NUMBA_CACHE_DIR"


def cache_dir() -> Path:
    """The per-user cache directory (``HCV_CACHE_DIR`` overrides it)."""
    env = os.environ.get("HCV_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / _APP


def expressions_dir() -> Path:
    return cache_dir() / "expressions"


# Sub-directories whose files later runs load (pickles, modules, tables).
_SUBDIRS = ("numba", "tables", "expressions")


def _untrusted(path: Path) -> str | None:
    """Why others could have written ``path`` or its sub-directories (None when they cannot).

    Owned by another user, or writable by group or others: numba's files are pickles, so
    such a cache could run another user's code in this process.
    """
    for p in (path, *(path / s for s in _SUBDIRS)):
        why = _who_else_writes(p)
        if why is not None:
            return why
    return None


def _who_else_writes(p: Path) -> str | None:
    """Why another user could write the directory ``p`` (None when none can, or it is absent)."""
    try:
        st = os.stat(p)  # a link is judged by its target
    except FileNotFoundError:
        return None
    if st.st_uid != os.geteuid():
        return f"{p} is owned by another user (uid {st.st_uid})"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return (
            f"{p} is writable by group or others (mode {oct(stat.S_IMODE(st.st_mode))}); "
            "its pickled code would run here. chmod 700 it after checking its content, "
            "or remove it"
        )
    return None


def _unusable(path: Path, min_free: int | None = None) -> str | None:
    """Why ``path`` cannot hold the cache (None when it can): not creatable, not writable,
    writable by others (`_untrusted`), full."""
    min_free = MIN_FREE_BYTES if min_free is None else min_free
    try:
        # 0700: only this user may write what later runs load (the parents as any directory).
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        why = _untrusted(path)
        if why is not None:
            return why
        # A real write, not os.access: the latter says yes to root on a read-only mount.
        probe = path / f".probe-{os.getpid()}"
        os.close(os.open(probe, os.O_CREAT | os.O_WRONLY | os.O_TRUNC, 0o600))
        os.unlink(probe)
        st = os.statvfs(path)
        free = st.f_bavail * st.f_frsize
    except OSError as exc:
        return f"cannot be written ({exc.strerror or type(exc).__name__})"
    if free < min_free:
        return f"is full ({free / 2**20:.0f} MB free, {min_free / 2**20:.0f} MB needed)"
    return None


def _warn_once(text: str) -> None:
    if not _state["warned"]:
        _state["warned"] = True
        warnings.warn(text, CacheWarning, stacklevel=3)


def _private_tmp() -> str | None:
    import atexit
    import shutil
    import tempfile

    if _state["tmp"] is None:
        try:
            _state["tmp"] = tempfile.mkdtemp(prefix="hcv-numba-")
        except OSError:
            return None
        atexit.register(shutil.rmtree, _state["tmp"], True)
    return _state["tmp"]


def _numba_dir_is_ours() -> bool:
    """True unless the user set ``NUMBA_CACHE_DIR`` (a value this package set, marked in
    ``_HCV_NUMBA_CACHE_DIR`` and inherited by a child process, is still ours)."""
    value = os.environ.get("NUMBA_CACHE_DIR")
    return value is None or value == os.environ.get(_MARK)


def _set_numba_dir(target: str) -> None:
    """Point numba at ``target``, marked as ours (`_numba_dir_is_ours`)."""
    os.environ["NUMBA_CACHE_DIR"] = os.environ[_MARK] = target
    numba_config = sys.modules.get("numba.core.config")
    if numba_config is not None:  # numba is imported: tell it too (it reads CACHE_DIR per use)
        numba_config.CACHE_DIR = target


def configure_numba_cache() -> bool:
    """Point numba's disk cache at the per-user directory; True when it is usable.

    Called once when the package is imported (before numba is), and cheap: one directory
    check. The keyed sub-directory (`_select_numba_dir`) is chosen when numba is imported,
    so a command that never compiles pays nothing for the key. When the directory is
    unusable, numba compiles into a private temporary directory removed at exit, and one
    `CacheWarning` names the directory and the reason.
    """
    if _state["usable"] is not None:
        return _state["usable"]
    root = cache_dir()
    reason = _unusable(root)
    _state["usable"] = reason is None
    _state["numba_root"] = None
    if _numba_dir_is_ours():
        if reason is None:
            _state["numba_root"] = root / "numba"  # its keyed sub-directory: when numba loads
        else:
            target = _private_tmp()
            if target is not None:
                _set_numba_dir(target)
    if reason is not None:
        _warn_once(
            f"hcv: the compile cache {root} {reason}; compiling for this process only "
            "(set HCV_CACHE_DIR to a writable directory to keep compiled code between runs)"
        )
    _guard_numba_loader()
    return _state["usable"]


# --------------------------------------------------------------------------- numba's keyed directory


def _select_numba_dir() -> None:
    """Point numba at ``numba/<key>`` of the cache (made 0700, checked like the cache),
    then prune the old keyed directories. Once per configuration; nothing when the user set
    ``NUMBA_CACHE_DIR`` or the cache is unusable."""
    numba_root = _state.get("numba_root")
    if numba_root is None:
        return
    _state["numba_root"] = None
    # Deferred: a command that never imports numba does not load it (1 ms).
    from reference_impl._numba_dir import numba_key, prune_numba_dirs

    target = numba_root / numba_key()
    try:
        for d in (numba_root, target):
            d.mkdir(mode=0o700, exist_ok=True)  # the cache root exists (`_unusable` made it)
        why = _who_else_writes(numba_root) or _who_else_writes(target)
        if why is None:
            os.utime(target)  # recently used: last to be pruned
    except OSError as exc:
        why = f"{target} cannot be written ({exc.strerror or type(exc).__name__})"
    if why is not None:
        _state["usable"] = False
        _warn_once(f"hcv: the compile cache {why}; compiling for this process only")
        tmp = _private_tmp()
        if tmp is not None:
            _set_numba_dir(tmp)
        return
    _set_numba_dir(str(target))
    prune_numba_dirs(numba_root, keep=target)


# --------------------------------------------------------------------------- damaged files


def _guard_numba_loader() -> None:
    """Wrap numba's cache loader and choose the keyed directory (`_numba_loaded`): now if
    ``numba.core.caching`` is imported, else when it is."""
    module = sys.modules.get("numba.core.caching")
    if module is not None:
        _numba_loaded(module)
    elif not _state.get("hooked"):
        _state["hooked"] = True
        sys.meta_path.insert(0, _PatchOnImport())


def _numba_loaded(caching) -> None:
    _wrap_loader(caching)
    _select_numba_dir()


class _PatchOnImport:
    """Import hook: once ``numba.core.caching`` is executed, wrap its loader (one shot)."""

    def find_spec(self, fullname, path, target=None):
        if fullname != "numba.core.caching":
            return None
        sys.meta_path.remove(self)
        from importlib.machinery import PathFinder

        spec = PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        execute = spec.loader.exec_module

        def exec_module(module):
            execute(module)
            _numba_loaded(module)

        spec.loader.exec_module = exec_module
        return spec


def _damaged(path: str, exc: BaseException) -> None:
    """Remove a numba file that cannot be loaded; warn once per process."""
    try:
        os.unlink(path)
    except OSError:
        pass  # read-only or already gone: numba overwrites it when it saves
    if not _state.get("warned_damaged"):
        _state["warned_damaged"] = True
        warnings.warn(
            f"hcv: the compile cache file {path} is damaged ({type(exc).__name__}: "
            f"{str(exc)[:80]}); it was removed and the function is compiled afresh",
            CacheWarning,
            stacklevel=2,
        )


def _wrap_loader(caching) -> None:
    """Make numba's index and data loads treat a damaged file as a miss (removed, warned).

    numba raises on a truncated or garbage pickle, on every later run; a miss compiles the
    function and numba's next save rewrites the entry whole (it writes to a temporary name).
    """
    files = caching.IndexDataCacheFile
    if getattr(files, "_hcv_guarded", False):
        return
    load_index, load_data = files._load_index, files._load_data

    def _load_index(self):
        try:
            return load_index(self)
        except Exception as exc:  # any failure to unpickle is a damaged file
            _damaged(self._index_path, exc)
            return {}

    def _load_data(self, name):
        try:
            return load_data(self, name)
        except OSError:
            raise  # numba's own handling: a data file removed under its index is a miss
        except Exception as exc:  # likewise
            _damaged(self._data_path(name), exc)
            return None

    files._load_index, files._load_data = _load_index, _load_data
    files._hcv_guarded = True
