"""How a metric's cells are read and written: the compared values of a metric
(`metric_columns`), values with units, statuses in plain text.

A leaf of the bench package, shared by the scorecard (`report`), the JSON report
(`_json`) and the side-by-side comparison (`compare`), which therefore need not import
each other's private names. `metric_columns` is importable from `report`.
"""

from __future__ import annotations

import math

__all__ = ["metric_columns"]  # the rest is private to the bench package

# How the status "error" is shown: it is ours (the reference's), not the code's.
_OURS = "ERROR (ours)"
_PLAIN_STATUS = {"pass": "pass", "fail": "FAIL", "skip": "skip", "error": _OURS, "n/a": "n/a"}
_UNITS = {
    "max_penetration": " m",
    "contact_time": " s",
    "contact_time_asked": " s",
    "peak_force_asked": " N",
    "dt_crit": " dt_safe",
}


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        if not math.isfinite(v):
            return "inf" if v > 0 else ("-inf" if v < 0 else "nan")
        return f"{v:.3g}"
    return str(v)


# Significant digits of measured values and references (errors keep 3): enough to see
# a restitution of 0.72925 against 0.729248.
_VALUE_DIGITS = 6


def _fmt_v(v, unit: str = "") -> str:
    s = f"{v:.{_VALUE_DIGITS}g}" if isinstance(v, float) and math.isfinite(v) else _fmt(v)
    return f"{s}{unit}" if s and unit and s not in ("nan", "inf", "-inf") else s


# Metrics whose value is a relative error of one quantity, and that quantity's key.
_RELATIVE = {
    "restitution_asked": "restitution",
    "contact_time_asked": "contact_time",
    "peak_force_asked": "max_force",
    "restitution_exact": "restitution",
    "max_penetration": "max_penetration",
    "contact_time": "contact_time",
}


def _records(result, m) -> list:
    for c in result.contexts:
        if c.variant == m.variant and c.scene == m.scene:
            return list(c.speeds)
    return []


def _worst_relative(result, m):
    """(measured, reference, v0) at the speed with the largest relative error of ``m``."""
    key = _RELATIVE[m.metric]
    worst = None
    for r in _records(result, m):
        meas = (r.measured or {}).get(key)
        if m.metric == "restitution_asked":
            ref = r.asked_e
        elif m.metric.endswith("_asked"):
            ref = (r.asked or {}).get(m.metric[: -len("_asked")])
        else:
            ref = (r.exact or {}).get(key)
        if not isinstance(meas, float) or not isinstance(ref, float) or not ref:
            continue
        err = abs(meas - ref) / abs(ref)
        if worst is None or not err <= worst[0]:
            worst = (err, meas, ref, r.v0)
    return (worst[1], worst[2], worst[3]) if worst else (None, None, None)


def metric_columns(result, m) -> dict:
    """Measured value, reference, error and tolerance of one metric, as separate fields.

    ``measured`` and ``reference`` are the compared quantities (e.g. the
    restitution and the asked restitution, at the worst speed ``v0``); ``error``
    is what the tolerance bounds when it is an error (a relative error, a spread, a
    difference); a ratio (``dt_crit``) and an order (``speed_error``) have their own
    fields ``ratio`` and ``order``, never ``error``. Delivery metrics add the split of
    their error, ``model_error`` and ``step_error``; ``verdict`` names the question a
    metric answers ("implementation" or "delivery"). Attributes ``measured`` /
    ``expected`` of the metric result are used when the metric provides them.
    """
    tol = m.tolerance
    out = {
        "measured": None,
        "reference": None,
        "error": m.value,
        "tolerance": tol,
        "v0": None,
        "unit": _UNITS.get(m.metric, ""),
        "limit": getattr(m, "limit", None),
        "rule": getattr(m, "rule", ""),
        "verdict": getattr(m, "verdict", "implementation"),
        "model_error": getattr(m, "model_error", None),
        "step_error": getattr(m, "step_error", None),
        "ratio": getattr(m, "ratio", None),
        "order": getattr(m, "order", None),
    }
    if m.metric in ("dt_crit", "speed_error"):
        out["error"] = None  # a ratio or an order: never in the error column
    if getattr(m, "rule", "") and m.status in ("pass", "fail"):
        # the metric says what it compared, at which speed, and the bound it applied
        out.update(measured=m.measured, reference=m.expected, error=m.error, v0=m.at_v0)
        return out
    if m.status not in ("pass", "fail", "error"):  # skip, n/a: nothing was compared
        out["error"] = None
        return out
    if getattr(m, "measured", None) is not None:
        out["measured"] = m.measured
        out["reference"] = getattr(m, "expected", None)
        return out
    if m.metric in _RELATIVE:
        out["measured"], out["reference"], out["v0"] = _worst_relative(result, m)
    elif m.metric == "energy_balance":
        worst = None
        for r in _records(result, m):
            ratio = (r.measured or {}).get("energy_ratio")
            if isinstance(ratio, float) and (worst is None or abs(ratio - 1) > abs(worst[0] - 1)):
                worst = (ratio, r.v0)
        if worst:
            out["measured"], out["reference"], out["v0"] = worst[0], 1.0, worst[1]
    elif m.metric == "dt_crit":
        out["measured"], out["reference"] = m.value, m.reference
        if isinstance(m.value, float) and isinstance(m.reference, float) and m.reference:
            out["ratio"] = m.value / m.reference if math.isfinite(m.reference) else math.nan
    elif m.metric == "attractive_force":
        out["measured"], out["reference"] = m.value, m.reference
        if isinstance(m.value, float) and isinstance(m.reference, float):
            out["error"] = abs(m.value - m.reference)
    else:  # spread, convergence order, energy drift: the value is what is bounded
        out["measured"], out["reference"] = m.value, m.reference
    return out
