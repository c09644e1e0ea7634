"""The map of measured Delta t_crit / Delta t_safe (report data) and the recommended step.

`dt_crit_map` runs `reference_impl.stability.search.search_scene` over power laws
p in [0.5, 5], the paper's ellipsoid at the three Table 1 speeds, a sphere and
a potential whose supremum of U'/sqrt(2U) is interior (`SaturatingForce`), for
each scene kind, and returns one row per (case, speed, scene).
`criterion_sensitivity` reports how Delta t_crit moves with the criterion
(factor and N of the sustained scenes, tol of the single impact).

`recommended_step` is the answer beyond the paper: where Delta t_safe is not a
lower bound, c * 2 sqrt(m / max U'') (the linear Verlet limit at the stiffest
tangent stiffness met on the path, times a measured safety factor) is.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from reference_impl.errors import HCVInputError
from reference_impl.integrators.verlet import SaturatingForce
from reference_impl.potentials import Ellipsoid, Potential, PowerLaw, Sphere
from reference_impl.stability.recommend import (  # re-exported: the map measures its margins
    RECOMMEND_FACTOR,
    RECOMMEND_FACTOR_SINGULAR,
    recommended_step,
)
from reference_impl.stability.search import (
    KINDS,
    Criterion,
    EnergyGrowth,
    ImpactGain,
    SearchGrid,
    default_criterion,
    search_scene,
)

__all__ = [
    "MapCase",
    "coverage",
    "dt_crit_map",
    "map_case_rows",
    "criterion_sensitivity",
    "oscillation_period",
    "recommended_step",
    "RECOMMEND_FACTOR",
    "RECOMMEND_FACTOR_SINGULAR",
]

# Power-law exponents of the full map: [0.5, 5] in steps of 1/4 (Hertz 1.5 and 2 included).
_P_FULL = tuple(np.round(np.arange(0.5, 5.0 + 1e-9, 0.25), 2))
# Quick map: the ends, the linear spring, Hertz, p = 2 and two stiffer laws.
_P_QUICK = (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0)
# Table 1 impact speeds (m/s) of the paper's ellipsoid.
_TABLE1_SPEEDS = (0.50, 0.99, 1.50)
# Saturating contact: speeds from below the interior maximum of U'/sqrt(2U)
# (q_max < 0.7 q_s at 0.25 m/s) to deep in the constant-force regime.
_SAT_FULL = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
_SAT_QUICK = (1.0, 8.0)
_DEFAULT_GRID = SearchGrid()
# Values per list of `criterion_sensitivity` (one search each; a full search is ~1 s).
_MAX_SENS_VALUES = 100


@dataclass(frozen=True)
class MapCase:
    """One potential of the coverage with its mass and impact speeds.

    Attributes
    ----------
    family : str
        "power", "ellipsoid", "sphere" or "saturating".
    label : str
        Short name for tables.
    potential : Potential
        The contact potential.
    m : float
        Mass (kg).
    velocities : tuple of float
        Impact speeds (m/s).
    p : float
        Power-law exponent (NaN for the other families).
    """

    family: str
    label: str
    potential: Potential
    m: float
    velocities: tuple
    p: float = math.nan


def coverage(quick: bool = False) -> list[MapCase]:
    """The cases of the section 6 verdict.

    Power laws use k = 1 N/m^p, m = 1 kg, v0 = 1 m/s: Delta t_crit / Delta t_safe
    of a power law depends on p only (the equation of motion is homogeneous;
    the suite checks this), so one (k, m, v0) per p covers the family.
    The ellipsoid is the paper's (a = 0.015 m, b = c = 0.008 m, m = 0.05 kg,
    Kn = 1e8, alpha = 0.5); the sphere has R = 0.01 m and the same m, Kn, alpha.
    """
    ps = _P_QUICK if quick else _P_FULL
    cases = [
        MapCase("power", f"p={p:g}", PowerLaw(1.0, float(p)), 1.0, (1.0,), float(p)) for p in ps
    ]
    cases.append(
        MapCase(
            "ellipsoid", "ellipsoid", Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5), 0.05, _TABLE1_SPEEDS
        )
    )
    cases.append(
        MapCase(
            "sphere", "sphere", Sphere(0.01, 1e8, 0.5), 0.05, (0.99,) if quick else _TABLE1_SPEEDS
        )
    )
    cases.append(
        MapCase(
            "saturating",
            "q^2/(1+q^2)",
            SaturatingForce(1.0, 1.0),
            1.0,
            _SAT_QUICK if quick else _SAT_FULL,
        )
    )
    return cases


def oscillation_period(pot: Potential, m: float, v0: float) -> float:
    """Period T(E) of the two-sided oscillation U(|q|) at E = m v0^2 / 2 (s).

    T = 4 int_0^q_max dq / sqrt(2 (E - U) / m) (Theorem 1); a one-sided contact
    lasts T / 2. The substitution q = q_max (1 - t^2) removes the inverse
    square-root endpoint singularity at q_max.
    """
    from scipy.integrate import quad

    E = 0.5 * m * v0 * v0
    q_max = pot.turning_point(E, check=False)
    f_max = float(pot._dU(np.array([q_max]))[0])

    def f(t):
        q = q_max * (1.0 - t * t)
        gap = E - float(pot._U(np.array([q]))[0])
        if gap <= 0:  # t -> 0 round-off: E - U ~ U'(q_max) q_max t^2 there
            return 2.0 * q_max / math.sqrt(2.0 * f_max * q_max / m)
        return 2.0 * q_max * t / math.sqrt(2.0 * gap / m)

    # relative 1e-10: far below the 0.1 % resolution at which the period is compared.
    val, _ = quad(f, 0.0, 1.0, epsabs=0.0, epsrel=1e-10, limit=200)
    return 4.0 * val


def _row(case: MapCase, r, period: float, crit: Criterion) -> dict:
    ce = r.counterexample or {}
    return {
        "family": case.family,
        "case": case.label,
        "p": case.p,
        "m": case.m,
        "v0": r.v0,
        "scene": r.kind,
        "criterion": r.criterion,
        # the sustained criterion's detection budget and confirmation horizon (in n_steps)
        "n_steps": getattr(crit, "n_steps", np.nan),
        "confirm_horizon": getattr(crit, "confirm_horizon", np.nan),
        "q_max": r.q_max,
        "geometry": r.geometry,
        "dt_safe": r.dt_safe,
        "dt_shortcut": r.dt_safe_shortcut,
        "dt_tangent": r.dt_tangent,
        "dt_crit": r.dt_crit,
        "dt_stable": r.dt_stable,
        "dt_crit_onset": np.nan if r.dt_crit_onset is None else r.dt_crit_onset,
        "ratio": r.ratio,
        "holds": r.holds,
        "failure_kind": r.failure_kind,
        "runaway_evidence": r.runaway_evidence,
        "dt_bounded": r.dt_bounded,
        "bounded_ratio": r.dt_bounded / r.dt_safe if r.dt_safe > 0 else math.inf,
        "bounded_E_max_over_E0": r.bounded_E_max_over_E0,
        "dt_accuracy": np.nan if r.dt_accuracy is None else r.dt_accuracy,
        "accuracy_ratio": np.nan if r.accuracy_ratio is None else r.accuracy_ratio,
        "degenerate": r.degenerate,
        "recommended_dt": r.recommended_dt,
        "recommended_ratio": r.dt_crit / r.recommended_dt,
        "period": period,
        "dt_crit_over_period": r.dt_crit / period,
        "counterexample_dt": ce.get("dt", np.nan),
        # the rebound energy for an impact, the largest energy for sustained scenes
        "counterexample_E_ratio": ce.get(
            "E_end_over_E0" if r.kind == "impact" else "E_max_over_E0", np.nan
        ),
        "counterexample_steps": ce.get("steps", np.nan),
        "counterexample_status": ce.get("status", ""),
    }


def dt_crit_map(
    cases: Sequence[MapCase] | None = None,
    kinds: Sequence[str] = KINDS,
    *,
    quick: bool = False,
    criteria: dict[str, Criterion] | None = None,
    grid: SearchGrid = _DEFAULT_GRID,
    progress: Callable[[int, int], None] | None = None,
) -> pd.DataFrame:
    """Measured Delta t_crit, Delta t_safe and the recommendation for every case and scene.

    Parameters
    ----------
    cases : sequence of MapCase, optional
        Default `coverage(quick)`.
    kinds : sequence of str
        Scene kinds to run.
    quick : bool
        Fewer cases (about 7 s of one core instead of about 20 s).
    criteria : dict, optional
        Criterion per scene kind; default `default_criterion`.
    grid : SearchGrid
        Search settings.
    progress : callable, optional
        ``progress(done, total)`` after each (case, scene) search.

    Returns
    -------
    pandas.DataFrame
        One row per (case, v0, scene) with columns family, case, p, m, v0, scene,
        criterion, n_steps and confirm_horizon (sustained criterion; NaN for
        impacts), q_max (m), geometry, dt_safe, dt_shortcut, dt_tangent,
        dt_crit, dt_stable, dt_crit_onset (s), ratio = dt_crit / dt_safe,
        holds (False only for a runaway below dt_safe), failure_kind
        ("runaway", "bounded", "accuracy" or None, see `reference_impl.stability.search`),
        runaway_evidence ("confirmed" or "domain"), dt_bounded (s) and
        bounded_ratio = dt_bounded / dt_safe with bounded_E_max_over_E0 (the
        smallest bounded excursion below dt_crit), dt_accuracy (s) and
        accuracy_ratio (impact: largest step within the rebound tolerance), degenerate, recommended_dt (s), recommended_ratio =
        dt_crit / recommended_dt (> 1 means the recommendation is safe),
        period T(E) (s), dt_crit_over_period, and the counterexample's step
        (s), E/E_0 (rebound energy for impacts, largest E_n otherwise), steps
        run and status when the claim fails (for a runaway, counterexample_steps
        / n_steps is the confirmation horizon that step needed).
    """
    cases = coverage(quick) if cases is None else list(cases)
    criteria = criteria or {}
    rows, total, done = [], len(cases) * len(kinds), 0
    for case in cases:
        for kind in kinds:
            rows.extend(map_case_rows(case, kind, criteria.get(kind), grid))
            done += 1
            if progress is not None:
                progress(done, total)
    return pd.DataFrame(rows)


def map_case_rows(
    case: MapCase, kind: str, criterion: Criterion | None = None, grid: SearchGrid = _DEFAULT_GRID
) -> list[dict]:
    """The map rows of one (case, scene kind) search: one dict per impact speed.

    The single home of a map search, used by `dt_crit_map` here and by the sweep
    engine (`reference_impl.sweep.dt_crit_map_on_cluster`) on worker processes.
    """
    crit = criterion if criterion is not None else default_criterion(kind)
    periods = {v: oscillation_period(case.potential, case.m, v) for v in case.velocities}
    results = search_scene(case.potential, case.m, case.velocities, kind, criterion=crit, grid=grid)
    return [_row(case, r, periods[r.v0], crit) for r in results]


def criterion_sensitivity(
    potential: Potential,
    m: float,
    v0: float,
    kind: str,
    *,
    factors: Sequence[float] = (10.0, 100.0, 1e4),
    n_steps: Sequence[int] = (1_000, 10_000, 100_000, 1_000_000),
    tols: Sequence[float] = (1e-3, 1e-2, 1e-1, 1.0),
    horizons: Sequence[int] = (EnergyGrowth().confirm_horizon,),
    gap: float | None = None,
    grid: SearchGrid = _DEFAULT_GRID,
) -> pd.DataFrame:
    """How the measured Delta t_crit moves with the definition of "unstable".

    Sustained scenes: every (factor, n_steps, confirm_horizon) of `EnergyGrowth`
    (``horizons``: confirmation horizons in units of n_steps).
    Impact: every tol of `ImpactGain`, with the onset at a step boundary
    (column dt_crit_onset) and at the worst of the stratified phases (dt_crit).

    Returns
    -------
    pandas.DataFrame
        Columns scene, factor, n_steps, confirm_horizon, tol, dt_safe, dt_crit,
        dt_crit_onset, ratio, failure_kind, dt_bounded, bounded_ratio, dt_accuracy.
    """
    for name, vals in (
        ("factors", factors),
        ("n_steps", n_steps),
        ("tols", tols),
        ("horizons", horizons),
    ):
        if len(vals) > _MAX_SENS_VALUES:
            raise HCVInputError(
                f"criterion_sensitivity takes at most {_MAX_SENS_VALUES} {name}, got {len(vals)}"
            )
    rows = []
    if kind == "impact":
        crits = [replace(ImpactGain(), tol=float(t)) for t in tols]
    else:
        crits = [
            EnergyGrowth(float(f), int(n), confirm_horizon=int(h))
            for f in factors
            for n in n_steps
            for h in horizons
        ]
    for c in crits:
        r = search_scene(potential, m, [v0], kind, gap=gap, criterion=c, grid=grid)[0]
        rows.append(
            {
                "scene": kind,
                "factor": getattr(c, "factor", np.nan),
                "n_steps": getattr(c, "n_steps", np.nan),
                "confirm_horizon": getattr(c, "confirm_horizon", np.nan),
                "tol": getattr(c, "tol", np.nan),
                "dt_safe": r.dt_safe,
                "dt_crit": r.dt_crit,
                "dt_crit_onset": np.nan if r.dt_crit_onset is None else r.dt_crit_onset,
                "ratio": r.ratio,
                "failure_kind": r.failure_kind,
                "dt_bounded": r.dt_bounded,
                "bounded_ratio": r.dt_bounded / r.dt_safe if r.dt_safe > 0 else math.inf,
                "dt_accuracy": np.nan if r.dt_accuracy is None else r.dt_accuracy,
            }
        )
    return pd.DataFrame(rows)
