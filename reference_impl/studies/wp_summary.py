"""Speed against error for the report: the study's runs and the summaries drawn from them.

`run_wp` runs `reference_impl.studies.workprecision.work_precision` on the report's
scenes; `wp_summary` and `family_summary` turn its rows into the report's tables
(written to results.json; the report only renders them).
"""

from __future__ import annotations

import math

import pandas as pd

from reference_impl._format import g
from reference_impl.studies.workprecision import (
    IVP_METHODS,
    IVP_RTOLS,
    VERLET_STEPS,
    default_scenes,
    work_precision,
)

__all__ = [
    "ERR_COLUMNS",
    "FAMILY_NAMES",
    "QUICK_SKIP",
    "SUMMARY_RTOL",
    "TARGETS",
    "family_summary",
    "max_error",
    "report_scenes",
    "run_wp",
    "scene_families",
    "settings_text",
    "wp_summary",
]

# The four relative errors of a row (contact time, restitution, maximum penetration, trajectory).
ERR_COLUMNS = ("err_contact_time", "err_restitution", "err_max_penetration", "err_trajectory")
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
    "saturating": "saturating force",
}
# The DOP853 tolerance the per-family summary quotes (the row whose rtol is nearest in log).
SUMMARY_RTOL = 1e-12


def scene_families() -> dict[str, str]:
    """{scene name: family label} for `default_scenes`."""
    return {
        s.name: FAMILY_NAMES.get(
            s.potential.family, s.potential.label or type(s.potential).__name__
        )
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
                "exact_max_error": max_error(e),
                "exact_contact_time_bound": float(e.get("contact_time_bound", math.nan)),
                "dop853_setting": d["setting"] if d else "not run",
                "dop853_seconds": float(d["seconds"]) if d else math.nan,
                "dop853_max_error": max_error(d) if d else math.nan,
                "dop853_over_exact": float(d["seconds"]) / float(e["seconds"]) if d else math.nan,
            }
        )
    return out


def report_scenes(quick: bool) -> list:
    """The scenes `run_wp` runs (`default_scenes`; quick: without `QUICK_SKIP`)."""
    return [s for s in default_scenes() if not (quick and s.name in QUICK_SKIP)]


def run_wp(quick: bool, progress=None) -> pd.DataFrame:
    """`work_precision` with the report's Verlet points (quick: without `QUICK_SKIP`)."""
    return work_precision(report_scenes(quick), quick=quick, progress=progress)


def max_error(r) -> float:
    """Largest of the four relative errors of a row (inf when one is missing)."""
    vals = [r.get(c, math.nan) for c in ERR_COLUMNS]
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
            errs = s.apply(lambda r: max_error(r.to_dict()), axis=1)
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
