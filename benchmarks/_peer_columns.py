"""Every peer's column of one `benchmarks.bench_exact` row, at equal error over a set (issue 38).

For a row (a potential, mass, speed and law, scored against its 30-digit truth), each peer
of `benchmarks._peers` that runs it gets its rung by `benchmarks._equal_error.set_ladder`
over the row's random set (truth: ours, checked on a subset against mpmath), and its
error on the row's own scene at that rung against the 30-digit truth. The calls at the
chosen rungs are returned for the timing.
"""

from __future__ import annotations

import numpy as np

from ._equal_error import (
    IMPACTS,
    LOG_STRENGTH,
    LOG_V0,
    MP_SUBSET,
    ZETA_MAX,
    check_proxy,
    random_impacts,
    set_ladder,
)
from ._peers import PEER_LABELS, outputs, peer_cases

__all__ = ["fastest", "peer_columns", "set_ok"]


def _scene_error(out, v0, truth: dict, keys) -> float:
    if out[8] != 0.0:
        return float("inf")
    got = outputs(out, v0)
    worst = 0.0
    for k in keys:
        b = float(truth[k])
        err = abs(float(got[k]) / b - 1.0) if b != 0.0 else abs(float(got[k]))
        worst = max(worst, err if err == err else float("inf"))  # NaN: not found
    return worst


def peer_columns(
    row: str,
    pot,
    m: float,
    v0: float,
    law: dict,
    truth: dict,
    keys,
    target: float,
    *,
    ours,
    truth_mp,
    bound_ok,
    rtols,
    impacts: int = IMPACTS,
    mp_subset: int = MP_SUBSET,
) -> tuple[dict, dict, dict]:
    """The peers' columns of a row.

    Parameters
    ----------
    row : str
        The row's name (seeds its random set).
    pot, m, v0, law
        The row's scene: potential, mass (kg), speed (m/s), damping law table.
    truth : dict
        The scene's 30-digit truth by output name.
    keys : sequence of str
        The outputs compared.
    target : float
        The equal-error target (largest relative error).
    ours : callable
        ``ours(v0, law) -> solution`` (the truth proxy of the set).
    truth_mp : callable
        ``truth_mp(v0, law) -> dict`` (the 30-digit truth of the subset).
    bound_ok : callable
        ``bound_ok(solution, truth) -> bool``: ours within its reported bounds.
    rtols : sequence of float
        Each peer's tolerance ladder.
    impacts, mp_subset : int
        Size of the set and of its subset checked against mpmath.

    Returns
    -------
    columns : dict
        ``{peer: {label, rtol, max_rel_error (worst over the set), mean_nfev,
        at_equal_error, ladder, scene_max_rel_error, scene_nfev}}``.
    calls : dict
        ``{peer: zero-argument call at its rung on the scene}`` (for the timing).
    equal_error_set : dict
        What the set was: its size, the impacts ours refused, the ranges, and the check
        of the proxy against mpmath (`benchmarks._equal_error.check_proxy`).
    """
    kept, sols, refused = [], [], 0
    for v, lw in random_impacts(row, law, impacts):
        try:
            sols.append(ours(v, lw))
        except (ValueError, ArithmeticError):  # HCVInputError is a ValueError
            refused += 1
            continue
        kept.append((v, lw))
    truths = np.array([[float(getattr(s, k)) for k in keys] for s in sols])
    subset = [(v, lw, s) for (v, lw), s in zip(kept[:mp_subset], sols[:mp_subset], strict=True)]
    proxy = check_proxy(subset, truth_mp, keys, bound_ok)
    columns, calls = {}, {}
    for name, case in peer_cases(pot, m).items():
        lad = set_ladder(case, kept, truths, keys, target, rtols)
        call = case(v0, law)
        if lad is None or call is None:
            continue
        out = call(lad["rtol"])
        columns[name] = {
            "label": PEER_LABELS[name],
            **lad,
            "scene_max_rel_error": _scene_error(out, v0, truth, keys),
            "scene_nfev": int(out[7]),
        }
        calls[name] = lambda call=call, rtol=lad["rtol"]: call(rtol)
    info = {
        "impacts": len(kept),
        "refused_by_ours": refused,
        "log10_v0_range": list(LOG_V0),
        "zeta_max": ZETA_MAX if law.get("law") == "universal" else None,
        "log10_strength_range": None if law.get("law") == "universal" else list(LOG_STRENGTH),
        "truth": "ours (the proxy); checked against the 30-digit truth on a subset",
        "proxy_check": proxy,
        "standard_met": bool(len(kept) >= IMPACTS and proxy["impacts"] >= MP_SUBSET),
    }
    return columns, calls, info


def set_ok(eqset: dict) -> bool:
    """The set met the issue's standard and ours stayed within its bounds on the subset."""
    return bool(eqset["standard_met"] and eqset["proxy_check"]["bounds_held"])


def fastest(cols: dict, t: dict) -> dict:
    """The row's peer fields: every peer's column (``peers``, with its time), and the ratio's
    denominator, the fastest peer at equal error over the set (when none gets there, the
    one with the smallest worst error over the set, marked ``peer_at_equal_error`` False).
    ``peer_max_rel_error`` is its error on the row's own scene against the 30-digit truth;
    ``peer_set_max_rel_error`` its worst over the set."""
    peers = {k: {**c, "us": t[f"peer:{k}"] * 1e6} for k, c in cols.items()}
    ok = [k for k in peers if peers[k]["at_equal_error"]]
    if ok:
        pick = min(ok, key=lambda k: peers[k]["us"])
    else:  # none at equal error: the most accurate (a fast but inaccurate one is no peer)
        pick = min(peers, key=lambda k: (peers[k]["max_rel_error"], peers[k]["us"]))
    p = peers[pick]
    return {
        "peer": p["label"],
        "peer_name": pick,
        "peer_us": p["us"],
        "peer_rtol": p["rtol"],
        "peer_max_rel_error": p["scene_max_rel_error"],
        "peer_set_max_rel_error": p["max_rel_error"],
        "peer_nfev": p["scene_nfev"],
        "peer_at_equal_error": p["at_equal_error"],
        "peer_ladder": p["ladder"],
        "peers": peers,
    }
