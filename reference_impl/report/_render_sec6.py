"""Section 6 of the report: the critical-step map, its kinds of failure, the criterion sensitivity."""

from __future__ import annotations

from reference_impl.claims.sec6_dt_safe_bound import kinds_below
from reference_impl.report._blocks import DETAILS, IMG, H, P, T, _num

__all__ = ["describe_recommendation", "dtmap_blocks"]


def describe_recommendation(settings: dict) -> str:
    """One line on the corrected bound (measured margins are in the table), from the
    factors the run used (results.json ``dt_crit_settings``)."""
    f = ", ".join(f"{k} {v:g}" for k, v in settings["recommend_factor"].items())
    fs = ", ".join(f"{k} {v:g}" for k, v in settings["recommend_factor_singular"].items())
    return (
        f"Recommended step (beyond the paper, `stability.recommend.recommended_step`): Δt_rec = "
        f"c · 2√(m / max U'') over the path, with c = {f}; when U'' is unbounded at onset "
        f"(leading exponent < 2) U''(q_max) is used with c = {fs}. The factors were set "
        f"from these measurements (smallest measured ratio / 1.3–1.7), so the margins "
        f"below are calibration margins; the suite also checks hold-out draws."
    )


def dtmap_blocks(r) -> list:
    rows = r["dt_crit_map"]
    by_scene = {}
    for x in rows:
        by_scene.setdefault(x["scene"], []).append(x)
    summ = []
    for scene, xs in by_scene.items():
        usable = [x for x in xs if not x["degenerate"]]
        below = [kinds_below(x) for x in usable]
        ratios = [x["ratio"] for x in usable if isinstance(x["ratio"], float)]
        rec = [x["recommended_ratio"] for x in xs if isinstance(x["recommended_ratio"], float)]
        n = len(usable)
        summ.append(
            [
                scene,
                str(len(xs)),
                str(len(xs) - n),
                f"{sum('runaway' in k for k in below)}/{n}",
                f"{sum('bounded' in k for k in below)}/{n}" if scene != "impact" else "–",
                f"{sum('accuracy' in k for k in below)}/{n}" if scene == "impact" else "–",
                _num(min(ratios), 4) if ratios else "–",
                _num(max(ratios), 4) if ratios else "–",
                _num(min(rec), 3) if rec else "–",
            ]
        )
    full = [
        [
            x["case"],
            _num(x["v0"], 3),
            x["scene"],
            x["geometry"],
            _num(x["dt_safe"]),
            _num(x["dt_crit"]),
            _num(x["ratio"], 4),
            x.get("failure_kind") or "none",
            ", ".join(kinds_below(x)) or "–",
            "yes" if x["holds"] else "NO",
            _num(x["recommended_dt"]),
            _num(x["recommended_ratio"], 3),
            x["counterexample_status"] or "",
        ]
        for x in rows
    ]
    fflags = [
        [None] * 6
        + [
            "bad" if not x["holds"] and not x["degenerate"] else None,
            None,
            "bad" if "runaway" in kinds_below(x) else None,
            "bad" if not x["holds"] else "good",
            None,
            "bad"
            if isinstance(x["recommended_ratio"], float) and x["recommended_ratio"] <= 1
            else None,
            None,
        ]
        for x in rows
    ]
    crit = sorted({x["criterion"] for x in rows})
    return [
        H(2, "4. Critical-step map", "dtcrit"),
        P(
            "Δt_crit is the smallest step at which velocity Verlet fails (searched on a grid and "
            "refined to 0.1 % of Δt_safe), for one impact (`impact`), a particle oscillating "
            "through a two-sided contact U(|q|) (`two-sided`) and repeated impacts between two "
            "walls (`two-walls`). Each failure has a kind: a runaway (an instability, the only "
            "kind that refutes the bound), a bounded excursion (large but saturating) or an "
            "impact accuracy limit (rebound energy gain above tolerance). Criteria: "
            + "; ".join(crit)
            + "."
        ),
        IMG(
            "dt_crit_map.png",
            "Δt_crit/Δt_safe against p for each scene, with the bound's "
            "line (1), bounded excursions (×) and the recommended corrected step (dashed/hollow).",
        ),
        P(describe_recommendation(r["dt_crit_settings"])),
        T(
            [
                "scene",
                "cases",
                "Δt_safe = 0 (degenerate)",
                "runaways below Δt_safe",
                "bounded at ≤ Δt_safe",
                "accuracy limit at ≤ Δt_safe",
                "min Δt_crit/Δt_safe",
                "max Δt_crit/Δt_safe",
                "min Δt_crit/Δt_rec",
            ],
            summ,
        ),
        P(next(c["evidence"] for c in r["claims"] if c["id"] == "sec6-dt-safe-bound")),
        *_sensitivity(r),
        DETAILS(
            f"All {len(rows)} rows of the map (times in s)",
            [
                T(
                    [
                        "case",
                        "v0",
                        "scene",
                        "geometry",
                        "Δt_safe",
                        "Δt_crit",
                        "Δt_crit/Δt_safe",
                        "failure kind",
                        "kinds at ≤ Δt_safe",
                        "bound holds",
                        "Δt_rec",
                        "Δt_crit/Δt_rec",
                        "failure",
                    ],
                    full,
                    fflags,
                )
            ],
        ),
    ]


