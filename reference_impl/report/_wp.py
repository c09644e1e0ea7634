"""Speed against error (work-precision diagrams) in the report."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from reference_impl.report._common import g
from reference_impl.studies.workprecision import (
    IVP_METHODS,
    IVP_RTOLS,
    VERLET_STEPS,
    default_scenes,
    work_precision,
)

METRICS = (
    ("err_contact_time", "contact time t_c"),
    ("err_restitution", "restitution e"),
    ("err_max_penetration", "max penetration q_max"),
    ("err_trajectory", "trajectory max|q(t) − q_true(t)| / q_max"),
)
METHOD_STYLE = {
    "exact": dict(color="k", marker="*", ms=13),
    "RK45": dict(color="#1f77b4", marker="o", ms=5),
    "DOP853": dict(color="#ff7f0e", marker="s", ms=5),
    "Radau": dict(color="#2ca02c", marker="D", ms=5),
    "LSODA": dict(color="#9467bd", marker="v", ms=6),
    "Verlet": dict(color="#8c564b", marker="^", ms=6),
}
# Errors below this are drawn at it on the log axes (the exact solver can hit 0).
FLOOR = 1e-17
# Accuracy targets of the summary table (relative error in all four metrics).
TARGETS = (1e-6, 1e-10)


def settings_text(quick: bool) -> str:
    """What the study ran (and what --quick drops)."""
    methods = ("DOP853", "RK45") if quick else IVP_METHODS
    rtols = IVP_RTOLS[::2] if quick else IVP_RTOLS
    steps = VERLET_STEPS[::2] if quick else VERLET_STEPS
    return (
        f"solve_ivp methods {', '.join(methods)} at rtol ∈ {{{', '.join(g(r) for r in rtols)}}}"
        f" (atol = rtol × state scale); velocity Verlet at {', '.join(map(str, steps))} steps "
        f"per contact; the exact harmonic-map solver at its default level"
    )


# Scene left out by --quick (its damped twin, the ellipsoid and the other families remain).
QUICK_SKIP = ("hertz-k1e9",)
# Potential family of a scene, by the class of its potential.
# The study's scene of each family, by the family's scene name (`Potential.family`).
FAMILY_NAMES = {
    "power": "power law (Hertz)",
    "ellipsoid": "ellipsoid (paper)",
    "sphere": "sphere",
    "sum": "sum of power laws",
    "expression": "user expression",
}
# The DOP853 tolerance the per-family summary quotes (the row whose rtol is nearest in log).
SUMMARY_RTOL = 1e-12


def scene_families() -> dict[str, str]:
    """{scene name: family label} for `default_scenes`."""
    return {
        s.name: FAMILY_NAMES.get(s.potential.family, s.potential.label or type(s.potential).__name__)
        for s in default_scenes()
    }


def _rtol_of(setting: str) -> float:
    return float(setting.split("=", 1)[1]) if setting.startswith("rtol=") else math.nan


def family_summary(rows: list[dict]) -> list[dict]:
    """Per scene, from the measured rows: the exact solver's time, largest error and own
    contact-time bound, and DOP853's time and largest error at the rtol nearest
    `SUMMARY_RTOL` (and that time over the exact solver's)."""
    fam = scene_families()
    out = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        ex = [r for r in rows if r["scene"] == scene and r["method"] == "exact"]
        dop = [
            r
            for r in rows
            if r["scene"] == scene
            and r["method"] == "DOP853"
            and r.get("seconds") is not None
            and math.isfinite(float(r["seconds"]))
        ]
        if not ex:
            continue
        e = ex[0]
        d = (
            min(dop, key=lambda r: abs(math.log10(_rtol_of(r["setting"]) / SUMMARY_RTOL)))
            if dop
            else None
        )
        out.append(
            {
                "scene": scene,
                "family": fam.get(scene, "?"),
                "exact_seconds": float(e["seconds"]),
                "exact_max_error": _max_err(e),
                "exact_contact_time_bound": float(e.get("contact_time_bound", math.nan)),
                "dop853_setting": d["setting"] if d else "not run",
                "dop853_seconds": float(d["seconds"]) if d else math.nan,
                "dop853_max_error": _max_err(d) if d else math.nan,
                "dop853_over_exact": float(d["seconds"]) / float(e["seconds"]) if d else math.nan,
            }
        )
    return out


def run_wp(quick: bool, progress=None) -> pd.DataFrame:
    """`work_precision` with the report's Verlet points (quick: without `QUICK_SKIP`)."""
    scenes = [s for s in default_scenes() if not (quick and s.name in QUICK_SKIP)]
    return work_precision(scenes, quick=quick, progress=progress)


def _short(info: str) -> str:
    """The scene description without the potential's repr (m, v0, zeta only)."""
    return info.split("), ", 1)[-1] if "), " in info else info


def _require_styles(df: pd.DataFrame) -> None:
    """A method of the study without a `METHOD_STYLE` is an error, not a curve left out."""
    missing = sorted(set(df.method) - set(METHOD_STYLE))
    if missing:
        raise ValueError(
            f"work-precision plot: method(s) {missing} have no entry in METHOD_STYLE "
            f"(reference_impl/report/_wp.py; styled: {sorted(METHOD_STYLE)})"
        )


def wp_figures(df: pd.DataFrame, fig_dir, scenes_info: dict) -> list[tuple[str, str]]:
    """The per-family overview, then one figure per scene with four log-log panels;
    returns [(file name, caption)]. Raises ValueError for a method without a style."""
    from matplotlib.figure import Figure

    _require_styles(df)
    out = [wp_overview_figure(df, fig_dir)]
    for scene in dict.fromkeys(df.scene):
        d = df[(df.scene == scene) & df.seconds.notna()]
        fig = Figure(figsize=(11.5, 8.4), dpi=110)
        axes = fig.subplots(2, 2)
        fig.subplots_adjust(left=0.075, right=0.985, bottom=0.07, top=0.895, wspace=0.2, hspace=0.3)
        for ax, (col, title) in zip(axes.flat, METRICS, strict=True):
            for method, style in METHOD_STYLE.items():
                s = d[d.method == method]
                if s.empty or col not in s:
                    continue
                y = np.maximum(s[col].to_numpy(dtype=float), FLOOR)
                x = s.seconds.to_numpy(dtype=float)
                ok = np.isfinite(x) & np.isfinite(y)
                if not ok.any():
                    continue
                ax.loglog(
                    x[ok],
                    y[ok],
                    ls="-" if method != "exact" else "none",
                    lw=1.3,
                    label=method,
                    **style,
                )
                if method != "exact" and ok.sum() > 1:
                    sets = s.setting.to_numpy()[ok]
                    for i in (0, ok.sum() - 1):
                        txt = sets[i].replace("rtol=", "").replace(" steps/contact", "")
                        ax.annotate(
                            txt,
                            (x[ok][i], y[ok][i]),
                            fontsize=7,
                            color=style["color"],
                            xytext=(4, 3),
                            textcoords="offset points",
                        )
            ax.set(
                xlabel="wall time per impact [s] (median of repeats)",
                ylabel="relative error",
                title=title,
            )
            ax.axhline(FLOOR, color="0.6", lw=0.6, ls=":")
            ax.grid(True, which="major", alpha=0.3)
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(
            handles,
            labels,
            loc="upper center",
            ncol=len(labels),
            fontsize=9.5,
            bbox_to_anchor=(0.5, 0.955),
            frameon=False,
        )
        info = scenes_info.get(scene, "")
        fig.suptitle(
            f"Work-precision, scene {scene}: {_short(info)}; truth: mpmath, 30 digits",
            fontsize=11.5,
        )
        name = f"work_precision_{scene}.png"
        fig.savefig(fig_dir / name)
        out.append(
            (
                name,
                f"Error against wall time, {scene} ({info}). Numbers at the ends of "
                f"each line: rtol (solve_ivp) or steps per contact (Verlet). Errors "
                f"below {g(FLOOR)} are drawn at {g(FLOOR)}.",
            )
        )
    return out


# Panels per row of the per-family overview figure.
_OVERVIEW_COLS = 3


def wp_overview_figure(df: pd.DataFrame, fig_dir) -> tuple[str, str]:
    """One panel per scene (every family): the largest of the four relative errors
    against wall time, every method; returns (file name, caption). Raises ValueError for
    a method without a style."""
    from matplotlib.figure import Figure

    _require_styles(df)
    fam = scene_families()
    scenes = list(dict.fromkeys(df.scene))
    nrow = -(-len(scenes) // _OVERVIEW_COLS)
    fig = Figure(figsize=(13.0, 3.9 * nrow + 0.6), dpi=110)
    axes = np.atleast_2d(fig.subplots(nrow, _OVERVIEW_COLS, squeeze=False))
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.08, top=0.88, wspace=0.25, hspace=0.42)
    for ax, scene in zip(axes.flat, scenes, strict=False):
        d = df[(df.scene == scene) & df.seconds.notna()]
        for method, style in METHOD_STYLE.items():
            s = d[d.method == method]
            if s.empty:
                continue
            y = np.maximum([_max_err(r) for r in s.to_dict("records")], FLOOR)
            x = s.seconds.to_numpy(dtype=float)
            ok = np.isfinite(x) & np.isfinite(y)
            if ok.any():
                ax.loglog(
                    x[ok],
                    y[ok],
                    ls="-" if method != "exact" else "none",
                    lw=1.3,
                    label=method,
                    **style,
                )
        ax.set(
            xlabel="wall time per impact [s]",
            ylabel="largest relative error (t_c, e, q_max, q(t))",
            title=f"{scene}: {fam.get(scene, '?')}",
        )
        ax.axhline(FLOOR, color="0.6", lw=0.6, ls=":")
        ax.grid(True, which="major", alpha=0.3)
    for ax in list(axes.flat)[len(scenes) :]:
        ax.set_visible(False)
    handles, labels = {}, {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    labels = list(handles)
    fig.legend(
        [handles[k] for k in labels],
        labels,
        loc="upper center",
        ncol=len(labels),
        fontsize=9.5,
        bbox_to_anchor=(0.5, 0.985),
        frameon=False,
    )
    fig.suptitle(
        "Work-precision, every potential family (truth: mpmath, 30 digits)",
        fontsize=11.5,
        y=0.94,
    )
    name = "work_precision_families.png"
    fig.savefig(fig_dir / name)
    return (
        name,
        "Largest of the four relative errors (contact time, restitution, maximum "
        "penetration, trajectory) against wall time per impact, one panel per scene and "
        f"so per potential family. Errors below {g(FLOOR)} are drawn at {g(FLOOR)}.",
    )


def _max_err(r) -> float:
    """Largest of the four relative errors of a row (inf when one is missing)."""
    vals = [r.get(c, math.nan) for c, _ in METRICS]
    vals = [float(v) for v in vals if v is not None]
    return max(vals) if vals and all(math.isfinite(v) for v in vals) else math.inf


def wp_summary(df: pd.DataFrame) -> list[dict]:
    """Per scene and method: best error, and the fastest setting reaching each target."""
    rows = []
    for scene in dict.fromkeys(df.scene):
        d = df[df.scene == scene]
        ex = d[d.method == "exact"]
        t_exact = float(ex.seconds.iloc[0]) if len(ex) else math.nan
        for method in dict.fromkeys(d.method):
            s = d[(d.method == method) & d.seconds.notna()]
            if s.empty:
                continue
            errs = s.apply(lambda r: _max_err(r.to_dict()), axis=1)
            best = errs.idxmin()
            row = {
                "scene": scene,
                "method": method,
                "best max error": float(errs[best]),
                "at setting": s.setting[best],
                "time at best [s]": float(s.seconds[best]),
            }
            for target in TARGETS:
                reach = s[errs <= target]
                if len(reach):
                    f = reach.seconds.idxmin()
                    row[f"fastest to ≤ {g(target)}"] = {
                        "setting": s.setting[f],
                        "seconds": float(s.seconds[f]),
                        "exact_faster_by": float(s.seconds[f]) / t_exact,
                    }
                else:
                    row[f"fastest to ≤ {g(target)}"] = {
                        "setting": "not reached",
                        "seconds": math.nan,
                        "exact_faster_by": math.nan,
                    }
            rows.append(row)
    return rows
