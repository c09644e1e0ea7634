"""Small tables computed once per machine and kept beside the compile cache.

A quadrature rule (the Gauss-Jacobi nodes and weights of a power law) costs ~1 ms to
compute, but computing it needs ``scipy.special``, whose import costs ~0.1 s: more than the
rest of a one-scene ``hcv solve`` outside numba (issue 20). `stored_floats` keeps such a
table in ``<cache_dir>/tables/``, so a new process reads it back instead.

**Exactness.** Values are stored as ``float.hex`` strings: a table read back is bit for bit
the one computed, so a result never depends on whether its table came from the disk.

**Key.** The table's kind and arguments, the bytecode and constants of the function that
computes it (a changed formula never meets an old entry), and the digest of every file
the caller names inside an installed package (e.g. scipy's ``version.py``: a scipy upgrade
computes afresh), read without importing the package.

**Checked.** The cache is input: an entry carries the sha256 of its name and values, and
one whose values do not match it (edited by hand, damaged, truncated, of the wrong length)
is never used: the table is computed afresh, rewritten, and one `CacheWarning` names the
file (issue 29: Gauss-Jacobi weights scaled by 1.001 moved t_c by 1e-3 under a reported
error of 5e-19). The checksum catches accidents and edits, not an adversary who can write
the cache (who could recompute it; see the cache's ownership rules in `reference_impl._cache`).

**Degrading.** An unusable cache directory (`reference_impl._cache.configure_numba_cache`
decides, and warns once) means the table is computed in this process; an entry that
cannot be written is simply not kept. Nothing here raises for the cache's sake.

**Bounded.** At most `MAX_ENTRIES` tables (a few kB each) are kept; beyond that the least
recently used are deleted.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import math
import os
import warnings
from collections.abc import Callable, Sequence
from functools import lru_cache
from pathlib import Path

from reference_impl._atomic import atomic_write
from reference_impl._cache import CacheWarning, cache_dir, configure_numba_cache

__all__ = ["MAX_ENTRIES", "stored_floats", "tables_dir"]

# Entries kept: a Gauss-Jacobi pair is ~3 kB, so 4096 entries stay below ~15 MB; a sweep
# over thousands of exponents evicts its oldest rules rather than growing without bound.
MAX_ENTRIES = 4096


def tables_dir() -> Path:
    """Directory of the stored tables (``<cache_dir>/tables``)."""
    return cache_dir() / "tables"


@lru_cache(maxsize=16)
def _file_digest(package: str, relative: str) -> str:
    """sha256 of a file inside a top-level package ('none' if absent).

    Located by ``find_spec`` of the top-level name, which does not import it (a
    sub-module's spec would: ``import scipy`` alone costs 20 ms).
    """
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        spec = None
    origin = getattr(spec, "origin", None)
    try:
        path = Path(origin).parent / relative
        return hashlib.sha256(path.read_bytes()).hexdigest() if origin else "none"
    except OSError:
        return "none"


def _key(kind: str, args: tuple, compute: Callable, files: Sequence[tuple[str, str]]) -> str:
    code = compute.__code__
    parts = [kind, repr(args), code.co_code.hex(), repr(code.co_consts)]
    parts += [f"{pkg}/{rel}={_file_digest(pkg, rel)}" for pkg, rel in files]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:32]


# Longest text an entry of n values can be: '"-0x1.fffffffffffffp+1023", ' is 28 characters,
# plus the keys and the 64-digit checksum.
_BYTES_PER_VALUE = 28
_ENTRY_OVERHEAD = 128
# Entries already warned about in this process (one warning per damaged entry).
_warned: set[str] = set()


def _checksum(path: Path, hexes: list[str]) -> str:
    """sha256 of the entry's name and values: an entry moved or edited no longer matches."""
    return hashlib.sha256((path.name + "\n" + json.dumps(hexes)).encode()).hexdigest()


def _read(path: Path, count: int) -> list[float] | None:
    """The entry's values; None (computed afresh) when absent, damaged or edited."""
    limit = _BYTES_PER_VALUE * count + _ENTRY_OVERHEAD
    try:
        with path.open("rb") as fh:
            # Read no more than such an entry can hold: a large file planted in the cache
            # is not ours and must not cost its size in memory.
            raw = fh.read(limit + 1)
    except OSError:
        return None  # absent, or the store cannot be read (not a directory, no permission)
    try:
        if len(raw) > limit:
            raise ValueError("longer than such an entry")
        data = json.loads(raw.decode("utf-8"))
        if isinstance(data, list):
            return None  # an entry of the format before checksums: rewritten, no warning
        hexes = data["v"]
        if not isinstance(hexes, list) or data.get("sha256") != _checksum(path, hexes):
            raise ValueError("its values do not match its checksum")
        values = [float.fromhex(v) for v in hexes]
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        return _bad(path, str(exc)[:80] or type(exc).__name__)
    if len(values) != count or not all(math.isfinite(v) for v in values):
        return _bad(path, f"it does not hold {count} finite values")
    return values


def _bad(path: Path, why: str) -> None:
    """One `CacheWarning` per damaged entry and process; the caller computes afresh."""
    if str(path) not in _warned:
        _warned.add(str(path))
        warnings.warn(
            f"hcv: the stored table {path} is damaged or was edited ({why}); "
            "it is computed afresh and rewritten",
            CacheWarning,
            stacklevel=4,
        )
    return None


def _evict(folder: Path, keep: Path) -> None:
    try:
        entries = [p for p in folder.glob("*.json") if p != keep]
        if len(entries) < MAX_ENTRIES:
            return
        stamped = []
        for p in entries:
            try:
                stamped.append((p.stat().st_mtime, p))
            except OSError:
                pass  # another process removed it
        for _, p in sorted(stamped)[: len(stamped) - MAX_ENTRIES + 1]:
            p.unlink(missing_ok=True)
    except OSError:
        pass


def stored_floats(
    kind: str,
    args: tuple,
    compute: Callable[..., Sequence[float]],
    count: int,
    files: Sequence[tuple[str, str]] = (),
) -> list[float]:
    """``compute(*args)`` as a list of ``count`` finite floats, stored on disk once computed.

    Parameters
    ----------
    kind : str
        Name of the table (part of the key and of the file name).
    args : tuple
        Arguments of ``compute``; their ``repr`` is part of the key (use exact values,
        e.g. floats, not their rounded text).
    compute : callable
        Module-level function returning ``count`` finite floats; its bytecode and
        constants are part of the key.
    count : int
        Number of values; an entry holding another number is ignored and rewritten.
    files : sequence of (str, str)
        Files ``compute`` depends on, as (top-level package, path inside it), e.g.
        ``("scipy", "version.py")``.

    Returns
    -------
    list of float
        The values, bit for bit those ``compute(*args)`` returns.
    """
    path = None
    if configure_numba_cache():
        path = tables_dir() / f"{kind}-{_key(kind, args, compute, files)}.json"
        values = _read(path, count)
        if values is not None:
            try:
                os.utime(path)  # recently used: last to be evicted
            except OSError:
                pass
            return values
    values = [float(v) for v in compute(*args)]
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{kind}{args!r}: expected {count} finite values, got {values!r}")
    if path is not None:
        try:
            hexes = [v.hex() for v in values]
            atomic_write(path, json.dumps({"v": hexes, "sha256": _checksum(path, hexes)}))
            _evict(path.parent, keep=path)
        except OSError:
            pass  # read-only or full: the table is used for this process only
    return values
