"""How the measured critical step moves with the definition of "unstable" (issue 13).

`run_sensitivity` runs `reference_impl.studies.dtcrit_map.criterion_sensitivity` on
Hertz and the linear spring (factor and budget N of the sustained scenes, tolerance of
the single impact) and, in the full study, on the slow runaways over the confirmation
horizon. Computation only: the report renders the rows written to results.json.
"""

from __future__ import annotations

import pandas as pd

from reference_impl.integrators.verlet import SaturatingForce
from reference_impl.potentials import PowerLaw
from reference_impl.stability.search import EnergyGrowth
from reference_impl.studies.dtcrit_map import criterion_sensitivity

__all__ = ["run_sensitivity"]

# How Delta t_crit moves with the definition of "unstable" (the issue asks for the
# factor and N of the sustained scenes, and the tolerance of the single impact).
_SENS_FACTORS = (10.0, 100.0, 1e4)
_SENS_STEPS_FULL = (10_000, 100_000, 1_000_000)
_SENS_STEPS_QUICK = (10_000,)
_SENS_TOLS = (1e-3, 1e-2, 1e-1, 1.0)
_SENS_CASES = (
    ("Hertz p = 1.5", 1.5, "two-sided"),
    ("Hertz p = 1.5", 1.5, "two-walls"),
    ("linear p = 1", 1.0, "two-sided"),
    ("Hertz p = 1.5", 1.5, "impact"),
)
# Confirmation horizons (in units of N = the map's default budget) for the cases whose
# runaway grows slowly: the map finds their runaways confirmed only after N steps, so
# their step moves with the horizon; Hertz two-sided (a fast runaway) is the control.
_SENS_HORIZONS = (2, 4, 10)
_SENS_HORIZON_CASES = (
    ("q^2/(1+q^2) 1 m/s", "saturating", "two-sided"),
    ("linear p = 1", 1.0, "two-walls"),
    ("Hertz p = 1.5", 1.5, "two-sided"),
)


def run_sensitivity(quick: bool) -> pd.DataFrame:
    """`criterion_sensitivity`: factor and N for Hertz and the linear spring, tolerance of
    the Hertz impact, and the confirmation horizon for the slow runaways (full run only)."""
    steps = _SENS_STEPS_QUICK if quick else _SENS_STEPS_FULL
    frames = []
    for label, p, kind in _SENS_CASES:
        df = criterion_sensitivity(
            PowerLaw(1.0, p), 1.0, 1.0, kind, factors=_SENS_FACTORS, n_steps=steps, tols=_SENS_TOLS
        )
        df.insert(0, "case", label)
        frames.append(df)
    if not quick:
        base = EnergyGrowth()
        for label, p, kind in _SENS_HORIZON_CASES:
            pot = SaturatingForce(1.0, 1.0) if p == "saturating" else PowerLaw(1.0, p)
            df = criterion_sensitivity(
                pot,
                1.0,
                1.0,
                kind,
                factors=(base.factor,),
                n_steps=(base.n_steps,),
                horizons=_SENS_HORIZONS,
            )
            df.insert(0, "case", label)
            frames.append(df)
    return pd.concat(frames, ignore_index=True)
