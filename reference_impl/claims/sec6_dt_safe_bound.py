"""Section 6: Delta t_safe is a lower bound of the critical velocity-Verlet step.

Measured on the critical-step map (`reference_impl.dtcrit_map.dt_crit_map`):
for every case and scene the smallest failing step is searched and compared
with Delta t_safe. A failing step below the bound is counted by its kind
(``failure_kind`` of the map's rows):

* ``runaway`` -- the energy grows without saturating: an instability, the only
  kind that is a counterexample of the claim;
* ``bounded`` -- a large but bounded orbit (e.g. the linear spring just below 2/omega);
* ``accuracy`` -- a single impact whose rebound energy error exceeds a tolerance;
* ``unclassified`` -- the map carries no ``failure_kind`` (an older map): the
  failure cannot be told apart, so the verdict is inconclusive unless a runaway
  is known.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ._base import Measurement, g

ID = "sec6-dt-safe-bound"
SECTION = "6"
STATEMENT = (
    "Delta t_safe = 2 sqrt(m) / max_[0,qmax] U'/sqrt(2U) is a lower bound of the critical "
    "Verlet time step: every Delta t <= Delta t_safe is stable; for stiffening contacts "
    "(2UU'' >= U'^2, all power laws p >= 1) it equals 2 m v0 / U'(qmax)."
)

# Kinds of a failing step (the map's failure_kind); only RUNAWAY is an instability.
RUNAWAY = "runaway"
FAILURE_KINDS = (RUNAWAY, "bounded", "accuracy")
UNCLASSIFIED = "unclassified"
# A failing step "lies below the bound" when dt_crit / dt_safe <= 1: the search brackets
# dt_crit to 0.1 % of dt_safe (SearchGrid().resolution), so no extra margin is added;
# the map's own `holds` flag is used where it says the bound fails.

_MAPS: dict = {}


def the_map(quick: bool = False):
    """The critical-step map of `coverage(quick)`, computed once per process."""
    if quick not in _MAPS:
        from ..dtcrit_map import dt_crit_map

        _MAPS[quick] = dt_crit_map(quick=quick)
    return _MAPS[quick]


def use_map(quick: bool, df) -> None:
    """Adopt a map measured elsewhere (the report runs it in a second process)."""
    _MAPS[quick] = df
    measure.cache_clear()


def failure_kind(row) -> str | None:
    """Kind of the failing step of one map row below the bound; None if it holds there."""
    kind = row.get("failure_kind") if hasattr(row, "get") else None
    has_key = "failure_kind" in row
    below = (not bool(row["holds"])) or (
        kind is not None and _is_set(kind) and float(row["ratio"]) <= 1.0
    )
    if bool(row["degenerate"]) or not below:
        return None
    if not has_key or not _is_set(kind):
        return UNCLASSIFIED
    return str(kind)


def _is_set(kind) -> bool:
    return kind is not None and not (isinstance(kind, float) and math.isnan(kind))


def _label(row) -> str:
    return f"{row['case']} {row['v0']:g} m/s, {row['scene']}"


def describe(row) -> str:
    """One line on a failing row, from its measured fields."""
    kind = failure_kind(row)
    E = row.get("counterexample_E_ratio", math.nan)
    steps = row.get("counterexample_steps", math.nan)
    status = row.get("counterexample_status", "")
    return (
        f"{kind or 'no failure'} at Δt = {float(row['ratio']):.4f} Δt_safe ({_label(row)}; "
        f"{row['criterion']}; E/E0 = {g(E, 4)} after {g(steps, 6)} steps"
        f"{', ' + str(status) if status else ''})"
    )


def verdict_from_map(df) -> Measurement:
    """Refuted iff at least one runaway lies below Delta t_safe; counts per kind reported."""
    usable = df[~df.degenerate]
    kinds = [failure_kind(row) for _, row in df.iterrows()]
    counts = {k: 0 for k in FAILURE_KINDS + (UNCLASSIFIED,)}
    per_scene: dict[str, dict] = {}
    for (_, row), kind in zip(df.iterrows(), kinds, strict=True):
        if bool(row["degenerate"]):
            continue
        sc = per_scene.setdefault(row["scene"], {"cases": 0, **{k: 0 for k in counts}})
        sc["cases"] += 1
        if kind is not None:
            counts[kind] = counts.get(kind, 0) + 1
            sc[kind] = sc.get(kind, 0) + 1
    runaways = [row for (_, row), k in zip(df.iterrows(), kinds, strict=True) if k == RUNAWAY]
    measured = {
        "per_kind": counts,
        "per_scene": per_scene,
        "cases": int(len(df)),
        "usable_cases": int(len(usable)),
        "degenerate_cases": int(df.degenerate.sum()),
        "classified": "failure_kind" in df.columns,
    }
    kind_text = ", ".join(f"{n} {k}" for k, n in counts.items() if n) or "none"
    text = (
        f"failing steps at or below Δt_safe in {sum(counts.values())} of {len(usable)} "
        f"cases with Δt_safe > 0, by kind: {kind_text}"
    )
    counter = None
    if runaways:
        worst = min(runaways, key=lambda r: float(r["ratio"]))
        counter = {
            "case": worst["case"],
            "v0": float(worst["v0"]),
            "scene": worst["scene"],
            "ratio": float(worst["ratio"]),
            "criterion": worst["criterion"],
            "failure_kind": RUNAWAY,
        }
        measured["worst_runaway"] = counter
        text += f"; worst runaway: {describe(worst)}"
    if counts[UNCLASSIFIED]:
        text += (
            "; the map gives no failure_kind, so these failures are not told apart "
            "(runaway, bounded orbit or accuracy)"
        )
    lin = df[(df.family == "power") & (df.p == 1.0) & (df.scene == "two-sided")]
    if len(lin):
        r = float(lin.ratio.iloc[0])
        measured["linear_two_sided_ratio"] = r
        text += f"; linear spring two-sided: Δt_crit/Δt_safe = {r:.4f} (exact 2/ω bound: 1)"
    degenerate = df[df.degenerate]
    if len(degenerate):
        ps = sorted({float(p) for p in degenerate.p if np.isfinite(p)})
        text += (
            f"; p < 1 ({', '.join(f'{p:g}' for p in ps)}): Δt_safe = 0 (sup U'/√(2U) "
            f"infinite at onset), the bound is degenerate while Δt_crit is finite"
        )
    rec = df.recommended_ratio
    if rec.notna().any():
        i = rec.idxmin()
        measured["recommended_min_margin"] = float(rec.min())
        text += (
            f"; the recommended step stays below Δt_crit everywhere "
            f"(smallest Δt_crit/Δt_rec = {rec.min():.2f}, {_label(df.loc[i])})"
            if rec.min() > 1
            else f"; the recommended step fails in {int((rec <= 1).sum())} cases"
        )
    if runaways:
        verdict = "refuted"
    elif counts[UNCLASSIFIED] or not len(usable):
        verdict = "inconclusive"
    else:
        verdict = "verified"
    return Measurement(
        ID,
        verdict,
        text,
        "refuted iff at least one runaway (energy growth that does not saturate) "
        "has a failing Verlet step ≤ Δt_safe; bounded orbits and accuracy "
        "thresholds are counted apart, unclassified failures leave it inconclusive",
        measured,
        counter,
        headline=(
            f"failing steps at or below Δt_safe by kind: {kind_text}"
            + (
                f"; worst runaway at {counter['ratio']:.2f} Δt_safe "
                f"({counter['case']}, {counter['scene']})"
                if counter
                else ""
            )
        ),
    )


@functools.cache
def measure(quick: bool = False) -> Measurement:
    """The verdict on the map of `coverage(quick)` (see `verdict_from_map`)."""
    return verdict_from_map(the_map(quick))
