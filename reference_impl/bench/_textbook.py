"""Textbook velocity Verlet with the law a code declares: the error a correct code makes.

At the run's own step (`textbook_errors`: the allowance of every accuracy limit,
tolerances.toml ``[allowance]``), on the speed-against-error table (`textbook_order`: the
order the code is compared with) and on the two-walls run (`textbook_drift`).
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters.base import AdapterScene, ImplementedLaw, Trajectory
from reference_impl.bench._errors import _Ours
from reference_impl.bench.measure import (
    contact_sample_times,
    exact_tensile_on_samples,
    measure,
)
from reference_impl.bench.worker import _one_line
from reference_impl.scenes import Scene

__all__ = [
    "table_errors",
    "textbook_drift",
    "textbook_errors",
    "textbook_order",
    "worst_table_error",
]

# Relative errors below this are round-off: left out of the convergence fit.
_ORDER_FLOOR = 1e-13

_TABLE_KEYS = ("restitution", "contact_time", "max_penetration")


def table_errors(meas: dict, ex: dict) -> dict:
    """Relative errors of one run against the exact reference: ``err_<quantity>``.

    The restitution and contact time are compared only when the exact law returns to
    q = 0 (finite contact time, e > 0); an overdamped law never does (e = 0, contact
    time inf: no relative error exists), and its rows compare the maximum penetration
    only, the others NaN (not compared). A quantity the run did not deliver is inf.
    """
    returns = math.isfinite(ex["contact_time"]) and ex["restitution"] > 0
    errs = {}
    for k in _TABLE_KEYS:
        if k != "max_penetration" and not returns:
            errs[f"err_{k}"] = math.nan
            continue
        got, want = meas.get(k, math.nan), ex[k]
        errs[f"err_{k}"] = abs(got - want) / abs(want) if math.isfinite(got) else math.inf
    return errs


def worst_table_error(errs: dict) -> float:
    """The largest of the compared ``err_*`` (NaN: not compared)."""
    vals = [v for v in errs.values() if not math.isnan(v)]
    return max(vals) if vals else math.nan


def textbook_errors(law: ImplementedLaw, ascene: AdapterScene, exact: dict) -> dict:
    """Errors of textbook velocity Verlet with the implemented law, at the run's own step.

    The error a correct code makes at the step the suite gives it (tolerances.toml,
    [allowance]): relative errors of restitution, contact time and max penetration
    against ``exact``, |E_out/E_in - 1|, and the tensile peak against the exact law
    sampled at Verlet's own instants. ``{"error": reason}`` when the reference
    Verlet cannot run the declared damping (a callable C(q)); ``{"internal": ...}``
    when it failed (ours).
    """
    from reference_impl.adapters.reference import law_trajectory

    v0 = ascene.v0
    try:
        t, q, v, f = law_trajectory(law, v0, ascene.dt, ascene.n_steps)
    except TypeError as exc:  # a damping the reference Verlet cannot run
        return {"error": f"textbook Verlet cannot run the declared law ({_one_line(exc)})"}
    except Exception as exc:  # ours
        return {"internal": f"textbook Verlet with the implemented law failed: {_one_line(exc)}"}
    tr = Trajectory(t, q, v, f)
    m = measure(tr, v0)
    if not math.isfinite(exact["contact_time"]):
        # an overdamped law never returns to q = 0: only the maximum penetration has a
        # reference (the metrics of the overlap end compare "no return" with no step
        # allowance, `reference_impl.bench.metrics`)
        got = m.get("max_penetration", math.nan)
        err = abs(got - exact["max_penetration"]) / exact["max_penetration"]
        if not math.isfinite(err):
            return {
                "internal": f"textbook Verlet at dt = {ascene.dt:.4g} s gave no finite "
                "max_penetration"
            }
        return {"max_penetration": err}
    out: dict = {"restitution_value": m.get("restitution", math.nan)}
    for k in ("restitution", "contact_time", "max_penetration"):
        got, want = m.get(k, math.nan), exact[k]
        out[k] = abs(got - want) / abs(want) if want else math.inf
    out["energy_ratio"] = abs(m.get("energy_ratio", math.nan) - 1.0)
    try:
        ref = exact_tensile_on_samples(law, v0, exact["contact_time"], contact_sample_times(tr, m))
    except Exception as exc:  # ours
        return {"internal": f"exact tensile peak on textbook Verlet's samples: {_one_line(exc)}"}
    out["tensile"] = abs(m.get("tensile", math.nan) - ref)
    for k, x in list(out.items()):
        if not math.isfinite(x):
            # a correct scheme at this step did not measure it: no allowance can be derived
            return {"internal": f"textbook Verlet at dt = {ascene.dt:.4g} s gave no finite {k}"}
    return out


def textbook_order(
    law: ImplementedLaw, v0: float, ex: dict, t_c: float, steps, budget
) -> tuple[float | None, str]:
    """Convergence order of textbook Verlet with the implemented law on the same table.

    The order a correct code shows on this scene at these steps (velocity Verlet is
    second order, first order once a velocity-dependent dashpot is evaluated
    explicitly; heavily damped scenes are pre-asymptotic at 25-800 steps) at
    dt = t_c / n for n in ``steps``, each run given ``budget(dt, t_c)`` steps. Returns
    (order, ""), or (None, why) when textbook Verlet cannot run the declared law.
    """
    from reference_impl.adapters.reference import law_trajectory

    pts = []
    for n in steps:
        dt = t_c / n
        try:
            t, q, v, f = law_trajectory(law, v0, dt, budget(dt, t_c))
        except TypeError as exc:
            return None, f"textbook Verlet cannot run the declared law ({_one_line(exc)})"
        meas = measure(Trajectory(t, q, v, f), v0)
        worst = worst_table_error(table_errors(meas, ex))
        if math.isfinite(worst) and worst > _ORDER_FLOOR:
            pts.append((dt, worst))
    if len(pts) >= 3:
        x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
        return float(np.polyfit(x, y, 1)[0]), ""
    return math.inf, ""  # at round-off: nothing left to converge


def textbook_drift(sc: Scene, v0: float, dt: float, n: int) -> float:
    """Energy drift of textbook Verlet on the same two-walls run (the allowance's scale).

    Raises `_Ours` when it cannot be run (our reference, never the code's failure).
    """
    from reference_impl.adapters.reference import verlet_trajectory

    try:
        t, q, v, f = verlet_trajectory(
            sc.potential,
            sc.mass,
            v0,
            dt,
            n,
            zeta=sc.zeta or 0.0,
            kind="two-walls",
            gap=float(sc.gap or 0.0),
        )
        with np.errstate(all="ignore"):
            E = 0.5 * sc.mass * v**2 + sc.potential._U(np.clip(q, 0.0, None))
    except Exception as exc:  # ours
        raise _Ours(f"textbook Verlet on the two-walls scene: {_one_line(exc)}") from None
    E0 = 0.5 * sc.mass * v0 * v0
    return float(np.max(np.abs(E / E0 - 1.0))) if np.all(np.isfinite(E)) else math.inf
