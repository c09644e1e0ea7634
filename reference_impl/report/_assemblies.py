"""Report section: the critical step in chains and packings (issue 39, section 6).

Everything is read from the results dict: the nonlinear table and the P_fail curves from
the measurement of the claim named in ``results["assemblies"]["claim"]`` (its
``measured.rows``, one home for that measurement), the linear closed-form checks from
``results["assemblies"]["linear"]``. The two figures are drawn from the same rows
(`assemblies_figures`) by the report's run. Absent ``assemblies`` (a results file written
before ``hcv-results/1.2``) the section is left out.
"""

from __future__ import annotations

import numpy as np

from reference_impl.report._blocks import IMG, H, P, T, _num, markdown_lines
from reference_impl.report.readme_table import _replace

__all__ = [
    "DOCS_END", "DOCS_START", "FIGURES", "assemblies_blocks", "assemblies_figures",
    "claim_rows", "docs_block", "rewrite_docs",
]  # fmt: skip

# The section's figures (in the report's figures/ directory), by what they show.
FIGURES = {"p_fail": "assemblies_p_fail.png", "factor": "assemblies_factor.png"}
# Markers of the dimensions d (chains 1, 2-D lattices 2, 3-D lattices 3).
_MARK = {1: "o", 2: "s", 3: "^"}
_LINESTYLE = ("-", "--", ":", "-.")
# The generated block of docs/assemblies.md (rewritten by `hcv report` into the checkout's
# reports/, as the README's verdict table).
DOCS_START = "<!-- assemblies:start -->"
DOCS_END = "<!-- assemblies:end -->"


def claim_rows(results: dict, claim_id: str) -> tuple[list[dict], dict]:
    """(rows, measured) of the claim ``claim_id``'s measurement in a results dict."""
    measured = next(c for c in results["claims"] if c["id"] == claim_id)["measured"]
    return measured["rows"], measured


def _paper(row: dict) -> float:
    """The row's Delta t_safe under the paper's convention (s)."""
    return float(row["dt_safe"]["paper"])


def assemblies_figures(rows: list[dict], fig_dir) -> list[str]:
    """Draw the P_fail curves and the factor against Z from the claim's rows.

    Parameters
    ----------
    rows : list of dict
        ``measured.rows`` of the claim ``sec6-assemblies`` (JSON-ready).
    fig_dir : Path
        Where the PNG files are written (names in `FIGURES`).

    Returns
    -------
    list of str
        The names written, ``figures/NAME.png`` as the report lists them.
    """
    from matplotlib.figure import Figure

    # P_fail(dt / dt_safe): one colour per case, one line style per horizon.
    fig = Figure(figsize=(11.5, 5.0), layout="constrained")
    ax = fig.subplots()
    for i, row in enumerate(rows):
        safe = _paper(row)
        for j, (h, curve) in enumerate(sorted(row["p_fail_by_horizon"].items(), key=_h)):
            if not curve:
                continue
            x = np.array([c[0] for c in curve]) / safe
            y = np.array([c[1] for c in curve])
            ax.step(
                np.concatenate([[0.0], x]), np.concatenate([[0.0], y]), where="post",
                color=f"C{i % 10}", ls=_LINESTYLE[j % len(_LINESTYLE)],
                label=f"{row['case']}, {int(h):,} steps",
            )  # fmt: skip
    ax.axvline(1.0, color="k", lw=0.8)
    ax.text(1.0, 0.02, " Δt_safe (paper)", fontsize=8, va="bottom")
    ax.set_xlabel("time step Δt / Δt_safe (paper: striker's mass and energy) [-]")
    ax.set_ylabel("P_fail(Δt): fraction of lanes with Δt_crit ≤ Δt [-]")
    ax.set_title("Undamped Hertz assemblies: fraction of the ensemble's lanes that run away")
    ax.set_xlim(left=0.0)
    ax.set_ylim(0.0, 1.02)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.grid(True, alpha=0.3)
    fig.savefig(fig_dir / FIGURES["p_fail"], dpi=130)

    # The factor (5 % point over dt_safe) against Z, 5-95 % as a bar, sqrt(d / 2Z) beside it.
    fig = Figure(figsize=(9.0, 5.0), layout="constrained")
    ax = fig.subplots()
    zs = np.linspace(1.5, 12.5, 200)
    for d in sorted({int(r["dim"]) for r in rows}):
        mine = [r for r in rows if int(r["dim"]) == d]
        z = np.array([float(r["coordination"]) for r in mine])
        lo = np.array([float(r["ratio_5"]) for r in mine])
        mid = np.array([float(r["ratio_50"]) for r in mine])
        hi = np.array([float(r["ratio_95"]) for r in mine])
        color = f"C{d - 1}"
        ax.errorbar(
            z, mid, yerr=[mid - lo, hi - mid], fmt="none", ecolor=color, alpha=0.5, capsize=3
        )
        ax.plot(z, lo, _MARK.get(d, "o"), color=color, label=f"d = {d}: 5 % point (the factor)")
        ax.plot(zs, np.sqrt(d / (2.0 * zs)), "--", color=color, lw=1.0,
                label=f"d = {d}: linear prediction √(d / (2Z))")  # fmt: skip
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xlabel("coordination number Z (contacts per body, walls counted) [-]")
    ax.set_ylabel("Δt_crit / Δt_safe (paper) [-]")
    ax.set_title("Factor by which Δt_safe must be reduced (bars: 5–95 % of the lanes)")
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.grid(True, alpha=0.3)
    fig.savefig(fig_dir / FIGURES["factor"], dpi=130)
    return [f"figures/{FIGURES[k]}" for k in ("p_fail", "factor")]


