"""Section 6 in the report: the critical-step map, its figure and the verdict."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..dtcrit import KINDS, default_criterion
from ..dtcrit_map import dt_crit_map

SCENE_COLOURS = {"impact": "#1f77b4", "two-sided": "#d62728", "two-walls": "#2ca02c"}
SCENE_MARKERS = {"impact": "o", "two-sided": "s", "two-walls": "^"}


def run_map(quick: bool, progress=None) -> pd.DataFrame:
    """`dt_crit_map` with a textual progress callback."""
    def tick(done, total):
        if progress:
            progress(f"critical-step map: search {done}/{total}")
    return dt_crit_map(quick=quick, progress=tick)


def _label(row) -> str:
    return f"{row['case']} {row['v0']:g} m/s"


def sec6_verdict(df: pd.DataFrame) -> dict:
    """Refuted if any case with dt_safe > 0 has dt_crit <= dt_safe (a failing step at or below it)."""
    usable = df[~df.degenerate]
    fails = usable[~usable.holds]
    per_scene = {k: {"failing": int((~usable[usable.scene == k].holds).sum()),
                     "cases": int((usable.scene == k).sum())} for k in KINDS}
    degenerate = df[df.degenerate]
    parts = [f"{k}: {v['failing']}/{v['cases']}" for k, v in per_scene.items()]
    measured = {"per_scene": per_scene, "degenerate_cases": int(len(degenerate)),
                "cases": int(len(df))}
    if len(fails):
        worst = fails.loc[fails.ratio.idxmin()]
        measured["worst"] = {"case": worst["case"], "v0": float(worst.v0), "scene": worst.scene,
                             "ratio": float(worst.ratio)}
        text = (f"Δt_crit < Δt_safe (a failing step below the bound) in {len(fails)} of "
                f"{len(usable)} cases with Δt_safe > 0 ({', '.join(parts)}); worst "
                f"Δt_crit/Δt_safe = {worst.ratio:.4f} ({_label(worst)}, {worst.scene})")
    else:
        text = f"no failing step at or below Δt_safe in any of {len(usable)} cases"
    lin = df[(df.family == "power") & (df.p == 1.0) & (df.scene == "two-sided")]
    if len(lin):
        F = default_criterion("two-sided").factor
        bias = math.sqrt(1 - 1 / F)
        r = float(lin.ratio.iloc[0])
        measured["linear_two_sided"] = {"ratio": r, "criterion_bias": bias, "factor": F}
        text += (f"; for p = 1 two-sided the failure is the criterion's bias: measured "
                 f"{r:.4f} vs √(1−1/F) = {bias:.4f} (F = {F:g})")
    if len(degenerate):
        ps = sorted({float(p) for p in degenerate.p if np.isfinite(p)})
        text += (f"; p < 1 ({', '.join(f'{p:g}' for p in ps)}): Δt_safe = 0 (sup U'/√(2U) "
                 f"infinite at onset), the bound is degenerate while Δt_crit is finite")
    rec = df.recommended_ratio
    if rec.notna().any():
        i = rec.idxmin()
        measured["recommended_min_margin"] = float(rec.min())
        text += (f"; the recommended step stays below Δt_crit everywhere "
                 f"(smallest Δt_crit/Δt_rec = {rec.min():.2f}, {_label(df.loc[i])}, "
                 f"{df.loc[i].scene})" if rec.min() > 1 else
                 f"; the recommended step fails in {int((rec <= 1).sum())} cases")
    verdict = "refuted" if len(fails) else ("verified" if len(usable) else "inconclusive")
    return {"verdict": verdict, "evidence": text,
            "rule": "refuted if any case with Δt_safe > 0 has a failing Verlet step ≤ Δt_safe",
            "measured": measured}


def map_figure(df: pd.DataFrame, path) -> None:
    """(a) power laws: Δt_crit/Δt_safe and Δt_rec/Δt_safe against p; (b) the other contacts."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12.5, 5.8), dpi=110)
    pa, pb = fig.subplots(1, 2, width_ratios=[1.0, 1.25])
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.25, top=0.88, wspace=0.15)
    pw = df[df.family == "power"].sort_values("p")
    deg = pw[pw.degenerate]
    ok = pw[~pw.degenerate]
    for k in KINDS:
        s = ok[ok.scene == k]
        c, mk = SCENE_COLOURS[k], SCENE_MARKERS[k]
        pa.plot(s.p, s.ratio, marker=mk, color=c, lw=1.5, ms=5, label=f"{k}: measured Δt_crit")
        pa.plot(s.p, s.recommended_dt / s.dt_safe, ls="--", color=c, lw=1.2,
                label=f"{k}: recommended Δt_rec")
    pa.axhline(1.0, color="k", lw=1.6)
    pa.text(1.6, 1.02, "paper: Δt_crit ≥ Δt_safe (bound)", ha="left", va="bottom", fontsize=9)
    lin = ok[(ok.p == 1.0) & (ok.scene == "two-sided")]
    if len(lin):
        F = default_criterion("two-sided").factor
        pa.plot([0.9, 1.1], [math.sqrt(1 - 1 / F)] * 2, color="k", lw=3, alpha=0.5)
        pa.annotate(f"linear limit √(1−1/F), F = {F:g}", (1.0, math.sqrt(1 - 1 / F)),
                    xytext=(1.9, 0.88), fontsize=8.5, arrowprops=dict(arrowstyle="->", lw=0.8))
    if len(deg):
        pa.axvspan(float(pw.p.min()) - 0.1, 1.0 - 0.05, color="0.85", zorder=0)
        pa.text(0.5 * (float(pw.p.min()) - 0.1 + 0.95), 0.55,
                "p < 1:\nΔt_safe = 0\n(degenerate)", ha="center", fontsize=8.5)
    pa.set(xlabel="power-law exponent p  (U' = k q^p)", ylabel="step / Δt_safe",
           title="(a) power laws, m = 1 kg, k = 1, v0 = 1 m/s (ratio is scale-free)",
           ylim=(0, 1.6))
    pa.legend(fontsize=7.5, loc="upper right", ncol=2)
    other = df[df.family != "power"].copy()
    if len(other):
        labels = list(dict.fromkeys(_label(r) for _, r in other.iterrows()))
        xpos = {lab: i for i, lab in enumerate(labels)}
        for j, k in enumerate(KINDS):
            s = other[other.scene == k]
            x = np.array([xpos[_label(r)] for _, r in s.iterrows()]) + (j - 1) * 0.22
            c, mk = SCENE_COLOURS[k], SCENE_MARKERS[k]
            pb.scatter(x, s.ratio, marker=mk, color=c, s=30, label=f"{k}: Δt_crit/Δt_safe")
            pb.scatter(x, s.recommended_dt / s.dt_safe, marker=mk, facecolors="none",
                       edgecolors=c, s=30, label=f"{k}: Δt_rec/Δt_safe")
        pb.axhline(1.0, color="k", lw=1.6)
        pb.set_xticks(range(len(labels)), labels, rotation=40, ha="right", fontsize=8.5)
        pb.set(ylabel="step / Δt_safe", ylim=(0, 1.6),
               title="(b) ellipsoid and sphere (Kn = 1e8, α = 0.5), q²/(1+q²) saturating force")
        pb.legend(fontsize=7.5, ncol=3, loc="upper left")
    for a in (pa, pb):
        a.grid(True, alpha=0.3)
    fig.suptitle("Critical Verlet step Δt_crit (smallest failing step) against the section 6 "
                 "bound Δt_safe: below the black line the bound fails", fontsize=11.5)
    fig.savefig(path)


