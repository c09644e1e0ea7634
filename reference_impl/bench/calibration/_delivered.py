"""What one calibration run delivers: the restitution the search reads at an end
(`quantity`) and, at the value found, the measured quantities against the declared law and
the scene as asked (`run_metrics`). Split from `calibrate` (the search) as its own subject.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters.base import ImplementedLaw
from reference_impl.bench.measure import _restitution_zero_force, exact_reference, measure
from reference_impl.exact.solve import solve_impact

__all__ = ["quantity", "run_metrics"]


def quantity(tr, v0: float, end: str) -> tuple[float, bool]:
    """(restitution at ``end``, read): NaN for a run that blew up or never touched;
    ``read`` is False for a run without rebound counted as 0.

    A run that stays finite and in contact for its whole budget (the body has not come
    back out after `calibrate._BUDGET` contact times: overdamped, or a rebound so late that its
    speed is negligible) did not rebound: its restitution counts as 0, at the overlap
    end and, when the force never vanished after the deepest overlap, at the zero-force
    end too (where it did, that end is read there as for any run).
    """

    meas = measure(tr, v0)
    key = "restitution" if end == "overlap" else "restitution_zero_force"
    val = meas.get(key)
    if isinstance(val, float) and math.isfinite(val):
        return val, True
    if meas.get("separated") or not meas.get("finite") or "max_penetration" not in meas:
        return math.nan, True  # blown up, never in contact, or an unreadable force
    if end == "zero-force":
        q, f = tr.q, tr.force
        last = q.size - 1
        peak = int(np.argmax(q))
        if last > peak and np.all(np.isfinite(f[peak:last])) and np.any(f[peak:last] <= 0):
            return _restitution_zero_force(q, tr.v, f, last, v0), True
    return 0.0, False


def run_metrics(tr, law: ImplementedLaw | None, scene, v0: float) -> dict:
    """Measured quantities at the calibrated value, against the declared law and the scene."""

    meas = measure(tr, v0)
    keys = ("restitution", "restitution_zero_force", "contact_time", "max_penetration")
    out: dict = {"measured": {k: meas.get(k) for k in keys}}
    if law is not None:
        ex = exact_reference(law, v0)
        # clipped laws: exact_reference's restitution is already the zero-force end
        ex_q0 = ex["restitution"]
        out["declared_law"] = {
            "description": law.description,
            "restitution": ex_q0,
            "restitution_zero_force": ex.get("restitution_zero_force"),
            "contact_time": ex["contact_time"],
            "max_penetration": ex["max_penetration"],
        }
    # the scene's own law, whatever it is (the harmonic map, the general-law solver)
    sol = solve_impact(scene.potential, scene.mass, v0, law=scene.law)
    out["scene_as_asked"] = {
        "restitution": sol.restitution,
        "restitution_zero_force": sol.restitution_zero_force,
        "contact_time": sol.contact_time,
        "max_penetration": sol.max_penetration,
    }
    for ref in ("declared_law", "scene_as_asked"):
        if ref not in out:
            continue
        errs = {}
        for k in keys:
            got, want = out["measured"].get(k), out[ref].get(k)
            if isinstance(got, float) and isinstance(want, float) and want:
                errs[k] = abs(got - want) / abs(want)
        out[f"error_vs_{ref}"] = errs
    return out
