"""The user expressions' compiled modules, kept in the compile cache (`reference_impl._cache`).

**User expressions.** numba cannot cache a function that was made at run time (a
lambdified expression has no source file). `expression_module` therefore writes the
expression's code, as sympy prints it from the validated tree (never the user's text), into
a small module file named by a key, and imports it; its functions carry
``cache=True``, so numba's disk cache applies to them and to every kernel specialised
around them (`reference_impl._jit.specialise` names each copy after the module function
it binds). The key is a digest of the canonical form (``sympy.srepr`` of the substituted
forms) and of everything the compiled code depends on: this package's version, the
versions of numba, sympy, numpy and Python, and the source of the modules whose generic
kernels are specialised around it. Files are written to a temporary name and renamed
(atomic on POSIX), so two processes writing one entry both leave a whole file. The entries
are bounded: beyond `max_bytes` (``HCV_CACHE_MAX_MB``, default 256 MB) the least recently
used ones are deleted with their numba files.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import math
import os
import sys
from functools import lru_cache
from pathlib import Path

from reference_impl._atomic import atomic_write
from reference_impl._cache import _warn_once, configure_numba_cache, expressions_dir
from reference_impl._version import version

__all__ = ["expression_module", "max_bytes", "numba_numbers", "printed_function", "record_files"]

# Default bound of the expression entries (module files and their numba files).
_DEFAULT_MAX_MB = 256


def max_bytes() -> int:
    """Bound of the expression entries in bytes (``HCV_CACHE_MAX_MB``, default 256)."""
    try:
        mb = float(os.environ.get("HCV_CACHE_MAX_MB", _DEFAULT_MAX_MB))
    except ValueError:
        mb = _DEFAULT_MAX_MB
    if not math.isfinite(mb) or mb <= 0:
        mb = _DEFAULT_MAX_MB
    return int(mb * 2**20)


# The modules whose generic kernels are specialised around an expression's functions:
# their source is part of every key (a changed kernel never meets an old entry).
_KERNEL_SOURCES = (
    "reference_impl.exact._nodes",
    "reference_impl.exact._one_call",
    "reference_impl.integrators.verlet_kernel",
    "reference_impl.integrators.verlet_expression",
    "reference_impl._jit",
    "reference_impl._cache",
    "reference_impl._expr_cache",
)


@lru_cache(maxsize=1)
def _dependencies() -> str:
    """Versions and kernel sources every compiled expression depends on, as one string."""
    import numba
    import numpy
    import sympy

    parts = [
        f"hcv={version()}",
        f"numba={numba.__version__}",
        f"sympy={sympy.__version__}",
        f"numpy={numpy.__version__}",
        f"python={sys.version}",
    ]
    for name in _KERNEL_SOURCES:
        spec = importlib.util.find_spec(name)
        origin = spec.origin if spec else None
        digest = hashlib.sha256(Path(origin).read_bytes()).hexdigest() if origin else "none"
        parts.append(f"{name}={digest}")
    return "\n".join(parts)


def _key(kind: str, canonical: str) -> str:
    text = f"{kind}\n{canonical}\n{_dependencies()}"
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _import_file(name: str, path: Path):
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def expression_module(kind: str, canonical: str, source: str):
    """The module of ``source`` (generated code), stored in the cache under its key; or None.

    Parameters
    ----------
    kind : str
        What the module holds (e.g. ``"nodes"``, ``"verlet"``): part of the key.
    canonical : str
        The canonical form of the expression (``sympy.srepr``): part of the key.
    source : str
        Python source of the module, generated from the validated sympy tree.

    Returns
    -------
    module or None
        None when the cache is unusable (the caller compiles in memory).
    """
    if not configure_numba_cache():
        return None
    key = _key(kind, canonical + "\n" + source)
    name = f"hcv_expr_{kind}_{key}"
    folder = expressions_dir()
    path = folder / f"{name}.py"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not path.is_file() or path.read_text() != source:
            atomic_write(path, source)
            _evict(folder, keep=name)
        else:
            os.utime(path)  # recently used: last to be evicted
        return _import_file(name, path)
    except OSError as exc:
        _warn_once(
            f"hcv: the compile cache {folder} cannot be written ({exc.strerror or exc}); "
            "compiling for this process only"
        )
        return None


# numba types an integer literal as int64: a larger one (a parameter such as k = 1e21
# substituted as the exact Integer 10**21, or a derivative's coefficient) fails to compile
# with "Int value is too large". Such numbers are printed as floats (`numba_numbers`).
_INT64_MAX = 2**63 - 1
# Digits of those floats: the decimal is within 1e-30 of the exact number, so Python's
# correctly rounded parse gives the nearest double (but for a fraction within 1e-30 of a
# tie between two doubles; integers below 1e30 are exact).
_FLOAT_DIGITS = 30


def numba_numbers(expr):
    """``expr`` with every integer or fraction numba cannot type (beyond int64) as a float.

    Parameters
    ----------
    expr : sympy.Basic or tuple of sympy.Basic
        A validated expression (or a tuple of them) about to be printed as math-module code.

    Returns
    -------
    sympy.Basic or tuple
        The same tree, its too-large integers and fractions replaced by sympy Floats of
        ``_FLOAT_DIGITS`` digits; unchanged (the same object) when there are none.
    """
    import sympy as sp

    if isinstance(expr, tuple):
        return tuple(numba_numbers(e) for e in expr)
    big = {
        a: sp.Float(a, _FLOAT_DIGITS)
        for a in expr.atoms(sp.Rational)
        if abs(a.p) > _INT64_MAX or a.q > _INT64_MAX
    }
    return expr.xreplace(big) if big else expr


def printed_function(q, expr, name: str) -> str | None:
    """``def name(q): return ...``: sympy's math-module print of ``expr``, or None.

    The text is what ``sympy.lambdify(q, expr, modules="math")`` compiles, renamed; None
    when it calls anything that ``from math import *`` and the builtins do not provide
    as the same object (the module could not reproduce it), or names a dummy symbol
    (a name that changes between processes would defeat the cache).
    """
    import builtins
    import inspect

    import sympy as sp

    f = sp.lambdify(q, numba_numbers(expr), modules="math")
    text = inspect.getsource(f)
    head = "def _lambdifygenerated("
    if not text.startswith(head) or "Dummy" in text:
        return None
    for used in f.__code__.co_names:
        ours = getattr(math, used, getattr(builtins, used, None))
        theirs = f.__globals__.get(used, getattr(builtins, used, None))
        same = ours is theirs or (isinstance(ours, float) and ours == theirs)
        if ours is None or not same:
            return None
    return f"def {name}(" + text[len(head) :]


def record_files(module_name: str, dispatchers) -> None:
    """Note which numba cache files belong to the entry ``module_name`` (for eviction)."""
    rows = []
    for d in dispatchers:
        cache = getattr(d, "_cache", None)
        path = getattr(cache, "_cache_path", None)
        py = getattr(d, "py_func", None)
        if path is None or py is None:
            continue
        stem = Path(py.__code__.co_filename).stem
        rows.append([str(path), f"{stem}.{py.__qualname__}-"])
    manifest = expressions_dir() / f"{module_name}.files"
    try:
        old = json.loads(manifest.read_text()) if manifest.is_file() else []
        merged = sorted({tuple(r) for r in old} | {tuple(r) for r in rows})
        atomic_write(manifest, json.dumps(merged))
    except (OSError, ValueError):
        pass  # eviction then leaves that entry's numba files (bounded by numba's own index)


def _entry_files(folder: Path, name: str) -> list[Path]:
    """The module file, its manifest and the numba files of one entry."""
    files = [folder / f"{name}.py", folder / f"{name}.files"]
    rows = []
    try:
        rows = json.loads((folder / f"{name}.files").read_text())
    except (OSError, ValueError):
        pass
    rows.append([str(_numba_dir_of(folder)), f"{name}."])
    for cache_path, prefix in rows:
        p = Path(cache_path)
        if p.is_dir():
            files.extend(f for f in p.iterdir() if f.name.startswith(prefix))
    return [f for f in files if f.exists()]


def _numba_dir_of(folder: Path) -> Path:
    """numba's cache directory for modules in ``folder`` (its UserProvidedCacheLocator rule)."""
    sub = os.path.abspath(folder)
    return Path(os.environ.get("NUMBA_CACHE_DIR", "")) / (
        os.path.split(sub)[-1] + "_" + hashlib.sha1(sub.encode()).hexdigest()
    )


def _evict(folder: Path, keep: str) -> None:
    """Delete the least recently used entries until the rest fit in `max_bytes`."""
    entries = []
    for module in folder.glob("hcv_expr_*.py"):
        name = module.stem
        if name == keep:
            continue
        files = _entry_files(folder, name)
        try:
            used = module.stat().st_mtime
            size = sum(f.stat().st_size for f in files)
        except OSError:
            continue  # another process is evicting it
        entries.append((used, size, files))
    total = sum(size for _, size, _ in entries)
    for f in _entry_files(folder, keep):
        try:
            total += f.stat().st_size
        except OSError:
            pass
    for _, size, files in sorted(entries, key=lambda e: e[0]):
        if total <= max_bytes():
            break
        for f in files:
            try:
                f.unlink()
            except OSError:
                pass
        total -= size
