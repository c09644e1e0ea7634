"""numba's cache directory for this package: its key, and the pruning of old ones.

numba checks a cached function only against the stamp (mtime, size) of its own source file:
a compiled function that calls or inlines one of another file kept the callee's old machine
code after the callee changed (the Verlet recorder over a changed step), and a wheel with
fixed mtimes can put other code behind an unchanged stamp. `reference_impl._cache` therefore
points numba at ``numba/<numba_key()>`` of the cache: a digest of this package's version,
numba's, numpy's and Python's, and the content of `_COMPILED_SOURCES`. Any change there
selects a fresh directory; a change elsewhere does not. `prune_numba_dirs` removes the old
ones without ever following a symbolic link out of the cache.

A leaf (standard library and `reference_impl._version`): it imports neither numba nor numpy.
"""

from __future__ import annotations

import hashlib
import os
import stat
import sys
from pathlib import Path

from reference_impl._version import __version__

__all__ = ["numba_key", "prune_numba_dirs"]


# The package files numba's machine code depends on: every module that compiles code with
# numba, and every package module those import (numba freezes the module globals a compiled
# function reads, constants from other modules included, into its machine code). numba checks
# a cached function against its own file's stamp only, so a change to any of these selects
# a fresh directory instead. verification/test_cache_key.py checks the list against the
# imports (AST), so a new compiled module cannot be left out.
_COMPILED_SOURCES = (
    "_atomic.py", "_cache.py", "_expr_cache.py", "_jit.py", "_numba_dir.py", "_stored.py", "_version.py",
    "errors.py",
    "exact/_branches.py", "exact/_cap_nodes.py", "exact/_general_contact.py", "exact/_general_kernel.py", "exact/_general_rows.py", "exact/_general_step.py",
    "exact/_general_fields.py", "exact/_general_taylor.py", "exact/_law_batch.py", "exact/_law_table.py",
    "exact/_nodes.py", "exact/_one_call.py", "exact/_oneshot_cache.py", "exact/_oscillator.py",
    "exact/_power_kernel.py",
    "exact/_prepared_kernel.py", "exact/_quadrature.py", "exact/_rtol.py", "exact/_split.py",
    "exact/_strategies.py", "exact/_sums.py", "exact/_tail.py", "exact/_taylor_cap.py", "exact/_taylor_force.py", "exact/_taylor_poly.py", "exact/_taylor_scan.py", "exact/_taylor_step.py", "exact/_taylor_lanes.py", "exact/_taylor_lanes_series.py",
    "exact/_truth.py",
    "exact/_validate.py", "exact/batch.py", "exact/general_law.py", "exact/prepared.py",
    "exact/solve.py",
    "integrators/assembly_kernel.py", "integrators/verlet_expression.py",
    "integrators/verlet_kernel.py",
    "potentials/_checks.py", "potentials/_expr_budget.py", "potentials/_expr_parse.py",
    "potentials/_expr_turning.py",
    "potentials/_families.py", "potentials/_near_zero.py", "potentials/_rising.py",
    "potentials/_terms.py", "potentials/base.py", "potentials/expression.py",
    "potentials/power.py", "potentials/saturating.py",
    "exact/_route.py", "exact/_generic_law.py",
    "theory/damping.py", "theory/harmonic_map.py",
    "theory/laws/__init__.py", "theory/laws/_registry.py", "theory/laws/_value.py",
    "theory/laws/none.py", "theory/laws/universal.py", "theory/laws/linear.py",
    "theory/laws/power.py", "theory/laws/polynomial.py", "theory/laws/viscoelastic.py",
    "theory/laws/hunt_crossley.py",
)  # fmt: skip
_PACKAGE = Path(__file__).resolve().parent
# numba/<_KEY_PREFIX><hex>: the keyed directories; numba/<name>_<40 hex>: numba's own
# directories of the layout before keys (its UserProvidedCacheLocator names them so).
_KEY_PREFIX = "key-"
_HEX = frozenset("0123456789abcdef")
# Pruning keeps the most recently used few, and any used within the last hour: another
# process (another checkout, another version) may be running on it. numba makes a removed
# directory again before each save, so a process that loses its directory recompiles.
_KEEP_KEYS = 3
_KEEP_RECENT_S = 3600.0


