"""The README's verdict table, generated from a report's results.json.

``python -m reference_impl.report.readme_table [--results reports/results.json]
[--readme README.md] [--check]`` rewrites only the block between
``<!-- verdicts:start -->`` and ``<!-- verdicts:end -->`` of the README with one
row per claim of results.json (id, section, verdict, headline), and, when
``reports/bench/exact.json`` exists (``nox -s bench``), the block between
``<!-- speed:start -->`` and ``<!-- speed:end -->`` with the exact solver's speed
and error per potential family as that benchmark measured them, and, when
``reports/bench/startup.json`` exists, the block between ``<!-- startup:start -->`` and
``<!-- startup:end -->`` with the start-up times of `benchmarks.bench_startup`; the speed
block links the work-precision figure when ``reports/bench/workprecision.json`` exists
(`benchmarks.bench_workprecision`) and states `solve_impacts` against the parallel peer when
``reports/bench/batch_peer.json`` exists (`benchmarks.bench_batch_peer`). ``--check``
writes nothing and exits 1 when a block differs from what the JSON files give.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from reference_impl.errors import HCVInputError
from reference_impl.report._schema import read_results
from reference_impl.report._text import markdown_text
from reference_impl.report._wp_goals import goals_text

__all__ = [
    "START",
    "END",
    "SPEED_START",
    "SPEED_END",
    "verdict_table",
    "speed_table",
    "workprecision_text",
    "batch_goal",
    "batch_peer_text",
    "STARTUP_START",
    "STARTUP_END",
    "startup_table",
    "readme_block",
    "rewrite_readme",
]

START = "<!-- verdicts:start -->"
END = "<!-- verdicts:end -->"
SPEED_START = "<!-- speed:start -->"
SPEED_END = "<!-- speed:end -->"
STARTUP_START = "<!-- startup:start -->"
STARTUP_END = "<!-- startup:end -->"
ROOT = Path(__file__).resolve().parents[2]


def _cell(text: str) -> str:
    """A table cell: no column break, no line break, no raw HTML or unsafe link (`_text`)."""
    return markdown_text(str(text).replace("|", "\\|").replace("\n", " "))


def verdict_table(results: dict) -> str:
    """Markdown table: claim | section | verdict | in one line (refuted in bold)."""
    lines = ["| claim | section | verdict | in one line (measured) |", "|---|---|---|---|"]
    for c in results["claims"]:
        verdict = f"**{_cell(c['verdict'])}**" if c["verdict"] != "verified" else c["verdict"]
        headline = c.get("headline") or c["evidence"].split(";")[0]
        lines.append(
            f"| {_cell(c['id'])} | {_cell(c['section'])} | {verdict} | {_cell(headline)} |"
        )
    env = results.get("environment", {})
    commit = (env.get("git_commit") or "unknown")[:12]
    dirty = " (uncommitted changes)" if env.get("git_dirty") else ""
    lines += [
        "",
        markdown_text(
            f"Generated from `reports/results.json` ({results.get('mode', '?')} run of "
            f"{results.get('generated_utc', '?')}, commit {commit}{dirty}{_run_cost(results)}) "
            f"by `python -m reference_impl.report.readme_table`."
        ),
    ]
    return "\n".join(lines)


def _run_cost(results: dict) -> str:
    """``; N s wall on C cores at load A to B, compile cache ...`` of the run (issue 41:
    the main job's time has its one home here, with what it depends on)."""
    env = results.get("environment", {})
    total = results.get("timings_seconds", {}).get("total")
    if total is None:
        return ""
    codes = [d.get("adapter") for d in results.get("adapters") or []]
    with_codes = (
        f" with {', '.join(map(str, codes))}" if codes and not results.get("carried") else ""
    )
    start, end = env.get("load_average_start"), env.get("load_average_end")
    load = f" at load {start[0]:g} to {end[0]:g}" if start and end else ", load not recorded"
    cache = env.get("compile_cache_start")
    if cache is None:
        state = "compile cache not recorded"
    else:
        state = (
            "empty compile cache"
            if not cache.get("entries")
            else (f"compile cache holding {cache['entries']} kernels")
        )
    return f"; {total:.0f} s wall{with_codes} on {env.get('cpu_count', '?')} cores{load}, {state}"


# Short names of the peers of `benchmarks._peers` (a record's ``peer_name``), for the cells.
_PEER_SHORT = {
    "dop853": "DOP853",
    "dop853_sqrt": "DOP853 q√q",
    "sundman": "Sundman DOP853",
    "numbalsoda": "numbalsoda",
}


def _peer_name(r: dict) -> str:
    """The row's peer, short: a record before the peer columns (issue 38) had the plain
    compiled DOP853 alone."""
    return _PEER_SHORT.get(r.get("peer_name", "dop853"), str(r.get("peer_name")))


def _peer_cell(r: dict) -> str:
    best = "" if r["peer_at_equal_error"] else ", its best"
    return (
        f"{_peer_name(r)}: {r['peer_us']:.0f} µs | {r['peer_max_rel_error']:.1e} "
        f"(rtol {r['peer_rtol']:.0e}{best})"
    )


def _peers_named(bench: dict) -> str:
    """The sentence naming the peers the rows were ranked among (the strongest of each row
    is its denominator), or saying that the record has the plain DOP853 alone."""
    labels = {}
    for r in (*bench.get("families", []), *bench.get("laws", [])):
        for name, col in (r.get("peers") or {}).items():
            labels.setdefault(name, col.get("label", name))
    if not labels:
        return (
            "The peer is `benchmarks/peer_dop853.py` (numba, the published Dormand–Prince "
            "8(5,3) tableau, events on its dense output, every output ours has), the only one "
            "in this record: the stronger peers of `benchmarks/_peers.py` (q·√q, "
            "Sundman-regularised) rank only from a rerun of `benchmarks.bench_exact`"
        )
    strongest = sorted({_peer_name(r) for r in (*bench["families"], *bench.get("laws", []))})
    return (
        "The peer of each row is the fastest at equal error of "
        + "; ".join(f"{_PEER_SHORT.get(k, k)} ({v})" for k, v in labels.items())
        + f" (the strongest here: {', '.join(strongest)})"
    )


def _row_sentences(bench: dict) -> list[str]:
    """One line per row: its one-shot and its prepared figure, each against its peer."""
    out = []
    for r in bench.get("families", []):
        prep = (
            f"; a `prepare(pot, m)` call {r['prepared_us']:.1f} µs (the peer "
            f"{r['prepared_ratio']:.1f}× as long)"
            if "prepared_us" in r
            else ""
        )
        out.append(
            f"- {_cell(r['scene'])}: a one-shot `solve_impact` takes {r['ours_us']:.1f} µs "
            f"({_peer_name(r)} at equal error takes {r['ratio']:.1f}× as long){prep}."
        )
    for r in bench.get("laws", []):
        prep = (
            f"; a `prepare_law` call {r['prepared_us']:.0f} µs (the peer "
            f"{r['prepared_ratio']:.2f}× as long)"
            if "prepared_us" in r
            else ""
        )
        out.append(
            f"- Hertz + {_cell(r['law'])}: a one-shot `solve_law_impact` takes "
            f"{r['ours_us']:.0f} µs ({_peer_name(r)} at equal error takes {r['ratio']:.2f}× "
            f"as long){prep}."
        )
    return out


# The laws every family of `benchmarks.bench_workprecision` runs under (the paragraph names
# them once); a law of the record run on fewer families is named with those families.
_WP_GRID_LAWS = ("universal", "linear")
_WP_FAMILY = {
    "Hertz p=1.5": "Hertz",
    "power p=2": "a q^2 force",
    "sphere (cap)": "the sphere's cap",
}
_WP_LAW = {"hunt-crossley": "Hunt-Crossley"}


def _wp_other_laws(wp: dict) -> str:
    """'; Hunt-Crossley on Hertz' for each law of the record's panels beyond `_WP_GRID_LAWS`
    (empty when there is none)."""
    by_law: dict[str, list[str]] = {}
    for p in wp.get("panels", []):
        law = p.get("law")
        name = law.get("law") if isinstance(law, dict) else law
        if name is None or name in _WP_GRID_LAWS:
            continue
        fam = p.get("family", "?")
        by_law.setdefault(name, []).append(_WP_FAMILY.get(fam, fam))
    return "".join(f"; {_WP_LAW.get(k, k)} on {', '.join(fams)}" for k, fams in by_law.items())


def workprecision_text(wp: dict) -> str:
    """The paragraph linking `benchmarks.bench_workprecision`'s figure, with what its record
    says of the run (impacts, blocks, load, commit)."""
    mi = wp.get("machine", {})
    n = min((p["impacts"] for p in wp.get("panels", [])), default=0)
    drawn = wp.get("impacts_drawn", n)  # the set each panel draws (before refusals)
    load = wp.get("load_average_1min")
    load = f"{load:.1f}" if isinstance(load, int | float) else "?"
    return (
        "Work-precision, ours as a curve: CPU time per impact against the largest relative "
        "error achieved over random impacts, from 1e-6 to 1e-15, for the one-shot and the "
        "prepared call at each `rtol` and for every peer over its tolerance ladder, per "
        "family (Hertz, a q^2 force, the sphere's cap) and law (universal, a linear "
        f"dashpot{markdown_text(_wp_other_laws(wp))}), the figure below "
        f"(`python -m benchmarks.bench_workprecision`; {drawn} random impacts drawn a panel, "
        f"at least {n} kept (the rest refused by ours or without an overlap end), "
        f"{wp.get('blocks', '?')} timing block(s), load {load}, commit "
        f"{str(mi.get('commit', '?'))[:12]}"
        + (
            "; a check that it runs, not a measurement: rerun it on a quiet machine"
            if wp.get("blocks", 0) < 3 or drawn < 1000
            else ""
        )
        + "). On a cap, a law of C(q) or Hunt-Crossley runs the Taylor kernel with the "
        "cap's factor (1 - q/3a)^alpha and trades with rtol (the viscoelastic and zeta laws "
        "stay on the GBS kernel at full accuracy: one point); under the universal law a cap "
        "keeps its fast Gauss-Jacobi pair where its bound is within rtol.\n\n"
        "![Work-precision: CPU time per impact against the largest relative error, ours "
        "(one-shot and prepared) and each peer, per family and law]"
        "(reports/bench/workprecision.png)"
    )


def _family_goal(r: dict) -> str:
    """'met', or by how much it is not and where the time goes (the compiled call alone)."""
    if r["goal_met"]:
        return "met"
    parts = []
    if r.get("prepared_identical") is False:
        parts.append("the prepared call differs from solve_impact")
    if r["ours_max_rel_error"] > 1e-14:
        parts.append(f"its error {r['ours_max_rel_error']:.1e} > 1e-14")
    if not r["peer_at_equal_error"]:
        parts.append("the peer never reaches equal error")
    if "time_over_goal" in r and r["time_over_goal"] > 1.0:
        parts.append(f"{r['time_over_goal']:.2f}× the 8 µs")
    if "ratio_short_of_goal" in r and r["ratio_short_of_goal"] > 1.0:
        parts.append(f"ratio {r['ratio_short_of_goal']:.2f}× short of 20×")
    if r.get("kernel_us") is not None:
        parts.append(f"its compiled call alone {r['kernel_us']:.1f} µs")
    return "**not met**" + (": " + ", ".join(parts) if parts else "")


def _batch_goal(b: dict) -> str:
    """'met', or by how much it is not and the serial part the speedup implies."""
    if b["goal_met"]:
        return "met"
    if not b["bit_identical_to_1_thread"]:
        return "**not met**: results differ from one thread's"
    s = b.get("implied_serial_fraction")
    if s is None or s < 0:  # no Amdahl reading (one core, or faster than the cores)
        return "**not met**"
    return f"**not met**: Amdahl's serial part implied: {100 * s:.0f} % of the one-thread time"


def _threads_figure(d: dict, fmt: str, unit: str = "") -> str:
    """'a on 1 thread, b on 2 threads' of a per-thread-count dict (keys: counts as text)."""
    return ", ".join(
        f"{format(v, fmt)}{unit} on {th} thread{'s' if th != '1' else ''}" for th, v in d.items()
    )


def _load_figure(x) -> str:
    return f"{x:.2f}" if isinstance(x, int | float) else "?"


def batch_goal(r: dict) -> str:
    """A row of `benchmarks.bench_batch_peer`'s record judged against goal 5: "met"; "not
    judged" where the one reason is that no peer reaches equal error (the ratio is then
    against the peer's most accurate rung, less accurate than ours: the goal, a ratio at
    equal error, cannot be read, as `_wp_goals` says of a panel no peer reaches); else
    "not met", with every reason."""
    why = "; ".join(_cell(g) for g in r["goal_not_met_because"])
    if r["goal_met"]:
        return "met"
    if not r["peer_at_equal_error"] and len(r["goal_not_met_because"]) == 1:
        return f"not judged: {why}"
    return f"**not met**: {why}"


def batch_peer_text(bp: dict) -> str:
    """The lines of `benchmarks.bench_batch_peer`'s record (issue 38, goal 5): per row, ours
    and the fastest peer run in a compiled parallel loop over the same impacts, the ratio on
    each thread count, the goal met or why not, and how the record was measured."""
    lines = []
    for r in bp["rows"]:
        eq = "" if r["peer_at_equal_error"] else ", its most accurate rung"
        goal = batch_goal(r)
        peers = ", ".join(
            f"{_PEER_SHORT.get(k, k)} {r['peer_us_per_impact'][th]:.1f} µs on {th} "
            f"thread{'s' if th != '1' else ''} (rtol {r['peer_rtol'][th]:.0e}{eq}; error "
            f"{r['peer_max_rel_error'][th]:.1e})"
            for th, k in r["peer"].items()
        )
        # a record of schema /2 holds ours' rung and its full-accuracy time beside it
        full = r.get("ours_full")
        rung = (
            ""
            if full is None or r.get("ours_rtol") is None
            else f", rtol {r['ours_rtol']:.0e}; at full accuracy "
            f"{_threads_figure(full['us_per_impact'], '.2f', ' µs')}, error "
            f"{full['max_rel_error']:.1e}, ratio {_threads_figure(full['ratio'], '.1f', '×')}"
        )
        lines.append(
            f"- `solve_impacts`, {_cell(r['row'])} ({r['impacts']} impacts): ours "
            f"{_threads_figure(r['us_per_impact'], '.2f', ' µs')} per impact (error "
            f"{r['ours_max_rel_error']:.1e}{rung}); the fastest peer in a parallel loop: {peers}; "
            f"ratio {_threads_figure(r['ratio'], '.1f', '×')} "
            f"(goal ≥ {bp['goal_ratio']:g}×: {goal}; load {_load_figure(r['load_average_1min'])})"
        )
    mi = bp.get("machine", {})
    lines += [
        "",
        "Batches against the fastest peer (`benchmarks/peer_batch.py`: the serial peer's very "
        "call, bit for bit, one impact per thread step of a numba `prange` loop; the rung at "
        f"equal error: {bp.get('equal_error', '?')}). Measured by `python -m "
        "benchmarks.bench_batch_peer --json reports/bench/batch_peer.json` "
        f"({bp.get('timing', '?')}; {mi.get('cpu_count', '?')} cpus, load "
        f"{_load_figure(bp.get('load_average_1min'))} before, "
        f"{_load_figure(bp.get('load_average_1min_after'))} after, commit "
        f"{str(mi.get('commit', '?'))[:12]}"
        + (
            "; a check that it runs, not a measurement: rerun it on a quiet machine"
            if bp.get("blocks", 0) < 3
            else ""
        )
        + ").",
    ]
    return "\n".join(lines)


def speed_table(bench: dict, wp: dict | None = None, batch_peer: dict | None = None) -> str:
    """Markdown tables of `benchmarks.bench_exact`'s JSON: the universal law per family, the
    general laws, the batch; every ratio against the fastest peer at equal error; one line
    per row with its one-shot and prepared figures; given ``wp`` (the record of
    `benchmarks.bench_workprecision`), the work-precision figure's paragraph; given
    ``batch_peer`` (the record of `benchmarks.bench_batch_peer`), its lines
    (`batch_peer_text`)."""
    lines = [
        "| scene (universal law) | `solve_impact` | `prepare(pot, m)` call | its error | fastest "
        "peer at equal error | its error | ratio (peer / prepared) | scipy DOP853 (rtol "
        "1e-12) | goal |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in bench["families"]:
        prep = f"{r['prepared_us']:.1f} µs" if "prepared_us" in r else "—"
        ratio = r.get("prepared_ratio", r["ratio"])
        lines.append(
            f"| {_cell(r['scene'])} | {r['ours_us']:.1f} µs | {prep} | "
            f"{r['ours_max_rel_error']:.1e} | {_peer_cell(r)} | {ratio:.1f}× | "
            f"{r['scipy_us'] / 1e3:.1f} ms | {_family_goal(r)} |"
        )
    laws = bench.get("laws", [])
    if laws:
        lines += [
            "",
            "| Hertz + damping law | `solve_law_impact` | `prepare_law(pot, m, law)` call | its "
            "error | fastest peer at equal error | its error | ratio (peer / one-shot) | "
            "ratio (peer / prepared) | scipy DOP853 (rtol 1e-12) | goal |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in laws:
            prep = f"{r['prepared_us']:.0f} µs" if "prepared_us" in r else "—"
            pratio = f"{r['prepared_ratio']:.2f}×" if "prepared_ratio" in r else "—"
            lines.append(
                f"| {_cell(r['law'])} | {r['ours_us']:.0f} µs | {prep} | "
                f"{r['ours_max_rel_error']:.1e} | {_peer_cell(r)} | {r['ratio']:.2f}× | {pratio} | "
                f"{r['scipy_us'] / 1e3:.1f} ms | {'met' if r['goal_met'] else '**not met**'} |"
            )
    lines.append("")
    for b in bench.get("batch", []):
        lines.append(
            f"- `solve_impacts`, {_cell(b['workload'])}: {b['us_per_impact_1_thread']:.2f} µs per "
            f"impact on 1 thread (CPU {b.get('cpu_us_per_impact_1_thread', float('nan')):.2f} µs), "
            f"{b['us_per_impact_all_threads']:.2f} µs on {b['threads']} "
            f"({b['parallel_speedup']:.2f}×, bit-identical: "
            f"{'yes' if b['bit_identical_to_1_thread'] else '**no**'}; goal {_cell(b['goal'])}: "
            f"{_batch_goal(b)})"
        )
    if batch_peer is not None:
        lines += ["", batch_peer_text(batch_peer)]
    mi = bench.get("machine", {})
    after = bench.get("load_average_1min_after")
    lines += ["", "Each row, one-shot and prepared:", "", *_row_sentences(bench)]
    if wp is not None:
        lines += ["", workprecision_text(wp), "", goals_text(wp)]
    lines += [
        "",
        "Error = the largest relative error over both ends' contact time and restitution and "
        "q_max (and the peak force for the laws), against "
        f"{bench.get('truth', '?')}. {_peers_named(bench)}. A peer runs over a tolerance "
        "ladder and is shown at its cheapest rung with the "
        f"{bench.get('equal_error', '?')}, or at its best rung when none gets there. "
        "Goals (issue 27): universal law ≤ 8 µs per prepared call and ≥ 20× the compiled "
        "DOP853 at ≤ 1e-14; general laws ≥ 3× (prepared call); `solve_impacts` ≥ 1.8× on 2 cores. "
        f"numbalsoda: {bench.get('numbalsoda', '?')}. Measured by `python -m "
        "benchmarks.bench_exact --json reports/bench/exact.json` "
        f"({bench.get('timing', '?')}; {mi.get('cpu_count', '?')} cpus, load {_load(bench)} "
        f"before, {after if after is None else f'{after:.2f}'} after, commit "
        f"{str(mi.get('commit', '?'))[:12]}).",
    ]
    return "\n".join(lines)


def _seconds(x) -> str:
    return f"{x:.2f} s" if x < 10 else f"{x:.0f} s"


def startup_table(bench: dict) -> str:
    """Markdown table of `benchmarks.bench_startup`'s JSON: one row per command."""
    lines = [
        "| command (new process) | first run, empty cache | then (median) | its CPU time | goal |",
        "|---|---|---|---|---|",
    ]
    for r in bench["cases"]:
        goal = r["goal_s"]
        verdict = (
            "—" if goal is None else (f"≤ {goal:g} s: {'met' if r['goal_met'] else '**not met**'}")
        )
        lines.append(
            f"| `{_cell(r['name'])}` | {_seconds(r['cold_wall_s'])} | {_seconds(r['warm_wall_s'])} "
            f"| {_seconds(r['warm_cpu_s'])} | {verdict} |"
        )
    e = bench["expression_over_power"]
    load = bench.get("load_average_1min", {})
    mi = bench.get("machine", {})
    lines += [
        "",
        f"- `hcv dt-crit`, expression over the same power law (then): {e['wall_ratio']:.2f}× wall, "
        f"{e['cpu_ratio']:.2f}× CPU (goal ≤ {e['goal']:g}×: {'met' if e['goal_met'] else '**not met**'})",
        "",
        f"Wall seconds from outside each new process; CPU = its user + system seconds. "
        f"Measured by `python -m benchmarks.bench_startup` ({mi.get('cpu_count', '?')} cpus, "
        f"load {load.get('before', float('nan')):.1f} before, {load.get('after', float('nan')):.1f} after; "
        f"commit {str(mi.get('commit', '?'))[:12]}); `reports/bench/startup.json`.",
    ]
    return "\n".join(lines)


def _load(bench: dict) -> str:
    load = bench.get("load_average_1min")
    return f"{load:.2f}" if isinstance(load, int | float) else "?"


def _between(text: str, start: str, end: str) -> tuple[int, int]:
    i, j = text.find(start), text.find(end)
    if i < 0 or j < 0 or j < i:
        raise HCVInputError(f"README has no {start} ... {end} block")
    return i + len(start), j


def readme_block(readme_text: str, start: str = START, end: str = END) -> str:
    """The text between the markers (HCVInputError when they are missing or out of order)."""
    i, j = _between(readme_text, start, end)
    return readme_text[i:j].strip("\n")


def _replace(text: str, start: str, end: str, body: str) -> str:
    i, j = _between(text, start, end)
    return text[:i] + "\n" + body + "\n" + text[j:]


def rewrite_readme(
    results: dict,
    readme_text: str,
    bench: dict | None = None,
    startup: dict | None = None,
    wp: dict | None = None,
    batch_peer: dict | None = None,
) -> str:
    """The README with only its verdict block (and, given ``bench``, its speed block, with
    the work-precision paragraph given ``wp`` and the batch-peer lines given
    ``batch_peer``; given ``startup``, its start-up block) replaced."""
    new = _replace(readme_text, START, END, verdict_table(results))
    if bench is not None:
        new = _replace(new, SPEED_START, SPEED_END, speed_table(bench, wp, batch_peer))
    if startup is not None:
        new = _replace(new, STARTUP_START, STARTUP_END, startup_table(startup))
    return new


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m reference_impl.report.readme_table", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--results", default=str(ROOT / "reports" / "results.json"))
    ap.add_argument("--readme", default=str(ROOT / "README.md"))
    ap.add_argument("--bench", default=str(ROOT / "reports" / "bench" / "exact.json"))
    ap.add_argument("--startup", default=str(ROOT / "reports" / "bench" / "startup.json"))
    ap.add_argument(
        "--workprecision", default=str(ROOT / "reports" / "bench" / "workprecision.json")
    )
    ap.add_argument("--batch-peer", default=str(ROOT / "reports" / "bench" / "batch_peer.json"))
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if out of date")
    args = ap.parse_args(argv)
    try:
        results = read_results(args.results, "--results")  # checked as hcv report --from
        readme = Path(args.readme).read_text()
        bench_path = Path(args.bench)
        bench = json.loads(bench_path.read_text()) if bench_path.is_file() else None
        startup_path = Path(args.startup)
        startup = json.loads(startup_path.read_text()) if startup_path.is_file() else None
        wp_path = Path(args.workprecision)
        wp = json.loads(wp_path.read_text()) if wp_path.is_file() else None
        bp_path = Path(args.batch_peer)
        bp = json.loads(bp_path.read_text()) if bp_path.is_file() else None
        new = rewrite_readme(results, readme, bench, startup, wp, bp)
    except (OSError, ValueError, KeyError, HCVInputError) as exc:
        print(f"readme_table: error: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if new != readme:
            print(
                f"readme_table: {args.readme} differs from {args.results} / {args.bench} / "
                f"{args.startup} / {args.workprecision} / {args.batch_peer}",
                file=sys.stderr,
            )
            return 1
        return 0
    if new != readme:
        Path(args.readme).write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
