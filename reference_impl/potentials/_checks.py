"""Parameter checks shared by the potential families and the solvers' public API.

One rule for numbers everywhere (issue 22): a parameter is a real number, i.e. a
Python int or float or a numpy integer or floating scalar. bool, str, complex,
containers and other types are refused with one line naming the value, and so
is an int beyond float64 range (10**400), never a raw OverflowError.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError

__all__ = ["finite", "is_real_number", "positive", "real_array", "show"]

# Characters of a refused value quoted in a message (10**400 has 401 digits).
_QUOTE_CHARS = 60


def show(value) -> str:
    """repr(value), cut to _QUOTE_CHARS characters."""
    r = repr(value)
    return r if len(r) <= _QUOTE_CHARS else r[: _QUOTE_CHARS - 3] + "..."


def is_real_number(value) -> bool:
    """True for a Python int or float or a numpy integer or floating scalar (not bool)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def finite(name: str, value, owner: str) -> float:
    """Return ``value`` as float, or raise naming it when it is not a finite real."""
    if type(value) is float and math.isfinite(value):  # the common case, without the checks
        return value
    if not is_real_number(value):
        raise HCVInputError(
            f"{owner}: parameter {name} must be a real number (int or float; bool, str, complex "
            f"and containers are refused), got {show(value)} of type {type(value).__name__}"
        )
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    if not math.isfinite(v):
        raise HCVInputError(
            f"{owner}: parameter {name} must be a finite real number within float64 range, "
            f"got {show(value)}"
        )
    return v


def positive(name: str, value, owner: str) -> float:
    """Return ``value`` as float, or raise naming it when it is not finite and > 0."""
    v = finite(name, value, owner)
    if v <= 0:
        raise HCVInputError(f"{owner}: parameter {name} must be > 0, got {show(value)}")
    return v


def real_array(name: str, values, owner: str) -> np.ndarray:
    """``values`` as a float64 array, or raise naming them when they are not an array of
    real numbers (ragged nesting, complex, dict, str, bool or object entries)."""
    try:
        arr = np.asarray(values)
    except (ValueError, TypeError) as exc:  # ragged nesting
        raise HCVInputError(
            f"{owner}: {name} must be an array of real numbers, got {show(values)} ({exc})"
        ) from None
    if arr.dtype.kind not in "iuf":
        ok = arr.dtype.kind == "O" and all(is_real_number(v) for v in arr.ravel())
        if not ok:
            bad = next((v for v in arr.ravel() if not is_real_number(v)), values)
            raise HCVInputError(
                f"{owner}: {name} must be an array of real numbers (bool, str, complex and "
                f"containers are refused), got {show(bad)} in {show(values)}"
            )
    try:
        out = arr.astype(float)
    except OverflowError:
        out = np.array([finite(name, v, owner) for v in arr.ravel()]).reshape(arr.shape)
    return out
