"""Parameter checks shared by the potential families."""

from __future__ import annotations

import math

from reference_impl.errors import HCVInputError

__all__ = ["positive", "finite"]


def finite(name: str, value, owner: str) -> float:
    """Return ``value`` as float, or raise naming it when it is not a finite real."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise HCVInputError(
            f"{owner}: parameter {name} must be a real number, got {value!r}"
        ) from None
    if isinstance(value, bool) or not math.isfinite(v):
        raise HCVInputError(
            f"{owner}: parameter {name} must be a finite real number, got {value!r}"
        )
    return v


def positive(name: str, value, owner: str) -> float:
    """Return ``value`` as float, or raise naming it when it is not finite and > 0."""
    v = finite(name, value, owner)
    if v <= 0:
        raise HCVInputError(f"{owner}: parameter {name} must be > 0, got {value!r}")
    return v
