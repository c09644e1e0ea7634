"""The critical step of a code, and of its declared scheme (textbook Verlet unless it
declares another: adapter contract item 12) with the law the code declares.

Increasing dt (in units of dt_safe, section 6) until the rebound energy exceeds
(1 + gain_tol) E_0, the run blows up or fails (`_DT_SCAN`), then bisection to the
resolution of tolerances.toml ``[dt_crit]``; each run is given a step budget of
`_DTCRIT_BUDGET` straight-line times q_max / v0.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from reference_impl.adapters.base import AdapterScene, ImplementedLaw, Scheme, Trajectory
from reference_impl.bench.measure import measure
from reference_impl.bench.scorecard._schemes import scheme_trajectory
from reference_impl.bench.worker import _one_line
from reference_impl.stability.bound import dt_safe as _dt_safe

__all__ = ["dt_crit"]

# Critical-step scan, in units of dt_safe, before bisection.
_DT_SCAN = (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0)
_DT_LOW = (0.25, 0.125, 0.0625)
# Step budget of a critical-step run: this many straight-line times q_max / v0 (as dtcrit).
_DTCRIT_BUDGET = 40.0
_EXTRA_STEPS = 64


def _stable(call, ascene: AdapterScene, dt: float, q_max: float, tol: dict) -> tuple[bool, str]:
    v0 = ascene.v0
    n = int(math.ceil(_DTCRIT_BUDGET * q_max / (v0 * dt))) + _EXTRA_STEPS
    out = call("impact", ascene.replace(dt=dt, n_steps=n))
    if not out.ok:
        return False, f"run failed: {out.error}"
    return _verdict(measure(out.value, v0), tol)


def _verdict(m: dict, tol: dict) -> tuple[bool, str]:
    if not m.get("finite", True):
        return False, "blew up (non-finite state)"
    if not m["separated"]:
        return False, m.get("reason", "did not separate")
    gain = m["energy_ratio"]
    if gain > 1.0 + tol["dt_crit"]["gain_tol"]:
        return False, f"rebound energy {gain:.4g} E_0"
    return True, ""


# The scheme of a code that declares none: the baseline the bench always used.
_VERLET = Scheme("velocity-verlet", 2.0)


def _verlet_stable(
    law: ImplementedLaw, v0: float, dt: float, q_max: float, tol: dict, scheme: Scheme = _VERLET
) -> tuple[bool, str]:
    n = int(math.ceil(_DTCRIT_BUDGET * q_max / (v0 * dt))) + _EXTRA_STEPS
    t, q, v, f = scheme_trajectory(law, scheme, v0, dt, n)
    return _verdict(measure(Trajectory(t, q, v, f), v0), tol)


def dt_crit(
    call, ascene: AdapterScene, law: ImplementedLaw, tol: dict, scheme: Scheme = _VERLET
) -> dict:
    """Critical step on the code and on its declared scheme with the same law, over dt_safe.

    ``call(method, ascene) -> Outcome`` runs the code (the scene run's adapter call);
    ``tol`` the tolerances (``[dt_crit]`` resolution and gain_tol); ``scheme`` the
    code's declared scheme, whose critical step is the baseline (a correct explicit
    Euler is unstable far below Verlet's, and is judged against its own). The result
    keeps its keys ``verlet_*`` (the JSON's) for the baseline, whichever scheme it is.
    """
    pot, m, v0 = law.potential, law.mass, ascene.v0
    try:
        safe = _dt_safe(pot, m, v0)
        q_max = pot.turning_point(0.5 * m * v0 * v0)
    except Exception as exc:  # ours, not the code's
        return {"internal": f"dt_safe of the implemented law failed: {_one_line(exc)}"}
    ref = safe.dt_safe if safe.dt_safe > 0 else safe.dt_shortcut
    res = tol["dt_crit"]["resolution"]
    out = {"dt_safe": ref}
    code = _search(lambda f: _stable(call, ascene, f * ref, q_max, tol), res)
    out.update(
        dt_crit=code["ratio"] * ref,
        ratio=code["ratio"],
        reason=code["reason"],
        runs=code["runs"],
    )
    try:
        verlet = _search(lambda f: _verlet_stable(law, v0, f * ref, q_max, tol, scheme), res)
        out.update(verlet_dt_crit=verlet["ratio"] * ref, verlet_ratio=verlet["ratio"])
        out["baseline_scheme"] = scheme.name
    except TypeError as exc:  # a damping the reference Verlet cannot run: no baseline
        out["verlet_error"] = f"textbook Verlet cannot run the declared law ({_one_line(exc)})"
    except Exception as exc:  # ours, not the code's
        out["internal"] = f"the {scheme.name} baseline with the implemented law failed: " + (
            _one_line(exc)
        )
    return out


def _search(stable: Callable[[float], tuple[bool, str]], resolution: float) -> dict:
    """Smallest unstable step, in units of dt_safe: scan `_DT_SCAN`, then bisect.

    Returns ``ratio`` (inf when every scanned step was stable), the reason of the
    deciding failure and the number of runs.
    """
    tried: dict[float, tuple[bool, str]] = {}

    def ok(f: float) -> bool:
        if f not in tried:
            tried[f] = stable(f)
        return tried[f][0]

    first_bad = next((f for f in _DT_SCAN if not ok(f)), None)
    if first_bad is None:
        return {
            "ratio": math.inf,
            "reason": f"stable up to {_DT_SCAN[-1]:g} dt_safe",
            "runs": len(tried),
        }
    below = [f for f in _DT_SCAN if f < first_bad]
    lo = below[-1] if below else 0.0
    if lo == 0.0:
        for f in _DT_LOW:
            if ok(f):
                lo = f
                break
            first_bad = f
    hi = first_bad
    while lo > 0 and hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return {"ratio": hi, "stable_ratio": lo, "reason": tried[hi][1], "runs": len(tried)}
