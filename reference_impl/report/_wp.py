"""Speed against error (work-precision diagrams) in the report: the figures.

Drawn from the study's rows (`reference_impl.studies.wp_summary.run_wp`, written to
results.json as ``work_precision``); nothing here runs a solver.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from reference_impl.report._common import g

__all__ = ["FLOOR", "METHOD_STYLE", "METRICS", "wp_figures", "wp_overview_figure"]

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


def _max_err(r) -> float:
    """Largest of the four relative errors of a row (inf when one is missing), as the
    study's `max_error` defines it."""
    vals = [r.get(c, math.nan) for c, _ in METRICS]
    vals = [float(v) for v in vals if v is not None]
    return max(vals) if vals and all(math.isfinite(v) for v in vals) else math.inf


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


def wp_figures(
    df: pd.DataFrame, fig_dir, scenes_info: dict, families: dict[str, str]
) -> list[tuple[str, str]]:
    """The per-family overview, then one figure per scene with four log-log panels;
    returns [(file name, caption)]. Raises ValueError for a method without a style."""
    from matplotlib.figure import Figure

    _require_styles(df)
    out = [wp_overview_figure(df, fig_dir, families)]
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
                ylabel="relative error [-]",
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


def wp_overview_figure(df: pd.DataFrame, fig_dir, families: dict[str, str]) -> tuple[str, str]:
    """One panel per scene (every family): the largest of the four relative errors
    against wall time, every method; returns (file name, caption). Raises ValueError for
    a method without a style."""
    from matplotlib.figure import Figure

    _require_styles(df)
    fam = families
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
            ylabel="largest relative error (t_c, e, q_max, q(t)) [-]",
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