def _h(item) -> int:
    return int(item[0])


def _by_horizon(row: dict, long: dict | None) -> str:
    """The 5 % point at each horizon: "10,000: 0.31; 100,000: 0.25"; the horizon read from
    the long-horizon record marked "(record)"."""
    parts = sorted(row["ratio_by_horizon"].items(), key=_h)
    rec = str(long.get("horizon")) if long and row.get("from_record") else None
    return "; ".join(
        f"{int(h):,}: {_num(q['5'], 3)}" + (" (record)" if h == rec else "") for h, q in parts
    )


def _record_sentence(long: dict | None) -> str:
    """Which horizon came from the long-horizon record (its commit and date), or why the
    record was ignored; empty when the measurement read none (a quick run)."""
    if not long:
        return ""
    if long.get("merged"):
        runs = long.get("runs") or [dict(long, cases=long["merged"])]

        def run(x: dict) -> str:
            dirty = ", with uncommitted changes" if x.get("git_dirty") else ""
            return f"commit {str(x['commit'])[:12]}{dirty}, {x['date']}"

        when = (
            f"at {run(runs[0])}"
            if len(runs) == 1
            else "; ".join(f"{', '.join(x['cases'])} at {run(x)}" for x in runs)
        )
        left = "; ".join(f"{c}: {why}" for c, why in (long.get("left_out") or {}).items())
        return (
            f" The {int(long['horizon']):,}-step horizon (marked “record”) of "
            f"{', '.join(long['merged'])} is not measured in this run but read from the record "
            f"`{long['source']}` (written by `python -m reference_impl.campaign.assembly_long` "
            f"{when}: the claim's lanes, grid and criterion), after its settings were checked "
            "against the claim's" + (f"; not in it: {left}" if left else "") + "."
        )
    if long.get("note"):
        return f" The long-horizon record was not used ({long['note']}): shorter horizons only."
    return ""


def _nonlinear(rows: list[dict], measured: dict) -> list:
    table, flags = [], []
    for x in rows:
        safe = x["dt_safe"]
        table.append(
            [
                x["case"],
                str(x["n_bodies"]),
                str(x["dim"]),
                _num(x["coordination"], 3),
                _num(safe["paper"], 4),
                f"{_num(safe['reduced'], 4)} / {_num(safe['one_contact'], 4)}",
                _num(x["ratio_5"], 3),
                _num(x["ratio_50"], 3),
                _num(x["ratio_95"], 3),
                _num(x["linear_prediction"], 3),
                _num(x["tangent_ratio"], 3),
                _by_horizon(x, measured.get("long_horizon")),
                "yes" if x["horizon_dependent"] else "no",
                "yes" if x["holds"] else "NO",
            ]
        )
        below = isinstance(x["ratio_5"], (int, float)) and x["ratio_5"] < 1
        flags.append([None] * 6 + ["bad" if below else "good"] + [None] * 5
                     + ["warn" if x["horizon_dependent"] else None]
                     + ["good" if x["holds"] else "bad"])  # fmt: skip
    horizons = ", ".join(f"{int(h):,}" for h in measured["horizons"])
    return [
        P(
            f"Undamped Hertz chains and lattices (the claim's measurement): per case an "
            f"ensemble of {measured['n_lanes']} lanes whose initial velocities differ in the "
            f"last bits, each with its own Δt_crit search, at horizons of {horizons} steps. "
            "Δt_crit/Δt_safe is given at the 5, 50 and 95 % points of the lanes (longest "
            "horizon); Δt_safe is the paper's (the striker's mass and energy), beside it the "
            "reduced-mass and all-energy-in-one-contact conventions. The factor by which "
            "Δt_safe must be reduced is the 5 % point where it is below 1; √(d/(2Z)) is the "
            "linear prediction (2/ω_max of a lattice of coordination Z in d dimensions over "
            "the single contact's 2√(m/k)); the tangent step is 2/ω_max of the assembly "
            "linearised at the stiffest contact met. Horizon-dependent: the median at the "
            "longest horizon lies below the 5 % point at the shortest."
            + _record_sentence(measured.get("long_horizon"))
        ),
        T(
            [
                "case",
                "N",
                "d",
                "Z",
                "Δt_safe paper [s]",
                "Δt_safe reduced / one contact [s]",
                "Δt_crit/Δt_safe 5 %",
                "50 %",
                "95 %",
                "√(d/(2Z))",
                "tangent step/Δt_safe",
                "5 % point by horizon [steps: ratio]",
                "horizon-dependent",
                "Δt_safe ≤ Δt_crit (5 %)",
            ],
            table,
            flags,
        ),
    ]


