"""A recommended Verlet step, beyond the paper: c_kind * 2 sqrt(m / k_t).

A policy, not a study: the factors were set from the critical-step map
(`reference_impl.studies.dtcrit_map`) and the map reports the margin of each case, while
the search (`reference_impl.stability.search`) attaches the recommendation to its results.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential
from reference_impl.stability.criteria import KINDS

__all__ = ["RECOMMEND_FACTOR", "RECOMMEND_FACTOR_SINGULAR", "recommended_step", "tangent_step"]


def tangent_step(pot: Potential, m: float, q_max: float) -> float:
    """2 sqrt(m / max U'') over (0, q_max] (s): the linear Verlet limit at the stiffest point.

    Returns 0 when U'' is unbounded on the path (leading exponent < 2, e.g.
    power laws with p < 1).
    """
    if pot.leading_exponent < 2:
        return 0.0
    q = np.unique(q_max * np.concatenate([np.logspace(-12, 0, 200), np.linspace(0, 1, 801)]))
    q = np.minimum(q, pot.q_sup)
    with np.errstate(all="ignore"):
        k = pot._d2U(q)
    i = int(np.argmax(k))
    kmax = float(k[i])
    if not math.isfinite(kmax) or kmax <= 0:
        return 0.0
    if 0 < i < q.size - 1:  # interior maximum: refine between the grid neighbours
        from scipy.optimize import minimize_scalar  # here: 0.2 s to import, rarely needed

        res = minimize_scalar(
            lambda x: -float(pot._d2U(np.array([x]))[0]),
            bounds=(q[i - 1], q[i + 1]),
            method="bounded",
        )
        kmax = max(kmax, -float(res.fun))
    return 2.0 * math.sqrt(m / kmax)


# Safety factors c of the recommendation dt_rec = c * 2 sqrt(m / k_t) (see
# `recommended_step`), set from measurements with the default criteria. Smallest
# measured dt_crit / (2 sqrt(m / k_t)): sustained scenes 0.26 (sphere pushed past
# 0.735 R, random draw), 0.27 (q^2/(1+q^2) at v0 = 11 m/s); single impact 0.091
# (q^2/(1+q^2) at v0 = 13 m/s). c is that minimum divided by about 1.3 (1.7 for
# the singular impact factor below).
RECOMMEND_FACTOR = {"two-sided": 0.2, "two-walls": 0.2, "impact": 0.07}
# The same for contacts whose U'' is unbounded at onset (leading exponent < 2,
# e.g. p < 1), where k_t = U''(q_max); smallest measured ratio: 0.025 (impact,
# p = 0.5), 0.50 (two-walls, p = 0.75).
RECOMMEND_FACTOR_SINGULAR = {"two-sided": 0.2, "two-walls": 0.2, "impact": 0.015}


def recommended_step(potential: Potential, m: float, v0: float, kind: str) -> float:
    """Recommended Verlet step (s): c_kind * 2 sqrt(m / k_t), beyond the paper.

    k_t is the largest tangent stiffness U'' met on the path [0, q_max] (the
    linear Verlet limit 2 sqrt(m / k_t) at the stiffest point); when U'' is
    unbounded at onset (leading exponent < 2) it is U''(q_max); where that is
    <= 0 (a concave, softening contact such as tanh(q), log(1 + q), sqrt(q))
    there is no recommendation (NaN), never an error. The factors
    c_kind (`RECOMMEND_FACTOR`, `RECOMMEND_FACTOR_SINGULAR`) are the smallest
    measured dt_crit / (2 sqrt(m / k_t)) divided by 1.3 to 1.7;
    `reference_impl.studies.dtcrit_map.dt_crit_map` reports the margin dt_crit / dt_rec
    of every case (column recommended_ratio).

    Returns
    -------
    float
        Recommended time step (s); NaN for concave contacts (U''(q_max) <= 0 with
        U'' unbounded or non-positive on the path): outside the measured classes.
    """
    if kind not in KINDS:
        raise HCVInputError(f"scene kind must be one of {', '.join(KINDS)}; got {kind!r}")
    q_max = potential.turning_point(0.5 * m * v0 * v0, check=False)
    dt_t = tangent_step(potential, m, q_max)
    if dt_t > 0:
        return RECOMMEND_FACTOR[kind] * dt_t
    k = float(potential._d2U(np.array([q_max]))[0])
    if not (math.isfinite(k) and k > 0):
        # Concave (softening) contacts such as tanh(q), log(1 + q), sqrt(q): no
        # tangent stiffness to scale by, and none of the measured classes the
        # factors come from (the chord stiffness U'(q_max)/q_max was measured
        # unsafe: impact dt_crit / dt_rec = 0.013 to 0.5). No recommendation.
        return math.nan
    return RECOMMEND_FACTOR_SINGULAR[kind] * 2.0 * math.sqrt(m / k)
