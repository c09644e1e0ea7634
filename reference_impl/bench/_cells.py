"""How a metric's cells are written: values with units, statuses in plain text.

A leaf of the bench package, shared by the scorecard (`report`) and the side-by-side
comparison (`compare`), which therefore need not import each other's private names.
"""

from __future__ import annotations

import math

__all__: list[str] = []  # private to the bench package

# How the status "error" is shown: it is ours (the reference's), not the code's.
_OURS = "ERROR (ours)"
_PLAIN_STATUS = {"pass": "pass", "fail": "FAIL", "skip": "skip", "error": _OURS}
_UNITS = {"max_penetration": " m", "contact_time": " s", "dt_crit": " dt_safe"}


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        if not math.isfinite(v):
            return "inf" if v > 0 else ("-inf" if v < 0 else "nan")
        return f"{v:.3g}"
    return str(v)


_VALUE_DIGITS = 6


def _fmt_v(v, unit: str = "") -> str:
    s = f"{v:.{_VALUE_DIGITS}g}" if isinstance(v, float) and math.isfinite(v) else _fmt(v)
    return f"{s}{unit}" if s and unit and s not in ("nan", "inf", "-inf") else s
