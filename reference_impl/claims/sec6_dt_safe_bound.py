"""Section 6: Delta t_safe is a lower bound of the critical velocity-Verlet step.

Measured on the critical-step map (`reference_impl.studies.dtcrit_map.dt_crit_map`):
for every case and scene the smallest failing step is searched and compared
with Delta t_safe. Every map row carries the engine's ``failure_kind``; a
failure at or below the bound is counted by kind:

* ``runaway`` -- energy growth confirmed past the confirmation level (or the
  body left the potential's domain) strictly below Delta t_safe (``holds`` is
  False): an instability, the only kind that is a counterexample of the claim;
* ``bounded`` -- a sustained scene whose energy crossed the detection level at a
  step <= Delta t_safe but saturated below the confirmation level (e.g. the
  linear spring just below 2/omega): not an instability;
* ``accuracy`` -- a single impact whose rebound energy gain exceeds the
  tolerance at a step <= Delta t_safe: an accuracy threshold, not an instability.

A runaway is confirmed within ``confirm_horizon * n_steps`` steps. The map
records how many steps the failing lane needed (``counterexample_steps``): a
runaway that needed more than ``n_steps`` would not be a failure with a
shorter horizon, so its Delta t_crit moves with the horizon (slow growth, e.g.
q^2/(1+q^2)); those are reported by name beside the verdict.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from reference_impl.claims._base import Measurement, g
from reference_impl.studies.dtcrit_map import dt_crit_map

ID = "sec6-dt-safe-bound"
SECTION = "6"
STATEMENT = (
    "Delta t_safe = 2 sqrt(m) / max_[0,qmax] U'/sqrt(2U) is a lower bound of the critical "
    "Verlet time step: every Delta t <= Delta t_safe is stable; for stiffening contacts "
    "(2UU'' >= U'^2, all power laws p >= 1) it equals 2 m v0 / U'(qmax)."
)

# The statement as printed (where, equation number or None, LaTeX; whitespace-normalised),
# checked verbatim against the paper's .tex by verification/test_tools_erratum.py.
PRINTED = (
    "section 6, after Eqs. (7)-(8)",
    None,
    r"The derived bound is rigorous: any physical timestep $\Delta t \le \Delta t_{\text{safe}}$ "
    r"guarantees stability for the nonlinear contact simulation.",
)

# Kinds of a failing step at or below the bound; only RUNAWAY is an instability.
RUNAWAY = "runaway"
FAILURE_KINDS = (RUNAWAY, "bounded", "accuracy")
# "At or below the bound": a runaway counts when the engine's `holds` is False
# (dt_crit < dt_safe); bounded excursions and accuracy limits when their step /
# dt_safe <= 1. The search brackets every step to 0.1 % of dt_safe
# (SearchGrid().resolution), so no extra margin is added.


@functools.cache
def the_map(quick: bool = False):
    """The critical-step map of `coverage(quick)`, computed once per process."""

    return dt_crit_map(quick=quick)


def _finite_le_1(x) -> bool:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return False
    return math.isfinite(x) and x <= 1.0


def is_runaway_below(row) -> bool:
    """A confirmed runaway strictly below Delta t_safe (the engine's ``holds`` is False)."""
    return not bool(row["degenerate"]) and row["failure_kind"] == RUNAWAY and not bool(row["holds"])


def kinds_below(row) -> list[str]:
    """Kinds of failure found at or below Delta t_safe in one map row (may be several)."""
    if bool(row["degenerate"]):
        return []
    out = []
    if is_runaway_below(row):
        out.append(RUNAWAY)
    if row["scene"] != "impact" and _finite_le_1(row["bounded_ratio"]):
        out.append("bounded")
    if row["failure_kind"] == "accuracy" and _finite_le_1(row["ratio"]):
        out.append("accuracy")
    return out


def confirm_horizon_needed(row) -> float:
    """Steps the runaway at dt_crit took to be confirmed, in units of n_steps (NaN if none).

    A value > 1 means the runaway is confirmed only after the detection budget:
    with a confirmation horizon below this value, that step is not a failure and
    Delta t_crit moves up.
    """
    n = row.get("n_steps", math.nan) if hasattr(row, "get") else math.nan
    steps = row.get("counterexample_steps", math.nan)
    if not is_runaway_below(row):
        return math.nan
    try:
        return float(steps) / float(n)
    except (TypeError, ValueError, ZeroDivisionError):
        return math.nan


def _label(row) -> str:
    return f"{row['case']} {row['v0']:g} m/s, {row['scene']}"


def describe(row) -> str:
    """One line on a map row's failure at or below the bound, from its measured fields."""
    kinds = kinds_below(row) or ["no failure"]
    E = row.get("counterexample_E_ratio", math.nan)
    steps = row.get("counterexample_steps", math.nan)
    status = row.get("counterexample_status", "")
    h = confirm_horizon_needed(row)
    return (
        f"{'+'.join(kinds)} at Δt = {float(row['ratio']):.4f} Δt_safe ({_label(row)}; "
        f"{row['criterion']}; E/E0 = {g(E, 4)} after {g(steps, 6)} steps"
        f"{', ' + str(status) if status else ''}"
        f"{f'; confirmed after {h:.2f} × n_steps' if math.isfinite(h) else ''})"
    )


def kind_counts(df) -> dict:
    """Failures at or below Delta t_safe counted by kind (cases with Delta t_safe > 0).

    Returns
    -------
    dict
        ``runaway``, ``bounded``, ``accuracy`` (see the module docstring) and
        ``cases`` over all usable cases, ``sustained_cases``, ``impact_cases``,
        the same per scene kind (``per_scene``), and ``kinds_in_range``: the
        engine's failure_kind of every usable row, at any step.
    """
    usable = df[~df.degenerate]

    def count(sub):
        ks = [kinds_below(r) for _, r in sub.iterrows()]
        out = {k: sum(k in x for x in ks) for k in FAILURE_KINDS}
        out["cases"] = int(len(sub))
        return out

    out = count(usable)
    out["sustained_cases"] = int((usable.scene != "impact").sum())
    out["impact_cases"] = int((usable.scene == "impact").sum())
    out["per_scene"] = {k: count(usable[usable.scene == k]) for k in dict.fromkeys(usable.scene)}
    fk = usable.failure_kind.fillna("none")
    out["kinds_in_range"] = {str(k): int((fk == k).sum()) for k in sorted(set(fk))}
    return out


def _horizon_findings(runs) -> dict:
    """Runaways below the bound split by whether their step moves with the horizon."""
    need = {_label(r): confirm_horizon_needed(r) for _, r in runs.iterrows()}
    moving = {k: v for k, v in need.items() if math.isfinite(v) and v > 1.0}
    return {"confirm_horizon_needed": need, "moves_with_horizon": moving}


def verdict_from_map(df) -> Measurement:
    """Refuted iff at least one runaway lies strictly below Delta t_safe; counts per kind."""
    usable = df[~df.degenerate]
    runs = df[[is_runaway_below(r) for _, r in df.iterrows()]]
    counts = kind_counts(df)
    hz = _horizon_findings(runs)
    measured = {
        "per_kind": {k: counts[k] for k in FAILURE_KINDS},
        "kind_counts": counts,
        "cases": int(len(df)),
        "usable_cases": int(len(usable)),
        "degenerate_cases": int(df.degenerate.sum()),
        **hz,
    }
    sc = counts["sustained_cases"]
    text = (
        f"at or below Δt_safe, in {len(usable)} cases with Δt_safe > 0: "
        f"{counts[RUNAWAY]} runaways (instabilities) in {sc} sustained cases, "
        f"{counts['bounded']} bounded excursions (saturating, not instabilities) in {sc} "
        f"sustained cases, {counts['accuracy']} impact accuracy limits (rebound gain above "
        f"tolerance, not instabilities) in {counts['impact_cases']} impacts"
    )
    counter = None
    if len(runs):
        worst = runs.loc[runs.ratio.idxmin()]
        dom = int((runs.runaway_evidence == "domain").sum())
        counter = {
            "case": worst["case"],
            "v0": float(worst["v0"]),
            "scene": worst["scene"],
            "ratio": float(worst["ratio"]),
            "criterion": worst["criterion"],
            "failure_kind": RUNAWAY,
            "confirm_horizon_needed": confirm_horizon_needed(worst),
        }
        measured["worst_runaway"] = counter
        measured["runaways_by_domain_exit"] = dom
        text += f"; {dom} of the runaways left the potential's domain; worst: {describe(worst)}"
        fixed = runs[[not (confirm_horizon_needed(r) > 1.0) for _, r in runs.iterrows()]]
        if hz["moves_with_horizon"]:
            mv = ", ".join(f"{k} ({v:.2f})" for k, v in hz["moves_with_horizon"].items())
            text += (
                f"; {len(hz['moves_with_horizon'])} of the {len(runs)} runaways were confirmed "
                f"only after the detection budget n_steps (needed horizon in n_steps: {mv}): "
                f"their Δt_crit moves with the confirmation horizon (slow growth)"
            )
        if len(fixed):
            wf = fixed.loc[fixed.ratio.idxmin()]
            measured["worst_runaway_within_n_steps"] = {
                "case": wf["case"],
                "v0": float(wf["v0"]),
                "scene": wf["scene"],
                "ratio": float(wf["ratio"]),
            }
            text += (
                f"; {len(fixed)} runaways are confirmed within n_steps (the same step for "
                f"any horizon >= 1), worst at {float(wf.ratio):.4f} Δt_safe ({_label(wf)})"
            )
    lin = df[(df.family == "power") & (df.p == 1.0) & (df.scene == "two-sided")]
    if len(lin):
        r = lin.iloc[0]
        measured["linear_two_sided"] = {
            "ratio": float(r.ratio),
            "failure_kind": r.failure_kind,
            "holds": bool(r.holds),
            "bounded_ratio": float(r.bounded_ratio),
        }
        text += (
            f"; linear spring two-sided: {r.failure_kind or 'no failure'} at Δt_crit/Δt_safe = "
            f"{float(r.ratio):.4f} (exact 2/ω bound: 1), bounded excursions from "
            f"{g(r.bounded_ratio, 4)} Δt_safe"
        )
    acc = usable[usable.scene == "impact"].accuracy_ratio
    if acc.notna().any():
        measured["impact_accuracy_min_ratio"] = float(acc.min())
        text += f"; smallest impact Δt_accuracy/Δt_safe = {acc.min():.4f}"
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
    verdict = "refuted" if len(runs) else ("verified" if len(usable) else "inconclusive")
    n_slow = len(hz["moves_with_horizon"])
    head = (
        f"below Δt_safe: {counts[RUNAWAY]} runaways"
        + (f" ({n_slow} of them with a step that moves with the horizon)" if n_slow else "")
        + f", {counts['bounded']} bounded, {counts['accuracy']} accuracy"
    )
    if counter:
        head += f"; worst runaway {counter['ratio']:.2f} Δt_safe ({counter['case']}, {counter['scene']})"
    return Measurement(
        ID,
        verdict,
        text,
        "refuted iff at least one runaway (energy confirmed past the confirmation level "
        "within the confirmation horizon, or the body left the domain) has a failing Verlet "
        "step < Δt_safe; bounded excursions and impact accuracy limits are counted apart",
        measured,
        counter,
        headline=head,
    )


@functools.cache
def measure(quick: bool = False) -> Measurement:
    """The verdict on the map of `coverage(quick)` (see `verdict_from_map`; a map measured
    elsewhere, as the report's background processes do, is passed to that function)."""
    return verdict_from_map(the_map(quick))


def corrected(m: dict, r: dict) -> tuple[str, str]:
    """This claim's erratum: the contract is `reference_impl.claims.Claim.corrected`."""
    w, k = m.get("worst_runaway") or {}, m["per_kind"]
    lin = m.get("linear_two_sided", {})
    rows = r.get("dt_crit_map", [])
    cases = ", ".join(dict.fromkeys(x["case"] for x in rows if not x["degenerate"]))
    degenerate = ", ".join(dict.fromkeys(x["case"] for x in rows if x["degenerate"]))
    impact = next((x["criterion"] for x in rows if x["scene"] == "impact"), "")
    slow = m.get("moves_with_horizon", {})
    return (
        "Withdrawn as a sufficient condition. Measured instead with velocity Verlet "
        f"({w.get('criterion', '')}): the smallest runaway step found on the search grid is "
        f"{w.get('ratio', float('nan')):.4f} Δt_safe, over the {m['usable_cases']} cases with "
        f"Δt_safe > 0 ({cases}; two-sided and two-walls scenes, and single impacts); Δt_crit = {g(lin.get('ratio'), 4)} Δt_safe for the linear spring, "
        f"two-sided; single impacts: no runaway at or below Δt_safe, accuracy limit ({impact}) "
        f"from {g(m.get('impact_accuracy_min_ratio'), 3)} Δt_safe. Δt_safe = 0 (no bound) for "
        f"{degenerate or 'none'}.",
        f"at or below Δt_safe in {m['usable_cases']} cases: {k['runaway']} runaways, "
        f"{k['bounded']} bounded excursions, {k['accuracy']} impact accuracy limits; worst runaway "
        f"{w.get('ratio', float('nan')):.4f} Δt_safe ({w.get('case')}, {w.get('scene')}); "
        f"{len(slow)} runaways have a Δt_crit that moves with the confirmation horizon "
        f"({', '.join(slow)}).",
    )