def _linear(lin: dict) -> list:
    rows = [
        [
            x["case"],
            x["reference"],
            _num(x["dt_search"], 10),
            _num(x["dt_reference"], 10),
            _num(x["rel_diff"], 2),
            "yes" if x["holds"] else "NO",
        ]
        for x in lin["rows"]
    ]
    flags = [[None] * 4 + [None, "good" if x["holds"] else "bad"] for x in lin["rows"]]
    bad = sum(not x["holds"] for x in lin["rows"])
    return [
        P(
            f"The search itself, where the mechanics is linear: bonded springs "
            f"(k = {_num(lin['k'])} N/m, m = {_num(lin['m'])} kg, every body moving) have "
            f"Δt_crit = 2/ω_max exactly; the suite's search (criterion {lin['criterion']}) "
            f"must reproduce it to {_num(lin['rtol'])} relative. "
            f"{len(rows) - bad} of {len(rows)} cases within it."
        ),
        T(
            [
                "case",
                "2/ω_max from",
                "Δt_crit searched [s]",
                "2/ω_max [s]",
                "|searched/2/ω_max − 1|",
                f"within {_num(lin['rtol'])}",
            ],
            rows,
            flags,
        ),  # fmt: skip
    ]


# HOOK (issue 39 section 4, the codes' step advice on assembly scenes): the codes study
# (LIGGGHTS fix check/timestep/gran, YADE PWaveTimeStep / GlobalStiffnessTimeStepper, LAMMPS,
# which gives none) fills ``results["assemblies"]["code_advice"]`` with one row per code,
# rule and scene (keys: ``code``, ``advice``, ``verdict``; optional ``scene``,
# ``dt_advice``, ``dt_crit``, ``factor``, ``note``; schema ``$defs/code_advice_row``).
# Rendered here when present; nothing in this module measures it.
def _code_advice(rows: list[dict]) -> list:
    table = [
        [
            x["code"],
            x.get("scene") or "–",
            x["advice"],
            _num(x.get("dt_advice"), 4),
            _num(x.get("dt_crit"), 4),
            _num(x.get("factor"), 3),
            x["verdict"],
            x.get("note") or "",
        ]
        for x in rows
    ]
    flags = [[None] * 6 + [{"safe": "good", "unsafe": "bad"}.get(x["verdict"]), None] for x in rows]
    return [
        P("The codes' own step advice on the same scenes, against the measured Δt_crit:"),
        T(
            [
                "code",
                "scene",
                "advice",
                "Δt advised [s]",
                "measured Δt_crit [s]",
                "Δt_crit / Δt advised",
                "verdict",
                "note",
            ],
            table,
            flags,
        ),  # fmt: skip
    ]


def assemblies_blocks(r: dict) -> list:
    """The section's blocks; none when the results dict has no ``assemblies``."""
    a = r.get("assemblies")
    if not a:
        return []
    rows, measured = claim_rows(r, a["claim"])
    blocks = [
        H(2, "Assemblies: Δt_safe in chains and packings (section 6, issue 39)", "assemblies"),
        *_nonlinear(rows, measured),
        IMG(
            a["figures"]["p_fail"].split("/")[-1],
            "P_fail(Δt): the fraction of an ensemble's lanes whose Δt_crit is at or below Δt "
            "(over the paper's Δt_safe), per case and horizon; lanes that never failed within "
            "the search's range are not counted.",
        ),
        IMG(
            a["figures"]["factor"].split("/")[-1],
            "Δt_crit/Δt_safe against the coordination number Z: the 5 % point of the lanes "
            "(the factor), bars from 5 to 95 %, and the linear prediction √(d/(2Z)).",
        ),
        *_linear(a["linear"]),
    ]
    if a.get("code_advice"):
        blocks += _code_advice(a["code_advice"])
    return blocks


def docs_block(r: dict) -> str:
    """The section as docs/assemblies.md shows it (Markdown, figures linked into the
    checkout's ``reports/figures``), headed by the report it comes from."""
    env = r["environment"]
    load = env.get("load_average_start")
    source = (
        f"Generated from the {r['mode']} report of {r['generated_utc']} (commit "
        f"{str(env.get('git_commit') or 'unknown')[:12]}"
        + (", with uncommitted changes" if env.get("git_dirty") else "")
        + (f", load average {load[0]:.2f} at its start" if isinstance(load, list) else "")
        + "); the report's own page is `reports/index.html`."
    )
    blocks = assemblies_blocks(r)[1:]  # the page has its own title
    if not blocks:
        source += (
            " That report predates the assemblies section (results.json without "
            "`assemblies`): the next `hcv report` into `reports/` writes it here."
        )
    out: list[str] = [source, ""]
    markdown_lines(blocks, out)
    return "\n".join(out).replace("](figures/", "](../reports/figures/").rstrip("\n")


def rewrite_docs(r: dict, text: str) -> str:
    """docs/assemblies.md with only its generated block replaced by `docs_block` of ``r``."""
    return _replace(text, DOCS_START, DOCS_END, docs_block(r))
