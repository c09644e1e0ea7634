"""Formatting shared by every layer that writes numbers: JSON values and short numbers.

A leaf module (numpy only), so that the claims, the bench, the sweep and the report
format numbers the same way without importing one another.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["g", "jsonable"]


def jsonable(x):
    """Plain JSON value: NaN -> None, +-inf -> "inf"/"-inf", numpy scalars and arrays unwrapped."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return [jsonable(v) for v in x.tolist()]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        x = float(x)
        if math.isnan(x):
            return None
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return x
    if x is None or isinstance(x, str):
        return x
    return str(x)


def g(x, digits: int = 3) -> str:
    """Short number: ``g(1.2345e-13) == '1.23e-13'``; NaN/None -> '–'."""
    if x is None:
        return "–"
    if isinstance(x, str):
        return x
    x = float(x)
    if math.isnan(x):
        return "–"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e5:
        return f"{x:.0f}" if abs(x) >= 10**digits else f"{x:.{digits}g}"
    mant, exp = f"{x:.{max(digits - 1, 0)}e}".split("e")
    if "." in mant:
        mant = mant.rstrip("0").rstrip(".")
    return f"{mant}e{int(exp)}"
