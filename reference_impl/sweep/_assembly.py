"""Assembly ensembles in a sweep: each case a group of lanes of one ensemble at one horizon.

A ``task = "dt-crit"`` sweep of chain or lattice scenes runs, for every swept scene, an
ensemble of ``lanes`` lanes (initial velocities differing in the last bits) at each of
``horizons``, as ``hcv dt-crit SCENE --horizons --lanes`` does
(`reference_impl.assembly.search`). The lanes' searches are independent, so the ensemble
is cut into groups of ``lane_group`` lanes, each group of each horizon one case of the
sweep (one Dask task, `reference_impl.sweep._runner`): a few large tasks of similar size
per ensemble rather than one task per ensemble (unequal: the longest horizon dominates)
or one per lane (tiny), so that two workers run close to twice as fast as one. Lane k of
a group is lane first_lane + k of the ensemble, bit for bit (`search_ensemble`'s
``first_lane``). The spec's optional table::

    [assembly]
    horizons = [10000, 100000]       # steps of each ensemble (default: hcv dt-crit's)
    lanes = 32                       # lanes per ensemble
    lane_group = 8                   # lanes per case (per Dask task)

Each case returns one row per lane; `ensemble_rows` gathers the rows of a sweep back into
one row per ensemble (scene and horizon): the 5 / 50 / 95 % points of Delta t_crit and over
Delta t_safe, with the number of lanes found.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.assembly.model import assembly_model
from reference_impl.assembly.search import (
    HORIZONS,
    MAX_ENSEMBLE,
    QUANTILES,
    reference_step,
    search_ensemble,
)
from reference_impl.stability.criteria import EnergyGrowth
from reference_impl.sweep._code import SweepSpecError

__all__ = [
    "ASSEMBLY_KINDS",
    "DEFAULTS",
    "assembly_rows",
    "check_assembly_table",
    "ensemble_rows",
    "lane_groups",
]

ASSEMBLY_KINDS = ("chain", "lattice")
# hcv dt-crit's defaults: the horizons, 32 lanes; 8 lanes a case gives 4 tasks per
# ensemble and horizon, enough to keep 2-4 workers busy on one scene.
DEFAULTS = {"horizons": list(HORIZONS), "lanes": 32, "lane_group": 8}
# A horizon's limit (steps), as hcv dt-crit --horizons.
_MAX_HORIZON = 10_000_000
# hcv dt-crit's runaway rule on an assembly: E > 100 E_0, confirmed at 1e4 x that within 10
# horizons (`reference_impl.assembly.search.assembly_report`'s defaults).
_FACTOR, _CONFIRM_FACTOR, _CONFIRM_HORIZON = 100.0, 1e4, 10


def _int(src: str, key: str, value, lo: int, hi: int) -> int:
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise SweepSpecError(f"spec {src}: assembly.{key} must be an integer in [{lo}, {hi}], "
                             f"got {value!r}")  # fmt: skip
    return value


def check_assembly_table(src: str, task: str, table) -> dict | None:
    """The ``[assembly]`` table with its defaults filled in (None when absent).

    Raises
    ------
    SweepSpecError
        Not a table, an unknown key, a value out of range, or a task other than dt-crit.
    """
    if table is None:
        return None
    if task != "dt-crit":
        raise SweepSpecError(f"spec {src}: [assembly] applies to task = 'dt-crit' only")
    if not isinstance(table, dict):
        raise SweepSpecError(f"spec {src}: [assembly] must be a table, got {table!r}")
    for k in table:
        if k not in DEFAULTS:
            raise SweepSpecError(f"spec {src}: assembly.{k}: not one of {', '.join(DEFAULTS)}")
    out = {**DEFAULTS, **table}
    hs = out["horizons"]
    if not isinstance(hs, list) or not hs:
        raise SweepSpecError(f"spec {src}: assembly.horizons must be a non-empty array of steps")
    out["horizons"] = sorted({_int(src, "horizons", h, 1, _MAX_HORIZON) for h in hs})
    out["lanes"] = _int(src, "lanes", out["lanes"], 1, MAX_ENSEMBLE)
    out["lane_group"] = _int(src, "lane_group", out["lane_group"], 1, MAX_ENSEMBLE)
    return out


def lane_groups(settings: dict | None) -> list[dict]:
    """The cases of one assembly scene: per horizon, per group of lanes, what the worker
    runs (``horizon``, ``first_lane``, ``n_lanes``, ``lanes`` of the whole ensemble)."""
    s = DEFAULTS if settings is None else settings
    n, g = s["lanes"], s["lane_group"]
    return [
        {"horizon": h, "first_lane": a, "n_lanes": min(g, n - a), "lanes": n}
        for h in s["horizons"]
        for a in range(0, n, g)
    ]


def assembly_rows(scene, group: dict, progress=None) -> list[dict]:
    """One row per lane of ``group`` (`lane_groups`) on the assembly ``scene``.

    Each row: ``horizon``, ``lane`` (its index in the ensemble), ``lanes``, ``dt_crit`` and
    ``dt_stable`` (s; inf where the lane never failed), ``evidence``, ``dt_crit_over_dt_safe``,
    ``dt_safe.paper`` / ``.reduced`` / ``.one_contact`` (s), ``e0`` (J), ``n_bodies``,
    ``n_contacts``, ``coordination``, ``dim``, ``contact_updates`` (of the whole group).
    ``progress(done, total)`` after each round of the search (the case's deadline).
    """
    model = assembly_model(scene)
    e0, safe, ref = reference_step(model)
    crit = EnergyGrowth(
        factor=_FACTOR, n_steps=int(group["horizon"]), confirm_factor=_CONFIRM_FACTOR,
        confirm_horizon=_CONFIRM_HORIZON,
    )  # fmt: skip
    ens = search_ensemble(
        model, ref, n_lanes=int(group["n_lanes"]), criterion=crit,
        progress=progress, first_lane=int(group["first_lane"]),
    )  # fmt: skip
    a = model.assembly
    paper = safe["paper"]
    rows = []
    for k in range(ens.dt_crit.size):
        d = float(ens.dt_crit[k])
        rows.append(
            {
                "horizon": int(group["horizon"]),
                "lane": int(group["first_lane"]) + k,
                "lanes": int(group["lanes"]),
                "dt_crit": d,
                "dt_stable": float(ens.dt_stable[k]),
                "evidence": ens.evidence[k],
                "dt_crit_over_dt_safe": d / paper if paper > 0 else math.inf,
                **{f"dt_safe.{c}": v for c, v in safe.items()},
                "e0": e0,
                "n_bodies": a.n_bodies,
                "n_contacts": a.n_contacts,
                "coordination": a.coordination,
                "dim": a.dim,
                "contact_updates": ens.contact_updates,
            }
        )
    return rows


def ensemble_rows(df, by: list[str]):
    """One row per ensemble (the swept parameters ``by`` and the horizon) of a sweep's
    per-lane rows: ``lanes_found`` of ``lanes``, the 5 / 50 / 95 % points of Delta t_crit
    (s) and over Delta t_safe (numpy's "lower" quantile, as `Ensemble.quantiles`).

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's rows (columns of `assembly_rows`, plus the swept parameters).
    by : list of str
        The swept parameters naming an ensemble (``assembly.first_lane`` excluded).
    """
    import pandas as pd

    keys = [*by, "horizon"]
    ran = df[df["lane"].notna()] if "lane" in df.columns else df.iloc[0:0]
    out = []
    for values, g in ran.groupby(keys, sort=False, dropna=False):
        d = np.sort(g["dt_crit"].to_numpy(dtype=float))
        r = np.sort(g["dt_crit_over_dt_safe"].to_numpy(dtype=float))
        row = dict(zip(keys, values if isinstance(values, tuple) else (values,), strict=True))
        row["lanes_found"] = len(g)
        row["lanes"] = int(g["lanes"].iloc[0])
        for p in QUANTILES:
            name = f"{round(100 * p)}"
            row[f"dt_crit_{name}"] = float(np.quantile(d, p, method="lower"))
            row[f"ratio_{name}"] = float(np.quantile(r, p, method="lower"))
        out.append(row)
    return pd.DataFrame(out)