def _source_digest(package: Path) -> str:
    """Digest of the relative path and content of each of `_COMPILED_SOURCES` in ``package``.

    The content, not the stamp (size, mtime): a wheel may carry fixed mtimes, so a file of
    the same size and mtime can hold other code. About 1 ms for the 0.4 MB read.
    """
    h = hashlib.sha256()
    for rel in _COMPILED_SOURCES:
        try:
            data = (package / rel).read_bytes()
        except OSError:
            data = b"<missing>"
        h.update(f"{rel}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()


def _versions() -> str:
    """This package's version and those of numba, numpy and Python (no import of its own).

    The package's is the source tree's `__version__`, not the installed metadata's
    (`reference_impl._version.version`, whose first call scans ``sys.path``: 18 ms): the code
    numba compiles is hashed whole anyway (`_source_digest`, ``_version.py`` included).
    """
    from importlib.metadata import version as dist_version

    parts = [f"hcv={__version__}", f"python={sys.version}"]
    for name in ("numba", "numpy"):
        module = sys.modules.get(name)
        v = getattr(module, "__version__", None)
        if v is None:  # numba was not imported (a direct call): ask its metadata
            try:
                v = dist_version(name)
            except Exception:
                v = "none"
        parts.append(f"{name}={v}")
    return "\n".join(parts)


def numba_key() -> str:
    """Name of numba's cache sub-directory for this package: a digest of the versions and
    of the compiled sources (`_source_digest`)."""
    text = f"{_versions()}\n{_source_digest(_PACKAGE)}"
    return _KEY_PREFIX + hashlib.sha256(text.encode()).hexdigest()[:24]


def _is_keyed(name: str) -> bool:
    """``key-`` and 24 hex digits: a directory `numba_key` names."""
    tail = name[len(_KEY_PREFIX) :]
    return name.startswith(_KEY_PREFIX) and len(tail) == 24 and set(tail) <= _HEX


def _is_unkeyed(name: str) -> bool:
    """``<folder>_<40 hex>``: numba's name for a folder's directory (the layout before keys)."""
    head, _, tail = name.rpartition("_")
    return bool(head) and len(tail) == 40 and set(tail) <= _HEX


def prune_numba_dirs(numba_root: Path, keep: Path, now: float | None = None) -> list[Path]:
    """Remove this cache's old numba directories; the ones removed.

    Only real directories (a symbolic link is never followed, nor removed) lying directly in
    the resolved ``numba_root``, owned by this user and named as this cache names them
    (`_is_keyed`, or `_is_unkeyed`: the layout before keys); the `_KEEP_KEYS` most recently
    used keyed ones, ``keep`` and any used within `_KEEP_RECENT_S` stay. Errors are
    ignored: another process may be pruning too.
    """
    import shutil
    import time

    if not shutil.rmtree.avoids_symlink_attacks:  # rmtree could follow a link planted in it
        return []
    now = time.time() if now is None else now
    real_root = os.path.realpath(numba_root)
    me = os.geteuid()
    keyed, old = [], []
    try:
        entries = list(os.scandir(real_root))
    except OSError:
        return []
    for entry in entries:
        try:
            st = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != me or entry.name == keep.name:
            continue
        if os.path.dirname(os.path.realpath(entry.path)) != real_root:
            continue  # not directly inside the resolved root
        if _is_keyed(entry.name):
            keyed.append((st.st_mtime, entry.path))
        elif _is_unkeyed(entry.name):
            old.append((st.st_mtime, entry.path))
    keyed.sort(reverse=True)
    candidates = keyed[max(_KEEP_KEYS - 1, 0) :] + old  # ``keep`` is one of the few kept
    removed = []
    for used, path in candidates:
        if now - used < _KEEP_RECENT_S:
            continue
        shutil.rmtree(path, ignore_errors=True)
        if not os.path.lexists(path):
            removed.append(Path(path))
    return removed
