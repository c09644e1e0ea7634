"""Section 6 in the report: the critical-step map's figure.

Drawn from the map's rows (results.json ``dt_crit_map``, measured by
`reference_impl.campaign`); the counts are the claim's own (`claims.sec6_dt_safe_bound`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from reference_impl.claims.sec6_dt_safe_bound import confirm_horizon_needed, kind_counts

__all__ = ["map_figure"]

SCENE_COLOURS = {"impact": "#1f77b4", "two-sided": "#d62728", "two-walls": "#2ca02c"}
SCENE_MARKERS = {"impact": "o", "two-sided": "s", "two-walls": "^"}
# The scene kinds of the map, in drawing order (`stability.search.KINDS`).
KINDS = tuple(SCENE_COLOURS)
# What Delta t_crit measures per scene kind (legend text).
_WHAT = {"impact": "accuracy limit", "two-sided": "runaway Δt_crit", "two-walls": "runaway Δt_crit"}


def _label(row) -> str:
    return f"{row['case']} {row['v0']:g} m/s"


def map_figure(df: pd.DataFrame, path) -> None:
    """(a) power laws: Δt_crit/Δt_safe and Δt_rec/Δt_safe against p; (b) the other contacts."""
    from matplotlib.figure import Figure

    # Two rows, each legend right of its panel (off the data); the counts line below.
    fig = Figure(figsize=(12.5, 10.5), dpi=110, layout="constrained")
    fig.get_layout_engine().set(rect=(0.0, 0.06, 1.0, 0.94))
    pa, pb = fig.subplots(2, 1, height_ratios=[1.0, 1.15])
    pw = df[df.family == "power"].sort_values("p")
    deg = pw[pw.degenerate]
    ok = pw[~pw.degenerate]
    for k in KINDS:
        s = ok[ok.scene == k]
        c, mk = SCENE_COLOURS[k], SCENE_MARKERS[k]
        what = _WHAT[k]
        pa.plot(s.p, s.ratio, marker=mk, color=c, lw=1.5, ms=5, label=f"{k}: {what}")
        pa.plot(
            s.p,
            s.recommended_dt / s.dt_safe,
            ls="--",
            color=c,
            lw=1.2,
            label=f"{k}: recommended Δt_rec",
        )
        if k != "impact":
            pa.scatter(
                s.p,
                s.bounded_ratio.replace(np.inf, np.nan),
                marker="x",
                color=c,
                s=28,
                label=f"{k}: bounded excursion",
            )
    pa.axhline(1.0, color="k", lw=1.6)
    pa.text(1.6, 1.02, "paper: Δt_crit ≥ Δt_safe (bound)", ha="left", va="bottom", fontsize=9)
    if len(deg):
        pa.axvspan(float(pw.p.min()) - 0.1, 1.0 - 0.05, color="0.85", zorder=0)
        pa.text(
            0.5 * (float(pw.p.min()) - 0.1 + 0.95),
            0.55,
            "p < 1:\nΔt_safe = 0\n(degenerate)",
            ha="center",
            fontsize=8.5,
        )
    pa.set(
        xlabel="power-law exponent p  (U' = k q^p) [-]",
        ylabel="step / Δt_safe [-]",
        title="(a) power laws, m = 1 kg, k = 1, v0 = 1 m/s (ratio is scale-free)",
        ylim=(0, 1.6),
    )
    pa.legend(fontsize=8.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    other = df[df.family != "power"].copy()
    if len(other):
        labels = list(dict.fromkeys(_label(r) for _, r in other.iterrows()))
        xpos = {lab: i for i, lab in enumerate(labels)}
        for j, k in enumerate(KINDS):
            s = other[other.scene == k]
            x = np.array([xpos[_label(r)] for _, r in s.iterrows()]) + (j - 1) * 0.22
            c, mk = SCENE_COLOURS[k], SCENE_MARKERS[k]
            pb.scatter(x, s.ratio, marker=mk, color=c, s=30, label=f"{k}: {_WHAT[k]}")
            pb.scatter(
                x,
                s.recommended_dt / s.dt_safe,
                marker=mk,
                facecolors="none",
                edgecolors=c,
                s=30,
                label=f"{k}: Δt_rec/Δt_safe",
            )
            if k != "impact":
                pb.scatter(
                    x,
                    s.bounded_ratio.replace(np.inf, np.nan),
                    marker="x",
                    color=c,
                    s=30,
                    label=f"{k}: bounded excursion",
                )
        pb.axhline(1.0, color="k", lw=1.6)
        pb.set_xticks(range(len(labels)), labels, rotation=40, ha="right", fontsize=8.5)
        pb.set(
            xlabel="case and impact speed v0 [m/s]",
            ylabel="step / Δt_safe [-]",
            ylim=(0, 1.6),
            title="(b) ellipsoid and sphere (Kn = 1e8, α = 0.5), q²/(1+q²) saturating force",
        )
        pb.legend(fontsize=8.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    for a in (pa, pb):
        a.grid(True, alpha=0.3)
    c = kind_counts(df)
    slow = sum(confirm_horizon_needed(r) > 1.0 for _, r in df.iterrows())
    fig.text(
        0.5,
        0.015,
        f"Below Δt_safe (cases with Δt_safe > 0): runaways (instabilities) {c['runaway']} "
        f"of {c['sustained_cases']} sustained cases ({slow} of them confirmed only after N "
        f"steps: their step moves with the confirmation horizon);\nbounded excursions (not "
        f"instabilities) {c['bounded']} of {c['sustained_cases']}; impact accuracy limit (not "
        f"an instability) {c['accuracy']} of {c['impact_cases']} impacts",
        ha="center",
        va="bottom",
        fontsize=9,
    )
    fig.suptitle(
        "Critical Verlet step against the section 6 bound Δt_safe: a runaway below the black "
        "line refutes the bound;\nbounded excursions (×) and the impact accuracy limit do not",
        fontsize=11,
    )
    fig.savefig(path)
