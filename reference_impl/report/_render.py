"""HTML (self-contained) and Markdown renderings of the results dict.

Both are built from the same section builders: each returns a list of blocks
(heading, paragraph, table, image, list, details) that the two writers format
(`reference_impl.report._blocks.markdown_lines`, `reference_impl.report._html.html_lines`).
Every number shown comes from ``results``.
"""

from __future__ import annotations

import html
from pathlib import Path

from reference_impl.report._assemblies import assemblies_blocks
from reference_impl.report._blocks import DETAILS, IMG, UL, H, P, T, _num
from reference_impl.report._blocks import markdown_lines as _md
from reference_impl.report._codes import codes_blocks
from reference_impl.report._common import g
from reference_impl.report._erratum import blocks as _erratum_blocks
from reference_impl.report._erratum import script_path as _script_path
from reference_impl.report._html import CSS as _CSS
from reference_impl.report._html import html_lines as _html
from reference_impl.report._laws import laws_blocks
from reference_impl.report._render_adapters import _adapters
from reference_impl.report._render_sec6 import dtmap_blocks
from reference_impl.report._steps import resolution_blocks
from reference_impl.report._text import markdown_text as _md_text

VERDICT_MARK = {"verified": "✔ verified", "refuted": "✘ refuted", "inconclusive": "? inconclusive"}
TABLE1_NAMES = {"delta_max": "δmax", "max_force": "U'(δmax)", "dt_safe": "Δt_safe"}


# ----------------------------------------------------------------------------------
# sections
# ----------------------------------------------------------------------------------
def _header(r) -> list:
    env = r["environment"]
    commit = env.get("git_commit") or "unknown"
    dirty = " (with uncommitted changes)" if env.get("git_dirty") else ""
    blocks = [
        P(
            f"Generated {r['generated_utc']} by `hcv report`{' --quick' if r['mode'] == 'quick' else ''}"
            f" in {r['timings_seconds']['total']:.1f} s on {env['cpu_count']} CPU(s); commit "
            f"{commit[:12]}{dirty}. Every result below was computed by this run"
            f"{_carried_note(r)}. Numbers typed in "
            f"are inputs only: the paper's data (Table 1 as printed, the Fig. 1 settings, "
            f"0.735 a, 3e-13), the parameters of the scenes and cases, and the tolerances of the "
            f"verdict rules, which are stated with each verdict."
        ),
    ]
    if r["mode"] == "quick":
        blocks.append(P("Quick mode: this report leaves out part of the study:", "warn"))
        blocks.append(UL(r["quick_drops"]))
    counts = {v: sum(c["verdict"] == v for c in r["claims"]) for v in VERDICT_MARK}
    blocks.append(P("Verdicts: " + ", ".join(f"{n} {v}" for v, n in counts.items() if n) + "."))
    return blocks


def _carried_note(r) -> str:
    """The header's exception when the code sections were carried from another run."""
    c = r.get("carried")
    if not c:
        return ""
    return (
        f", except the contact codes' sections, carried from the report of "
        f"{c['generated_utc']} (commit {str(c.get('git_commit') or 'unknown')[:12]}) and "
        "marked there"
    )


def _tests_cell(tests: list[str]) -> str:
    """``file::test`` names grouped by file: "test_sec4_action.py (5)"."""
    per_file: dict[str, int] = {}
    for t in tests:
        f = t.split("::")[0]
        per_file[f] = per_file.get(f, 0) + 1
    return ", ".join(f"{f} ({n})" for f, n in per_file.items()) or "–"


def _ledger(r) -> list:
    rows, flags = [], []
    for c in r["claims"]:
        rows.append(
            [
                c["id"],
                c["section"],
                VERDICT_MARK[c["verdict"]],
                c["evidence"],
                f"{_tests_cell(c['tests'])}; script `{_script_path(c['id'])}`",
            ]
        )
        flags.append(
            [
                None,
                None,
                "good"
                if c["verdict"] == "verified"
                else "bad"
                if c["verdict"] == "refuted"
                else "warn",
                None,
                None,
            ]
        )
    statements = UL(
        [f"{c['id']} ({c['section']}): {c['statement']} Rule: {c['rule']}." for c in r["claims"]]
    )
    return [
        H(2, "1. Claims ledger", "claims"),
        T(
            [
                "claim",
                "paper section",
                "verdict",
                "evidence (measured in this run)",
                "tests; independent script",
            ],
            rows,
            flags,
            cls="ledger",
        ),
        DETAILS(
            "The claims as the paper states them, and the rule that decided each verdict",
            [statements],
        ),
    ]


