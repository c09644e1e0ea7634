"""The outcome of one critical-step search (`DtCritResult`) and its JSON form.

Built by `reference_impl.stability.search.search_scene` (which re-exports it); the failure
kinds are described in `reference_impl.stability.search`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

__all__ = ["DtCritResult"]


@dataclass
class DtCritResult:
    """Outcome of one critical-step search (one speed, one scene kind).

    Attributes
    ----------
    v0 : float
        Impact speed (m/s).
    kind : str
        Scene kind.
    dt_safe : float
        Section 6 bound, supremum over [0, q_max] (s); 0 when the supremum is infinite.
    dt_safe_shortcut : float
        Endpoint shortcut 2 m v0 / U'(q_max) (s).
    dt_crit : float
        Smallest failing step found (s): a runaway for the sustained scenes, the
        accuracy threshold for the single impact; inf when none failed up to the
        search limit.
    ratio : float
        dt_crit / dt_safe (inf when dt_safe = 0 or dt_crit = inf).
    criterion : str
        What counted as a failure (the rule used, see the module docstring).
    holds : bool
        False only for a runaway strictly below dt_safe (dt_crit < dt_safe with
        failure_kind "runaway"); bounded excursions and impact accuracy failures
        never make it False; vacuously True when dt_safe = 0 (see `degenerate`).
    counterexample : dict or None
        When dt_crit < dt_safe (a runaway, or an impact accuracy failure): the
        failing step and its energy history.
    dt_stable : float
        Largest stable step tried below dt_crit (s); the bracket is [dt_stable, dt_crit].
    dt_crit_onset : float or None
        Impact only: dt_crit with the onset exactly at a step boundary (phase 0).
    q_max : float
        Turning point (m).
    geometry : str
        Geometry class of section 6 on (0, q_max].
    degenerate : bool
        dt_safe = 0 (sup U'/sqrt(2U) infinite at q -> 0, e.g. p < 1): no usable step.
    dt_tangent : float
        2 sqrt(m / max_[0, q_max] U'') (s), the linearised limit at the stiffest point.
    recommended_dt : float
        The recommended step (s), `reference_impl.studies.dtcrit_map.recommended_step`.
    lane_steps : int
        Verlet steps integrated by the whole `search_scene` call (all lanes).
    engine : str
        "numba" or "numpy".
    failure_kind : {"runaway", "bounded", "accuracy", None}
        Kind of the failure found (module docstring): "runaway" when dt_crit is
        a confirmed runaway, "bounded" when only bounded excursions were found,
        "accuracy" for an impact's rebound-energy threshold, None when nothing
        failed in the search range.
    dt_bounded : float
        Sustained scenes: smallest step with a bounded excursion below dt_crit
        (s); inf when none (null in `to_dict`).
    bounded_E_max_over_E0 : float
        Peak E_n / E_0 of the bounded excursion at dt_bounded (NaN when none; null in `to_dict`).
    dt_accuracy : float or None
        Impact only: largest step below the first failure whose rebound energy
        gain stays within tol (s), i.e. the lower end of the bracket.
    accuracy_ratio : float or None
        Impact only: dt_accuracy / dt_safe (inf when dt_safe = 0).
    runaway_evidence : str or None
        For a runaway: "confirmed" (E_n exceeded the confirmation level),
        "domain" (q > q_sup or non-finite: the lane blew up).
    """

    v0: float
    kind: str
    dt_safe: float
    dt_safe_shortcut: float
    dt_crit: float
    ratio: float
    criterion: str
    holds: bool
    counterexample: dict | None
    dt_stable: float
    dt_crit_onset: float | None
    q_max: float
    geometry: str
    degenerate: bool
    dt_tangent: float
    recommended_dt: float = math.nan
    lane_steps: int = 0
    engine: str = ""
    failure_kind: str | None = None
    dt_bounded: float = math.inf
    bounded_E_max_over_E0: float = math.nan
    dt_accuracy: float | None = None
    accuracy_ratio: float | None = None
    runaway_evidence: str | None = None
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (inf written as the string "inf").

        Fields that only exist when a bounded excursion was seen (``dt_bounded``,
        ``bounded_E_max_over_E0``) are ``None`` (JSON null) otherwise: "no such step"
        is an absence, not an infinite or undefined number.
        """
        d = asdict(self)
        extra = d.pop("extra")
        d.update(extra)
        for key in _ABSENT_WHEN_NOT_FINITE:
            if d.get(key) is not None and not math.isfinite(d[key]):
                d[key] = None
        return _jsonable(d)


# Optional measurements whose non-finite placeholder means "not observed".
_ABSENT_WHEN_NOT_FINITE = ("dt_bounded", "bounded_E_max_over_E0")


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else ("inf" if x > 0 else "-inf" if x < 0 else "nan")
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x