def _fin(x) -> float | None:
    """A finite float of a results.json value ("inf", None and NaN give None)."""
    return x if isinstance(x, float) and x == x and abs(x) != float("inf") else None


def _sensitivity(r) -> list:
    rows = r.get("dt_crit_sensitivity") or []
    if not rows:
        return []

    def crit(x):
        if x["scene"] == "impact":
            return f"rebound gain > {x['tol']:g}"
        h = x.get("confirm_horizon")
        hz = f", confirmed within {int(h)} × N" if isinstance(h, (int, float)) and h == h else ""
        return f"E > {x['factor']:g} E0 within N = {int(x['n_steps']):,} steps{hz}"

    table = [
        [
            x["case"],
            x["scene"],
            crit(x),
            x.get("failure_kind") or "none",
            _num(x["ratio"], 4),
            _num(x.get("bounded_ratio"), 4) if x["scene"] != "impact" else "–",
        ]
        for x in rows
    ]
    groups: dict = {}
    for x in rows:
        groups.setdefault((x["case"], x["scene"]), []).append(x)
    res = r["dt_crit_settings"]["search_resolution"]
    lines = []
    for (case, scene), xs in groups.items():
        ratios = [v for v in (_fin(x["ratio"]) for x in xs) if v is not None]
        kinds = sorted({x.get("failure_kind") or "none" for x in xs})
        names = {"factor": "F", "n_steps": "N", "confirm_horizon": "horizon", "tol": "tol"}
        varied = [
            f"{short} {', '.join(f'{v:g}' for v in vals)}"
            for key, short in names.items()
            if len(vals := sorted({x.get(key) for x in xs if _fin(x.get(key)) is not None})) > 1
        ]
        what = f"criteria ({'; '.join(varied)})" if varied else "criteria"
        line = f"{case}, {scene}: {'/'.join(kinds)}"
        if ratios:
            line += (
                f" at Δt_crit/Δt_safe {min(ratios):.4f} to {max(ratios):.4f} over "
                f"{len(xs)} {what} (spread {max(ratios) - min(ratios):.4f})"
            )
        bounded = [v for v in (_fin(x.get("bounded_ratio")) for x in xs) if v is not None]
        if scene != "impact" and bounded:
            line += f", bounded excursions from {min(bounded):.4f} to {max(bounded):.4f}"
        lines.append(line)
    return [
        P(
            'How the measured Δt_crit/Δt_safe moves with the definition of "unstable" '
            "(factor, budget N and confirmation horizon of the sustained scenes, tolerance of "
            "the impact; m = k = v0 = 1, ratios are scale-free for power laws): "
            + "; ".join(lines)
            + f". A spread within the search bracket ({res:g} Δt_safe) means the step does not "
            "depend on the "
            "criterion; a larger spread is a property of the criterion (a threshold), "
            "not of the integrator."
        ),
        T(
            [
                "case",
                "scene",
                "criterion",
                "failure kind",
                "Δt_crit/Δt_safe",
                "bounded from Δt/Δt_safe",
            ],
            table,
        ),
    ]
