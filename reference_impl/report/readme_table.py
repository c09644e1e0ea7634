"""The README's verdict table, generated from a report's results.json.

``python -m reference_impl.report.readme_table [--results reports/results.json]
[--readme README.md] [--check]`` rewrites only the block between
``<!-- verdicts:start -->`` and ``<!-- verdicts:end -->`` of the README with one
row per claim of results.json (id, section, verdict, headline), and, when
``reports/bench/exact.json`` exists (``nox -s bench``), the block between
``<!-- speed:start -->`` and ``<!-- speed:end -->`` with the exact solver's speed
and error per potential family as that benchmark measured them, and, when
``reports/bench/startup.json`` exists, the block between ``<!-- startup:start -->`` and
``<!-- startup:end -->`` with the start-up times of `benchmarks.bench_startup`. ``--check``
writes nothing and exits 1 when a block differs from what the JSON files give.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from reference_impl.errors import HCVInputError

__all__ = [
    "START",
    "END",
    "SPEED_START",
    "SPEED_END",
    "verdict_table",
    "speed_table",
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
    return str(text).replace("|", "\\|").replace("\n", " ")


def verdict_table(results: dict) -> str:
    """Markdown table: claim | section | verdict | in one line (refuted in bold)."""
    lines = ["| claim | section | verdict | in one line (measured) |", "|---|---|---|---|"]
    for c in results["claims"]:
        verdict = f"**{c['verdict']}**" if c["verdict"] != "verified" else c["verdict"]
        headline = c.get("headline") or c["evidence"].split(";")[0]
        lines.append(f"| {c['id']} | {_cell(c['section'])} | {verdict} | {_cell(headline)} |")
    env = results.get("environment", {})
    commit = (env.get("git_commit") or "unknown")[:12]
    dirty = " (uncommitted changes)" if env.get("git_dirty") else ""
    lines += [
        "",
        f"Generated from `reports/results.json` ({results.get('mode', '?')} run of "
        f"{results.get('generated_utc', '?')}, commit {commit}{dirty}) by "
        f"`python -m reference_impl.report.readme_table`.",
    ]
    return "\n".join(lines)


def speed_table(bench: dict) -> str:
    """Markdown table of `benchmarks.bench_exact`'s JSON: one row per family, then the batch."""
    lines = [
        "| scene | exact solver | error t_c | error e | DOP853 (rtol "
        f"{bench.get('dop853_rtol', '?')}) | its error t_c | speed-up | goal |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in bench["families"]:
        lines.append(
            f"| {_cell(r['family'])} | {r['exact_us']:.0f} µs | "
            f"{r['exact_contact_time_rel_error']:.1e} | {r['exact_restitution_rel_error']:.1e} | "
            f"{r['dop853_us'] / 1e3:.1f} ms | {r['dop853_contact_time_rel_error']:.1e} | "
            f"{r['speedup']:.0f}× | {'met' if r['goal_met'] else '**not met**'} |"
        )
    lines.append("")
    for b in bench.get("batch", []):
        lines.append(
            f"- `solve_impacts`, {_cell(b['workload'])}: {b['impacts_per_s']:.3g} impacts/s "
            f"({'met' if b['goal_met'] else '**not met**'})"
        )
    laws = bench.get("laws")
    if laws:
        lg = bench.get("law_goal", {})
        lines += [
            "",
            "Damping laws (issue 18): Hertz with each law of `reference_impl.theory.laws`, calibrated to "
            "e = 0.8 at 1 m/s (overlap end), v0 = 1 m/s, solved by `reference_impl.exact.general_law`; "
            "error = largest relative error over both ends' contact time and restitution, "
            f"q_max and the peak force, against {bench.get('law_truth', '?')}.",
            "",
            "| law | general solver | its error | DOP853 (rtol "
            f"{bench.get('dop853_rtol', '?')}) | its error t_c | speed-up | goal |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in laws:
            lines.append(
                f"| {_cell(r['law'])} | {r['exact_us']:.0f} µs | {r['exact_max_rel_error']:.1e} | "
                f"{r['dop853_us'] / 1e3:.1f} ms | {r['dop853_contact_time_rel_error']:.1e} | "
                f"{r['speedup']:.0f}× | {'met' if r['goal_met'] else '**not met**'} |"
            )
        lmi = bench.get("laws_machine")
        run = (
            f" Law rows measured in their own run (`python -m benchmarks.bench_exact --laws-only`, "
            f"{lmi.get('cpu_count', '?')} cpus, load {bench.get('laws_load_average_1min') or 0:.2f}, "
            f"commit {str(lmi.get('commit', '?'))[:12]})."
            if lmi
            else ""
        )
        lines += [
            "",
            f"Goal (issue 18): ≤ {lg.get('us_per_impact', '?')} µs per impact at ≤ "
            f"{lg.get('error', '?')} relative error and ≥ {lg.get('speedup', '?')}× DOP853.{run}",
        ]
    goal = bench.get("goal", {})
    mi = bench.get("machine", {})
    lines += [
        "",
        f"Goals (issue 9): ≤ {goal.get('us_per_impact', '?')} µs per impact at ≤ "
        f"{goal.get('error', '?')} relative error and ≥ {goal.get('speedup', '?')}× DOP853; "
        f"batch ≥ {goal.get('batch_impacts_per_s', '?'):.0e} impacts/s. Truth: "
        f"{bench.get('truth', '?')}. Measured by `python -m benchmarks.bench_exact` "
        f"({mi.get('cpu_count', '?')} cpus, load {_load(bench)}, "
        f"commit {str(mi.get('commit', '?'))[:12]}); `reports/bench/exact.json`.",
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
        verdict = "—" if goal is None else (
            f"≤ {goal:g} s: {'met' if r['goal_met'] else '**not met**'}"
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
    results: dict, readme_text: str, bench: dict | None = None, startup: dict | None = None
) -> str:
    """The README with only its verdict block (and, given ``bench``, its speed block; given
    ``startup``, its start-up block) replaced."""
    new = _replace(readme_text, START, END, verdict_table(results))
    if bench is not None:
        new = _replace(new, SPEED_START, SPEED_END, speed_table(bench))
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
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if out of date")
    args = ap.parse_args(argv)
    try:
        results = json.loads(Path(args.results).read_text())
        readme = Path(args.readme).read_text()
        bench_path = Path(args.bench)
        bench = json.loads(bench_path.read_text()) if bench_path.is_file() else None
        startup_path = Path(args.startup)
        startup = json.loads(startup_path.read_text()) if startup_path.is_file() else None
        new = rewrite_readme(results, readme, bench, startup)
    except (OSError, ValueError, KeyError, HCVInputError) as exc:
        print(f"readme_table: error: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if new != readme:
            print(
                f"readme_table: {args.readme} differs from {args.results} / {args.bench} / "
                f"{args.startup}",
                file=sys.stderr,
            )
            return 1
        return 0
    if new != readme:
        Path(args.readme).write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
