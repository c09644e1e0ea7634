"""The code's declared scheme (default textbook velocity Verlet) with the law it declares:
the error a correct code of that scheme makes (issue 40, §1).

At the run's own step (`textbook_errors`: the allowance of every accuracy limit,
tolerances.toml ``[allowance]``), on the speed-against-error table (`textbook_order`: the
order the code is compared with, and the scheme's own extrapolated answer) and on the
two-walls run (`textbook_drift`, velocity Verlet). The schemes themselves are
`reference_impl.bench.scorecard._schemes`.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.adapters.base import AdapterScene, ImplementedLaw, Scheme, Trajectory
from reference_impl.bench.measure import (
    contact_sample_times,
    exact_tensile_on_samples,
    measure,
)
from reference_impl.bench.scorecard._errors import _Ours
from reference_impl.bench.scorecard._schemes import force_mismatch, scheme_trajectory
from reference_impl.bench.worker import _one_line
from reference_impl.scenes import Scene

__all__ = [
    "VERLET",
    "extrapolated_error",
    "table_errors",
    "textbook_drift",
    "textbook_errors",
    "textbook_order",
    "worst_table_error",
]

# Relative errors below this are round-off: left out of the convergence fit.
_ORDER_FLOOR = 1e-13

_TABLE_KEYS = ("restitution", "contact_time", "max_penetration")
# The scheme a code that declares none is judged against (what the bench always assumed).
VERLET = Scheme("velocity-verlet", 2.0)


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


def _who(scheme: Scheme) -> str:
    return (
        "textbook Verlet" if scheme.name == VERLET.name else f"the declared scheme ({scheme.name})"
    )


def textbook_errors(
    law: ImplementedLaw, ascene: AdapterScene, exact: dict, scheme: Scheme = VERLET
) -> dict:
    """Errors of the declared scheme with the implemented law, at the run's own step.

    The error a correct code of that scheme makes at the step the suite gives it
    (tolerances.toml, [allowance]): relative errors of restitution, contact time and max
    penetration against ``exact``, |E_out/E_in - 1|, the tensile peak against the exact
    law sampled at the scheme's own instants, and ``force``: its recorded force against
    the law at its recorded states (`force_mismatch`). ``{"error": reason}`` when the
    scheme cannot run the declared damping (a callable C(q) in the Verlet recorder);
    ``{"internal": ...}`` when it failed (ours). ``scheme`` names the scheme run.
    """
    v0 = ascene.v0
    who = _who(scheme)
    try:
        t, q, v, f = scheme_trajectory(law, scheme, v0, ascene.dt, ascene.n_steps)
    except TypeError as exc:  # a damping the reference Verlet cannot run
        return {"error": f"{who} cannot run the declared law ({_one_line(exc)})"}
    except Exception as exc:  # ours
        return {"internal": f"{who} with the implemented law failed: {_one_line(exc)}"}
    tr = Trajectory(t, q, v, f)
    m = measure(tr, v0)
    if not math.isfinite(exact["contact_time"]):
        # an overdamped law never returns to q = 0: only the maximum penetration has a
        # reference (the metrics of the overlap end compare "no return" with no step
        # allowance, `reference_impl.bench.scorecard.metrics`)
        got = m.get("max_penetration", math.nan)
        err = abs(got - exact["max_penetration"]) / exact["max_penetration"]
        if not math.isfinite(err):
            return {"internal": f"{who} at dt = {ascene.dt:.4g} s gave no finite max_penetration"}
        force = force_mismatch(tr, law)["error"]
        if not math.isfinite(force):
            return {"internal": f"{who} at dt = {ascene.dt:.4g} s gave no finite force"}
        return {"max_penetration": err, "force": force, "scheme": scheme.name}
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
    out["force"] = force_mismatch(tr, law)["error"]
    for k, x in list(out.items()):
        if not math.isfinite(x):
            # a correct scheme at this step did not measure it: no allowance can be derived
            return {"internal": f"{who} at dt = {ascene.dt:.4g} s gave no finite {k}"}
    out["scheme"] = scheme.name
    return out


def textbook_order(
    law: ImplementedLaw, v0: float, ex: dict, t_c: float, steps, budget, scheme=VERLET
) -> tuple[float | None, str, list]:
    """Convergence order of the declared scheme with the implemented law on the same table.

    The order a correct code of that scheme shows on this scene at these steps
    (velocity Verlet is second order, first order once a velocity-dependent dashpot is
    evaluated explicitly; heavily damped scenes are pre-asymptotic at 25-800 steps) at
    dt = t_c / n for n in ``steps``, each run given ``budget(dt, t_c)`` steps. Returns
    (order, "", points), or (None, why, []) when the scheme cannot run the declared
    law; ``points`` are (n, measured dict) of each run, for `extrapolated_error`.
    """
    pts, runs = [], []
    for n in steps:
        dt = t_c / n
        try:
            t, q, v, f = scheme_trajectory(law, scheme, v0, dt, budget(dt, t_c))
        except TypeError as exc:
            return None, f"{_who(scheme)} cannot run the declared law ({_one_line(exc)})", []
        meas = measure(Trajectory(t, q, v, f), v0)
        runs.append((n, meas))
        worst = worst_table_error(table_errors(meas, ex))
        if math.isfinite(worst) and worst > _ORDER_FLOOR:
            pts.append((dt, worst))
    if len(pts) >= 3:
        x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
        return float(np.polyfit(x, y, 1)[0]), "", runs
    return math.inf, "", runs  # at round-off: nothing left to converge


def extrapolated_error(runs: list, ex: dict, order: float) -> tuple[float, str]:
    """Relative error of the Richardson-extrapolated answer of a step-refinement study.

    From the two finest runs (n1 < n2 steps per contact, ratio r = n2 / n1), each
    quantity X of the table (restitution, contact time, max penetration; those the exact
    law defines, as `table_errors`) is extrapolated to dt -> 0 with the given order p,
    X* = X2 + (X2 - X1) / (r^p - 1), and compared with the exact answer. What remains
    is the next order's term (a correct code) or a law error that does not shrink with
    the step (a wrong one).

    Parameters
    ----------
    runs : list of (int, dict)
        (steps per contact, measured dict) of each successful run, any order.
    ex : dict
        The exact reference of the declared law.
    order : float
        p (> 0; inf: the errors are at round-off, X* = X2).

    Returns
    -------
    (float, str)
        The largest |X* - exact| / |exact| and the quantity it is of; (NaN, why) with
        fewer than two runs.
    """
    runs = sorted(runs, key=lambda r: r[0])
    if len(runs) < 2:
        return math.nan, "fewer than two runs of the step-refinement study"
    (n1, m1), (n2, m2) = runs[-2], runs[-1]
    r = n2 / n1
    returns = math.isfinite(ex["contact_time"]) and ex["restitution"] > 0
    worst, which = 0.0, ""
    for k in _TABLE_KEYS:
        if k != "max_penetration" and not returns:
            continue
        x1, x2, want = m1.get(k, math.nan), m2.get(k, math.nan), ex[k]
        star = x2 if math.isinf(order) else x2 + (x2 - x1) / (r**order - 1.0)
        err = abs(star - want) / abs(want) if math.isfinite(star) else math.inf
        if err > worst or not which:
            worst, which = err, k
    return worst, which


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