def _table1(r) -> list:
    headers = ["v0 [m/s]"]
    for col in ("delta_max", "max_force", "dt_safe"):
        unit = r["table1"][0][col]["unit"]
        headers += [
            f"{TABLE1_NAMES[col]} printed [{unit}]",
            f"{TABLE1_NAMES[col]} computed",
            "Δ [last digit]",
        ]
    rows, flags, bad = [], [], 0
    for row in r["table1"]:
        cells, fl = [row["v0"]], [None]
        for col in ("delta_max", "max_force", "dt_safe"):
            c = row[col]
            ok = c["match"]
            bad += not ok
            mark = "" if ok else "✘ "
            cells += [
                c["printed"],
                f"{mark}{c['computed_rounded']} ({c['computed']})",
                f"{c['difference_in_last_digit']:+.2f}",
            ]
            fl += [None if ok else "bad", "good" if ok else "bad", None if ok else "bad"]
        rows.append(cells)
        flags.append(fl)
    return [
        H(2, "2. Table 1 reproduced", "table1"),
        P(
            "The paper's ellipsoid (a = 0.015 m, b = c = 0.008 m, m = 0.05 kg, Kn = 1e8, "
            "α = 0.5) recomputed at 50 digits: δmax solves U(δ) = m v0²/2, the force is "
            "U'(δmax), Δt_safe = 2 m v0 / U'(δmax). Computed values are rounded to the printed "
            "number of digits (15 significant digits in parentheses); Δ is computed − printed "
            "in units of the printed last digit. Cells marked ✘ do not match."
        ),
        T(headers, rows, flags),
        P(
            next(c["evidence"] for c in r["claims"] if c["id"] == "table1")
            + f" ({bad} cells flagged above)."
        ),
    ]


def _fig1(r) -> list:
    f = r["fig1"]
    rows = [
        [
            _num(x["v0"], 3),
            _num(x["C0"]),
            _num(x["zeta"]),
            str(x["steps"]),
            _num(x["drift"], 3),
            _num(x["H_end_over_H0"], 5),
            _num(x["restitution"], 6),
            _num(x["restitution_theory"], 6),
            _num(x["identity_err"], 2),
            _num(x["exact_dev"], 2),
        ]
        for x in f["runs"]
    ]
    claimed = next(c for c in r["claims"] if c["id"] == "fig1")["measured"]["claimed"]
    flags = [
        [None] * 4 + ["bad" if x["drift"] >= claimed else "good"] + [None] * 5 for x in f["runs"]
    ]
    return [
        H(2, "3. Fig. 1 regenerated", "fig1"),
        P(
            f"Ellipsoid, α = 0.5, Kn = 1e8, K = 1, M = 0.75; C0 = 0 dashed and 0.5 solid; "
            f"v0 = 0.50, 0.99, 1.50 m/s; physical ODE integrated with RK45 (Dormand–Prince "
            f"5(4), as ode45) at RelTol = {g(f['rtol'])}, AbsTol = {g(f['atol'])}, with τ as "
            f"an extra state. Panel (d) is not in the paper: the measured drift of "
            f"H = M x'²/2 + K x²/2 at the solver's steps."
        ),
        IMG(
            "fig1.png",
            "Fig. 1: (a) physical phase space, (b) transformed phase space, "
            "(c) time series, (d) transformed-energy drift (C0 = 0).",
        ),
        T(
            [
                "v0 [m/s]",
                "C0",
                "ζ = C0/(2√(KM))",
                "RK45 steps",
                "max |H/H0 − 1|",
                "H_end/H0",
                "e measured",
                "e = exp(−πζ/√(1−ζ²))",
                "|H/E_phys − 1|",
                "max |x − x_exact(τ)| / amplitude",
            ],
            rows,
            flags,
        ),
        P(next(c["evidence"] for c in r["claims"] if c["id"] == "fig1")),
    ]


