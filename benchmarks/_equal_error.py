"""Equal error over a set of random impacts, not one scene (issue 38, goal 1).

A peer's rung (its rtol) is at equal error with ours when its WORST relative error over
every output and every impact of a set of `IMPACTS` random impacts is <= the target.
The impacts are drawn over the ranges `benchmarks.bench_exact` uses: speeds log-uniform
in 10^`LOG_V0` m/s (its batch rows' speeds); for the universal law, zeta uniform in
[0, `ZETA_MAX`] (its batch's); for a general law, its one strength parameter (c, A,
alpha; every coefficient of a polynomial) times 10^u, u uniform in `LOG_STRENGTH`, below
the calibrated strength (e = 0.8 at 1 m/s) so that slow impacts still come back out.

Truth. The 30-digit mpmath solvers take ~1 s per impact here, too slow for 1000 impacts
per row and peer, so each impact's truth is ours (`solve_impact` / `solve_law_impact`:
~1e-16 relative, far below the 1e-14 target), the *proxy*. That ours is within its own
reported bound, and how far the proxy is from the truth, is measured on the first
`MP_SUBSET` impacts of each set against the 30-digit solvers (`check_proxy`) and
recorded with the row: the peer's error against the truth is its error against the
proxy plus at most the proxy's. An impact ours refuses (e.g. a sphere pressed past its
cap) is left out of the set and counted.
"""

from __future__ import annotations

import zlib

import numpy as np

from ._peers import outputs

__all__ = [
    "IMPACTS",
    "LOG_STRENGTH",
    "LOG_V0",
    "MP_SUBSET",
    "ZETA_MAX",
    "check_proxy",
    "law_bound_ok",
    "random_impacts",
    "set_ladder",
    "universal_bound_ok",
]

IMPACTS = 1000  # impacts per row (the minimum)
MP_SUBSET = 50  # of them checked against the 30-digit truth (the minimum)
LOG_V0 = (-1.0, 1.0)  # log10 of the speed (m/s): bench_exact's batch speeds, 0.1 .. 10
ZETA_MAX = 0.85  # bench_exact's BATCH_ZETA_MAX
# log10 of a general law's strength over its calibrated one: 0.1x .. 1x (stronger laws
# at 0.1 m/s approach no return, where no peer here ends the contact).
LOG_STRENGTH = (-1.0, 0.0)
_STRENGTH_KEYS = ("c", "A", "alpha")  # the one strength parameter of each table law


def _scaled(law: dict, factor: float) -> dict:
    out = dict(law)
    for k in _STRENGTH_KEYS:
        if k in out:
            v = out[k]
            out[k] = [factor * c for c in v] if isinstance(v, (list, tuple)) else factor * v
    return out


def random_impacts(name: str, law: dict, n: int = IMPACTS) -> list[tuple[float, dict]]:
    """``n`` impacts (v0 [m/s], law) over the ranges of the module docstring; seeded by
    ``name`` (the row), so that every run draws the same set."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    v0s = 10.0 ** rng.uniform(*LOG_V0, n)
    if law.get("law") == "universal":
        zetas = rng.uniform(0.0, ZETA_MAX, n)
        return [
            (float(v), {"law": "universal", "zeta": float(z)})
            for v, z in zip(v0s, zetas, strict=True)
        ]
    f = 10.0 ** rng.uniform(*LOG_STRENGTH, n)
    return [(float(v), _scaled(law, float(g))) for v, g in zip(v0s, f, strict=True)]


def _rel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b != 0.0, np.abs(a / np.where(b != 0.0, b, 1.0) - 1.0), np.abs(a))


def check_proxy(ours: list, truth_mp, keys, bound_ok) -> dict:
    """Ours against the 30-digit truth on ``ours`` ((v0, law, solution) triples).

    Returns the largest relative error per output, and whether every reported bound held
    (``bound_ok(solution, truth)``).
    """
    worst = dict.fromkeys(keys, 0.0)
    held = True
    for v0, law, sol in ours:
        truth = truth_mp(v0, law)
        for k in keys:
            b = float(truth[k])
            err = abs(float(getattr(sol, k)) / b - 1.0) if b != 0.0 else abs(getattr(sol, k))
            worst[k] = max(worst[k], err)
        held = held and bool(bound_ok(sol, truth))
    return {
        "impacts": len(ours),
        "max_rel_error": worst,
        "proxy_max_rel_error": max(worst.values()),
        "bounds_held": held,
    }


def set_ladder(case, impacts, truths: np.ndarray, keys, target: float, rtols) -> dict | None:
    """The peer's rung at equal error over a set, or its best rung.

    Parameters
    ----------
    case : callable
        ``case(v0, law) -> call`` of `benchmarks._peers.peer_cases` (``call(rtol) -> out``;
        None where the peer does not run the law).
    impacts : list of (float, dict)
        The set (v0 [m/s], law).
    truths : ndarray, shape (len(impacts), len(keys))
        The proxy truth of each output (ours).
    keys : sequence of str
        The outputs compared (names of `benchmarks._peers.outputs`).
    target : float
        Largest relative error allowed at equal error.
    rtols : sequence of float
        The ladder.

    Returns
    -------
    dict or None
        The chosen rung (``rtol``, ``max_rel_error``: the worst over the set,
        ``mean_nfev``), ``at_equal_error``, and the whole ``ladder``; None where the
        peer does not run some impact of the set.
    """
    calls = [case(v0, law) for v0, law in impacts]
    if any(c is None for c in calls):
        return None
    got = np.empty_like(truths)
    rungs = []
    for rtol in rtols:
        nfev = 0
        failed = 0
        for i, ((v0, _law), call) in enumerate(zip(impacts, calls, strict=True)):
            out = call(rtol)
            nfev += out[7]
            if out[8] != 0.0:
                failed += 1
                got[i] = np.nan
                continue
            o = outputs(out, v0)
            for j, k in enumerate(keys):
                got[i, j] = o[k]
        err = _rel(got, truths)
        err[np.isnan(err)] = np.inf  # an output the peer did not find is no agreement
        worst = float(np.max(err)) if failed == 0 else float("inf")
        rungs.append(
            {
                "rtol": rtol,
                "max_rel_error": worst,
                "mean_nfev": nfev / len(impacts),
                "no_end": failed,
            }
        )
    ok = [r for r in rungs if r["max_rel_error"] <= target]
    if ok:
        return {**min(ok, key=lambda r: r["mean_nfev"]), "at_equal_error": True, "ladder": rungs}
    best = min(rungs, key=lambda r: r["max_rel_error"])
    return {**best, "at_equal_error": False, "ladder": rungs}


def universal_bound_ok(sol, truth) -> bool:
    """`solve_impact` within its reported bounds on both contact times (s)."""
    return bool(
        abs(sol.contact_time - float(truth["contact_time"])) <= sol.quadrature_error
        and abs(sol.contact_time_zero_force - float(truth["contact_time_zero_force"]))
        <= sol.quadrature_error_zero_force
    )


def law_bound_ok(sol, truth) -> bool:
    """`solve_law_impact` within its reported bounds on both ends' time and restitution."""
    return bool(
        abs(sol.contact_time - float(truth["contact_time"])) <= sol.error_time
        and abs(sol.restitution - float(truth["restitution"])) <= sol.error_restitution
        and abs(sol.contact_time_zero_force - float(truth["contact_time_zero_force"]))
        <= sol.error_time
        and abs(sol.restitution_zero_force - float(truth["restitution_zero_force"]))
        <= sol.error_restitution
    )
