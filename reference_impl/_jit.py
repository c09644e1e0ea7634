"""Compiled copies of generic numba functions, each with its own name in numba's disk cache.

The node loops, whole-impact kernels and Verlet lanes are written once, generic in the
compiled functions they call (``_EV``, ``_NODES``, ``_force_energy``, ...), and compiled per
callee. A function argument or a closure would do the same, but numba then cannot cache the
result on disk (it keys closures by captured objects that change in every process, and
refuses functions passed as values); a copy bound through its globals caches like any module
function.

numba's cache index is named after the function's module and qualified name and checked
against its source file, not its globals. Two copies of one function bound to different
callees would therefore share one index and could load each other's machine code.
`specialise` gives every copy a qualified name that spells its bindings, and refuses to cache
a copy whose bindings have no stable name of their own (e.g. two lambdified expressions both
called ``_lambdifygenerated``).
"""

from __future__ import annotations

import hashlib
import types

import numba

__all__ = ["binding_name", "rebind", "specialise"]


def _stable_name(value) -> str | None:
    """Module-qualified name of a compiled or plain module-level function, else None."""
    fn = getattr(value, "py_func", value)
    qual = getattr(fn, "__qualname__", None)
    mod = getattr(fn, "__module__", None)
    if not (isinstance(qual, str) and isinstance(mod, str)) or "<" in qual:
        return None  # closures and lambdas: no name that is the same in every process
    if qual.startswith("_lambdifygenerated"):
        return None
    return f"{mod}.{qual}"


def binding_name(func, bound: dict) -> str:
    """The qualified name of ``func`` specialised to ``bound`` (sorted by global name)."""
    parts = []
    for key in sorted(bound):
        name = _stable_name(bound[key]) or f"id{id(bound[key]):x}"
        parts.append(f"{key}={name.replace('.', '_')}")
    # A digest, not the names themselves: nested bindings would outgrow a file name (255 bytes).
    digest = hashlib.sha256(",".join(parts).encode()).hexdigest()[:16]
    return f"{func.__qualname__}__{digest}"


def specialise(func, cache: bool, *, error_model: str = "numpy", inline: str = "never", **bound):
    """A numba-compiled copy of the plain function ``func`` with globals ``bound`` rebound.

    Parameters
    ----------
    func : function
        A plain (not yet compiled) module-level function.
    cache : bool
        Cache the compiled copy on disk. Allowed only when every bound value has a stable
        module-qualified name, which then becomes part of the copy's qualified name (so two
        bindings never share a cache entry).
    error_model : str
        numba's error model of the copy ("numpy": inf/nan; "python": exceptions).
    inline : str
        numba's ``inline`` option of the copy ("always": inlined into its callers' IR).
    **bound
        Global names of ``func`` and the compiled functions they stand for in this copy.

    Raises
    ------
    ValueError
        ``cache=True`` with a binding that has no stable name.
    """
    if cache:
        anonymous = sorted(k for k, v in bound.items() if _stable_name(v) is None)
        if anonymous:
            raise ValueError(
                f"specialise({func.__qualname__}): cannot cache a copy bound to unnamed "
                f"functions ({', '.join(anonymous)}); their machine code would share one "
                "cache entry. Pass cache=False."
            )
    glb = dict(func.__globals__)
    glb.update(bound)
    f = types.FunctionType(func.__code__, glb, func.__name__, func.__defaults__)
    f.__qualname__ = binding_name(func, bound)
    f.__module__, f.__doc__ = func.__module__, func.__doc__
    return numba.njit(cache=cache, error_model=error_model, inline=inline)(f)


def rebind(func, **bound):
    """A plain Python copy of ``func`` with globals ``bound`` rebound (no compile).

    The Python binding of a numba-compatible function written once: e.g. the Verlet
    step around a `Potential`'s own force. ``func`` is the plain function (a numba
    dispatcher's ``py_func``); the copy keeps its name, qualified name and defaults.
    """
    glb = dict(func.__globals__)
    glb.update(bound)
    f = types.FunctionType(func.__code__, glb, func.__name__, func.__defaults__)
    f.__qualname__, f.__module__, f.__doc__ = func.__qualname__, func.__module__, func.__doc__
    return f