def _wp(r) -> list:
    present = list(dict.fromkeys(x["scene"] for x in r["work_precision"]))
    scenes = {k: v for k, v in r["work_precision_scenes"].items() if k in present}
    summ = r["work_precision_summary"]
    tkeys = [k for k in summ[0] if k.startswith("fastest to")]
    summ_rows = []
    for x in summ:
        row = [
            x["scene"],
            x["method"],
            _num(x["best max error"], 2),
            x["at setting"],
            _num(x["time at best [s]"], 3),
        ]
        for k in tkeys:
            t = x[k]
            row += [
                t["setting"],
                _num(t["seconds"], 3),
                _num(t["exact_faster_by"], 3) if x["method"] != "exact" else "–",
            ]
        summ_rows.append(row)
    headers = ["scene", "method", "best max error", "at setting", "time [s]"]
    for k in tkeys:
        tgt = k.replace("fastest to ", "")
        headers += [f"fastest setting to {tgt}", "time [s]", "time / exact solver time"]
    full = []
    for x in r["work_precision"]:
        full.append(
            [x["scene"], x["method"], x["setting"], _num(x.get("seconds"), 3)]
            + [
                _num(x.get(k), 2)
                for k in (
                    "err_contact_time",
                    "err_restitution",
                    "err_max_penetration",
                    "err_trajectory",
                )
            ]
            + [x.get("failure") or ""]
        )
    blocks = [
        H(2, "5. Speed against error", "wp"),
        P(
            "Work-precision diagrams as SciMLBenchmarks draws them: relative error against "
            "wall time per impact (median of repeats in one process), against a 30-digit "
            "mpmath ground truth (`workprecision.ground_truth`). Runs: "
            + r["work_precision_settings"]
            + ". Velocity Verlet is the lane engine's "
            "algorithm and force kernel (compiled), with the contact starting at a step "
            "boundary and the dashpot on the half-step velocity; its trajectory is "
            "interpolated by cubic Hermite from (q_n, v_n). Scenes:"
        ),
        UL([f"{k}: {v}" for k, v in scenes.items()]),
    ]
    load = wp_load_sentence(r)
    if load:
        blocks.append(P(load))
    fam = r["work_precision_families"]["rows"]
    blocks.append(
        P(
            "Every potential family has a scene (the added sphere, sum of power laws and user "
            "expression run the exact solver, DOP853 and RK45 only; their trajectory truth, "
            "like the others', evaluates U, U' at 30 digits). Per family, from the measured "
            "rows (largest of the four relative errors; DOP853 at the rtol nearest "
            f"{g(r['work_precision_families']['dop853_rtol'])} run):"
        )
    )
    blocks.append(
        UL(
            [
                f"{x['family']}, scene {x['scene']}: exact solver {_num(x['exact_seconds'], 3)} s "
                f"per impact, error {_num(x['exact_max_error'], 2)} (its own contact-time "
                f"bound {_num(x['exact_contact_time_bound'], 2)}); DOP853 at "
                f"{x['dop853_setting']}: {_num(x['dop853_seconds'], 3)} s, error "
                f"{_num(x['dop853_max_error'], 2)}, {_num(x['dop853_over_exact'], 3)}× the "
                "exact solver's time"
                for x in fam
            ]
        )
    )
    caps = r.get("figure_captions", {})
    for name in r["figures"]:
        n = name.split("/")[-1]
        if n.startswith("work_precision_"):
            blocks.append(IMG(n, caps.get(n, n)))
    blocks += [
        P(
            "Summary: per scene and method, the smallest maximum error over the four "
            "metrics, and the fastest setting whose four errors are all at or below each "
            "target (its wall time, and that time divided by the exact solver's)."
        ),
        T(headers, summ_rows),
        DETAILS(
            f"All {len(full)} rows (relative errors)",
            [
                T(
                    [
                        "scene",
                        "method",
                        "setting",
                        "seconds",
                        "t_c",
                        "e",
                        "q_max",
                        "q(t)",
                        "failure",
                    ],
                    full,
                )
            ],
        ),
    ]
    return blocks


def _hard(r) -> list:
    hc = r["hard_cases"]
    st = hc["settings"]
    rows = []
    for x in hc["cases"]:
        qa = x.get("q_max_over_a")
        rows.append(
            [
                x["case"],
                _num(x.get("v0"), 3),
                _num(x.get("q_max"), 3) + (f" ({qa:.5g} a)" if isinstance(qa, float) else ""),
                x.get("geometry", "–"),
                _num(x.get("dt_safe"), 3),
                _num(x.get("shortcut_over_safe"), 4),
                _num(x.get("dtcrit_over_safe"), 3),
                _num(x.get("dtcrit_over_rec"), 3),
                _num(x.get("exact_err_t_c"), 2),
                _num(x.get("ode_err_t_c"), 2),
                _num(x.get("verlet_err_t_c"), 2),
                "; ".join(x.get("notes", [])),
            ]
        )
    return [
        H(2, "6. Hard cases", "hard"),
        P(
            "Each case runs every part of the suite: the section 6 bound (`dt_safe`, its "
            "geometry class and the endpoint shortcut 2 m v0/U'(q_max)), the measured critical "
            f"step of one impact, the exact solver and scipy DOP853 (rtol {g(st['ode_rtol'])}) "
            f"against a {st['mp_dps']}-digit mpmath contact time (the physical integral for "
            "conservative contacts, `solve_impact_mp` for damped ones), and velocity Verlet at "
            f"{st['verlet_steps']} steps per contact. For a fixed shape the dimensionless problem depends on Kn and v0 only "
            "through q_max/a, so the depth sweep covers the stiffness range as well."
        ),
        T(
            [
                "case",
                "v0 [m/s]",
                "q_max [m]",
                "geometry",
                "Δt_safe [s]",
                "shortcut/Δt_safe",
                "Δt_crit/Δt_safe",
                "Δt_crit/Δt_rec",
                "exact t_c err",
                "DOP853 t_c err",
                "Verlet t_c err",
                "notes",
            ],
            rows,
        ),
        P("Where accuracy is lost (measured):"),
        UL(hc["accuracy"]),
        IMG(
            "hard_cases.png",
            "Errors against impact speed (Hertz) and penetration depth "
            "(ellipsoid), and the bound near 2a.",
        ),
    ]