def map_table(df: pd.DataFrame) -> list[dict]:
    """Compact rows for the rendered table."""
    out = []
    for _, r in df.iterrows():
        out.append({"case": r["case"], "v0 [m/s]": r.v0, "scene": r.scene, "geometry": r.geometry,
                    "Δt_safe [s]": r.dt_safe, "Δt_crit [s]": r.dt_crit,
                    "Δt_crit/Δt_safe": r.ratio, "holds": "yes" if r.holds else "NO",
                    "Δt_rec [s]": r.recommended_dt, "Δt_crit/Δt_rec": r.recommended_ratio,
                    "failure": r.counterexample_status or ""})
    return out


def describe_recommendation() -> str:
    """One line on the corrected bound (measured margins are in the table)."""
    from ..dtcrit_map import RECOMMEND_FACTOR, RECOMMEND_FACTOR_SINGULAR

    f = ", ".join(f"{k} {v:g}" for k, v in RECOMMEND_FACTOR.items())
    fs = ", ".join(f"{k} {v:g}" for k, v in RECOMMEND_FACTOR_SINGULAR.items())
    return (f"Recommended step (beyond the paper, `dtcrit_map.recommended_step`): Δt_rec = "
            f"c · 2√(m / max U'') over the path, with c = {f}; when U'' is unbounded at onset "
            f"(leading exponent < 2) U''(q_max) is used with c = {fs}. The factors were set "
            f"from these measurements (smallest measured ratio / 1.3–1.7), so the margins "
            f"below are calibration margins; the suite also checks hold-out draws.")


# How Delta t_crit moves with the definition of "unstable" (the issue asks for the
# factor and N of the sustained scenes, and the tolerance of the single impact).
_SENS_FACTORS = (10.0, 100.0, 1e4)
_SENS_STEPS_FULL = (10_000, 100_000, 1_000_000)
_SENS_STEPS_QUICK = (10_000,)
_SENS_TOLS = (1e-3, 1e-2, 1e-1, 1.0)
_SENS_CASES = (("Hertz p = 1.5", 1.5, "two-sided"), ("Hertz p = 1.5", 1.5, "two-walls"),
               ("linear p = 1", 1.0, "two-sided"), ("Hertz p = 1.5", 1.5, "impact"))


def run_sensitivity(quick: bool) -> pd.DataFrame:
    """`criterion_sensitivity` for Hertz (two-sided, two-walls, impact) and the linear spring."""
    from ..dtcrit_map import criterion_sensitivity
    from ..potentials import PowerLaw

    steps = _SENS_STEPS_QUICK if quick else _SENS_STEPS_FULL
    frames = []
    for label, p, kind in _SENS_CASES:
        df = criterion_sensitivity(PowerLaw(1.0, p), 1.0, 1.0, kind, factors=_SENS_FACTORS,
                                   n_steps=steps, tols=_SENS_TOLS)
        df.insert(0, "case", label)
        frames.append(df)
    return pd.concat(frames, ignore_index=True)