def _load_cell(pair, cores) -> str:
    """``start / end`` of one stage's 1-minute load, flagged when over the cores."""
    if not pair:
        return "–"
    text = " / ".join("–" if x is None else f"{x:g}" for x in pair)
    over = cores and any(x is not None and x > cores for x in pair)
    return f"{text} (over {cores} cores)" if over else text


def wp_load_sentence(r) -> str | None:
    """The load while the speed-against-error timings ran, and a warning when it exceeded
    the cores (issue 41: the main job re-measured them at load 15 without a word)."""
    pair = (r.get("stage_loads") or {}).get("speed against error")
    cores = r["environment"].get("cpu_count")
    if not pair or any(x is None for x in pair):
        return None
    text = f"These timings ran at a 1-minute load of {pair[0]:g} to {pair[1]:g} on {cores} cores"
    if cores and max(pair) > cores:
        return text + ": above the cores, so other work slowed them; compare ratios, not times."
    return text + "."


def _env(r) -> list:
    env = r["environment"]
    rows = [[k, str(v)] for k, v in env.items() if k not in ("packages", "seeds")]
    rows += [[f"package {k}", str(v)] for k, v in env["packages"].items()]
    rows += [[f"seed {k}", str(v)] for k, v in env["seeds"].items()]
    loads = r.get("stage_loads") or {}  # hcv-results/1.3; older files: no column
    cores = env.get("cpu_count")
    if loads:
        trows = [
            [k, f"{v:.2f}", _load_cell(loads.get(k), cores)]
            for k, v in r["timings_seconds"].items()
        ]
        theads = ["step", "seconds", "load (1 min) at start / end"]
    else:
        trows = [[k, f"{v:.2f}"] for k, v in r["timings_seconds"].items()]
        theads = ["step", "seconds"]
    return [
        H(2, "7. Environment and provenance", "env"),
        T(["item", "value"], rows),
        P(
            "Wall time of each step of this run (s)"
            + (
                f", with the load beside it (over the {cores} cores: slowed by other work):"
                if loads
                else ":"
            )
        ),
        T(theads, trows),
        P(
            "Reproduce: `hcv report` (full) or `hcv report --quick`; the machine-readable "
            "results are in results.json next to this page. HYPOTHESIS_PROFILE and the "
            "hypothesis seeds apply to the pytest suite; the report's only random draw is "
            "the (K, M) pairs of the Theorem 2 check, with the seed above."
        ),
    ]


def _sections(r) -> list:
    return (
        _header(r)
        + _ledger(r)
        + _erratum_blocks(r)
        + _table1(r)
        + _fig1(r)
        + dtmap_blocks(r)
        + assemblies_blocks(r)
        + _wp(r)
        + laws_blocks(r)
        + _hard(r)
        + _adapters(r)
        + codes_blocks(r)
        + resolution_blocks(r)
        + _env(r)
    )


# ----------------------------------------------------------------------------------
# Markdown
# ----------------------------------------------------------------------------------
def markdown(r: dict) -> str:
    out = [f"# {_md_text(r['title'])}\n"]
    _md(_sections(r), out)
    return "\n".join(out) + "\n"


# ----------------------------------------------------------------------------------
# HTML
# ----------------------------------------------------------------------------------
def html_page(r: dict, fig_dir: Path) -> str:
    nav = (
        "<nav>"
        + "".join(
            f'<a href="#{a}">{t}</a>'
            for a, t in (
                ("claims", "Claims"),
                ("erratum", "Erratum"),
                ("table1", "Table 1"),
                ("fig1", "Fig. 1"),
                ("dtcrit", "Critical step"),
                *([("assemblies", "Assemblies")] if r.get("assemblies") else []),
                ("wp", "Speed vs error"),
                ("hard", "Hard cases"),
                *([("adapters", "Contact codes")] if r.get("adapters") else []),
                *([("codes", "Codes side by side")] if r.get("codes_side_by_side") else []),
                ("env", "Environment"),
            )
        )
        + "</nav>"
    )
    out = [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{html.escape(r['title'])}</title>",
        f"<style>{_CSS}</style>",
        "</head>",
        "<body>",
        f"<h1>{html.escape(r['title'])}</h1>",
        nav,
    ]
    _html(_sections(r), fig_dir, out)
    out += ["</body>", "</html>"]
    return "\n".join(out) + "\n"
