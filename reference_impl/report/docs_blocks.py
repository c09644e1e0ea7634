"""The docs' measured figures, generated from the committed benchmark records (issue 41).

Every time the README and the site state sits in a block ``<!-- NAME:start -->`` ...
``<!-- NAME:end -->`` rewritten from its record in ``reports/bench/`` with the record's
commit, the load beside each timing and the compile cache's state (empty, the first run
after an install; or filled). ``python -m reference_impl.report.docs_blocks`` rewrites the
blocks, ``--check`` writes nothing and exits 1 when a page differs from its records
(``verification/test_docs_figures.py`` fails then too). The records and who writes them:

- ``commands.json``: ``python -m benchmarks.bench_startup --docs --repeats 1 --json
  reports/bench/commands.json`` (the smoke command, ``hcv report --from``, the gates);
- ``codes.json``: ``python -m benchmarks.bench_codes --runs 5 --json
  reports/bench/codes.json`` (a run of YADE and LIGGGHTS, persistent and one-shot);
- ``sweep.json``: ``python -m benchmarks.bench_sweep --masses 30 --json
  reports/bench/sweep.json`` (the 480-case map on 1 and 2 Dask workers);
- ``device_scaling.json``: ``python3 benchmarks/device_scaling.py`` (16 cores).
- ``batch_peer_16cores.json``: ``python -m benchmarks.bench_batch_peer --rows ROW --threads
  1,4,16`` on a 16-core machine, the rows merged into one record.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from reference_impl.errors import HCVInputError
from reference_impl.report._text import markdown_text
from reference_impl.report.readme_table import batch_goal, readme_block

__all__ = [
    "BLOCKS",
    "Block",
    "load_records",
    "render",
    "rewrite_page",
    "stale_blocks",
    "main",
]

ROOT = Path(__file__).resolve().parents[2]
BENCH = Path("reports") / "bench"


def _sig(v: float) -> str:
    """Two significant figures, never in exponent form (0.39, 6.4, 17, 274)."""
    return f"{v:.0f}" if v >= 10 else (f"{v:.1f}" if v >= 1 else f"{v:.2g}")


def _dur(x: float) -> str:
    """A duration in the unit that reads best: s from 0.1 s, else ms, else µs."""
    if x >= 0.1:
        return f"{_sig(x)} s"
    return f"{_sig(x * 1e3)} ms" if x >= 1e-4 else f"{_sig(x * 1e6)} µs"


def _load(before: float, after: float) -> str:
    lo, hi = sorted((before, after))
    return f"load {lo:.1f}" if f"{lo:.1f}" == f"{hi:.1f}" else f"load {lo:.1f}–{hi:.1f}"


def _busy(loads, cores: int) -> str:
    """A sentence warning that timings were taken at a load above the cores (issue 41),
    or nothing."""
    worst = max(loads)
    if worst <= cores:
        return ""
    return (
        f" The load (up to {worst:.1f}) exceeded the {cores} cores: other work slowed the "
        "wall times."
    )


def _timed(run: dict) -> str:
    """``W s wall, C s CPU at load A–B`` of one run of `benchmarks.bench_startup`."""
    return (
        f"{_dur(run['wall_s'])} wall, {_dur(run['cpu_s'])} CPU at "
        f"{_load(run['load_before'], run['load_after'])}"
    )


def _loads(*runs: dict) -> list[float]:
    return [x for r in runs for x in (r["load_before"], r["load_after"])]


def _provenance(rec: dict) -> str:
    m = rec["machine"]
    dirty = ", uncommitted changes" if m.get("git_dirty") else ""
    return f"{m['cpu_count']} cores, commit {str(m['commit'])[:7]}{dirty}"


def _row(rec: dict, name: str) -> dict:
    rows = [r for r in rec["cases"] if r["name"] == name]
    if not rows:
        raise HCVInputError(f"commands.json has no row {name!r}: re-run bench_startup --docs")
    return rows[0]


def _median_run(row: dict) -> dict:
    runs = sorted(row["warm_runs"], key=lambda w: w["wall_s"])
    return runs[len(runs) // 2]


def _cold_warm(rec: dict, name: str) -> str:
    """The first run on an empty compile cache, then the (median) run on the filled one,
    and a warning when the load exceeded the cores."""
    r = _row(rec, name)
    warm = _median_run(r)
    return (
        f"the first time (empty compile cache) {_timed(r['cold_run'])}; then (cache "
        f"filled by that run) {_timed(warm)}."
        + _busy(_loads(r["cold_run"], warm), rec["machine"]["cpu_count"])
    )


def smoke_time(records: dict) -> str:
    """README: the smoke command's wall and CPU time, cold and warm."""
    rec = records["commands.json"]
    return (
        f"The smoke command took, {_cold_warm(rec, 'smoke command')} Wall and CPU seconds of "
        "the command and its children, measured by `python -m benchmarks.bench_startup "
        f"--docs` ({_provenance(rec)}; `reports/bench/commands.json`)."
    )


def report_from_time(records: dict) -> str:
    """getting-started: ``hcv report --from``'s time, cold and warm."""
    rec = records["commands.json"]
    return (
        "`hcv report --from reports/results.json --out DIR` (renders, runs nothing) took, "
        f"{_cold_warm(rec, 'hcv report --from')} Measured by `python -m "
        f"benchmarks.bench_startup --docs` ({_provenance(rec)}; `reports/bench/commands.json`)."
    )


# What each measured gate runs (its code's persistent mode: one process for all runs).
_GATE_LABEL = {
    "yade": "`yade` (persistent: one YADE for all runs and variants)",
    "liggghts": "`liggghts` (persistent: one LIGGGHTS, runs separated by `clear`)",
}
_RUN_LABEL = {
    "yade[en,wall]": "`yade[en,wall]` (persistent)",
    "yade[en,wall,persistent=false]": "`yade[en,wall,persistent=false]` (a YADE per run, "
    "as a one-shot `cmd:` adapter)",
    "liggghts[hertz,wall]": "`liggghts[hertz,wall]` (persistent)",
    "liggghts[hertz,wall,persistent=false]": "`liggghts[hertz,wall,persistent=false]` (a "
    "LIGGGHTS per run)",
}


def gate_times(records: dict) -> str:
    """adapter-protocol: the default gates' times (commands.json) and a run's cost in either
    mode (codes.json)."""
    rec, codes = records["commands.json"], records["codes.json"]
    cores, loads = rec["machine"]["cpu_count"], []
    lines = [
        "| gate (`hcv bench CODE --gate`, default scenes) | variants | its verdict | first "
        "time (empty compile cache) | then (cache filled) |",
        "|---|---|---|---|---|",
    ]
    for code, label in _GATE_LABEL.items():
        rows = [r for r in rec["cases"] if r["name"] == f"hcv bench {code} --gate"]
        if not rows:
            lines.append(f"| {label} | — | not installed where measured | — | — |")
            continue
        r, g = rows[0], rows[0]["gate"]
        warm = _median_run(r)
        loads += _loads(r["cold_run"], warm)
        s = g["summary"]
        decided = s["pass"] + s["fail"] + s["error"]
        lines.append(
            f"| {label} | {len(g['variants'])} | {g['status']} ({s['fail']} of {decided} "
            f"metrics failed) | {_timed(r['cold_run'])} | {_timed(warm)} |"
        )
    lines += [
        "",
        f"Wall and CPU seconds of `hcv` and its children (the code's processes), measured by "
        f"`python -m benchmarks.bench_startup --docs` ({_provenance(rec)}; "
        f"`reports/bench/commands.json`).{_busy(loads or [0.0], cores)} A run of `hertz-damped` at its middle speed, 200 "
        "steps per contact, in either mode:",
        "",
        "| code | a run (fastest of "
        f"{codes['runs']}) | × 93 runs (a variant's default scenes; extrapolated) |",
        "|---|---|---|",
    ]
    for spec, per in codes["per_run_s"].items():
        lines.append(
            f"| {_RUN_LABEL.get(spec, f'`{spec}`')} | {_dur(per)} | {_dur(codes['gate_s'][spec])} |"
        )
    ratios = ", ".join(
        f"{code} {r:.0f}×" for code, r in codes["ratio_one_shot_over_persistent"].items()
    )
    ld = codes["load_average_1min"]
    lines += [
        "",
        f"One-shot over persistent: {ratios}. Measured by `python -m benchmarks.bench_codes "
        f"--runs {codes['runs']}` ({_provenance(codes)}; load {ld['before']:.1f} before, "
        f"{ld['after']:.1f} after; `reports/bench/codes.json`)."
        + _busy([ld["before"], ld["after"]], codes["machine"]["cpu_count"]),
    ]
    return "\n".join(lines)


def _sweep_load(run: dict) -> float:
    return float(str(run["load"]).split()[0])


def sweep_two_cores(records: dict) -> str:
    """performance: the 480-case map on 1 and 2 Dask workers (sweep.json)."""
    rec = records["sweep.json"]
    m, r1, r2 = rec["model"], rec["runs"]["1"], rec["runs"]["2"]
    goals = m["goals"]
    speedup = rec["speedup_2_over_1"]
    busy = [run["in_case_s"] / (run["wall_s"] * run["workers"]) for run in (r1, r2)]
    cluster = [run["startup_s"] + run["close_s"] for run in (r1, r2)]
    loads = [_sweep_load(run) for run in (r1, r2)]
    pred = ", ".join(f"{_dur(t)} on {n}" for n, t in m["predicted_480_s"].items())

    def met(ok: bool) -> str:
        return "met" if ok else "**not met**"

    return (
        f"**Measured** (`python -m benchmarks.bench_sweep --masses 30 --json "
        f"reports/bench/sweep.json`: the {rec['cases']}-case critical-step map, two-sided "
        f"Δt_crit searches of ~{_dur(m['case_cpu_s'])} CPU each, kernels compiled before the "
        f"timing; {_provenance(rec)}, load {loads[0]:.1f} as 1 worker started and "
        f"{loads[1]:.1f} as 2 did): 1 worker finishes in "
        f"{_dur(r1['wall_s'])}, 2 workers in {_dur(r2['wall_s'])}, a speed-up of "
        f"**{speedup:.2f}×** (issue 27's goal ≥ {goals['speedup_480']:g}× on this map: "
        f"{met(speedup >= goals['speedup_480'])}); the workers are busy inside cases "
        f"{100 * min(busy):.0f}–{100 * max(busy):.0f} % of the time; cases are grouped per Dask "
        f"task, and the engine costs **{_dur(m['engine_per_case_grouped_s'])}** per case grouped "
        f"against {_dur(m['engine_per_case_single_s'])} one case per task (goal ≤ "
        f"{_dur(goals['per_case_s'])}: {met(m['engine_per_case_grouped_s'] <= goals['per_case_s'])}); "
        f"starting and closing the local cluster takes {_sig(min(cluster))}–{_dur(max(cluster))} "
        f"(goal ≤ {_dur(goals['fixed_s'])}: {met(max(cluster) <= goals['fixed_s'])}). The "
        f"benchmark fits a model to its own runs, fixed ({_dur(m['fixed_base_s'])}) + per case "
        f"({_dur(m['case_cpu_s'])} CPU + {_dur(m['engine_per_case_grouped_s'])}) / N workers, "
        f"and predicts for N idle cores ({rec['cases']} cases: {pred}); only 1 and 2 workers "
        "were measured."
    )


def sweep_sixteen_cores(records: dict) -> str:
    """performance: the same map and the batch API on a 16-core machine (device_scaling)."""
    rec = records["device_scaling.json"]
    mi, sw = rec["machine"], rec["sections"]["sweep"]
    table = {int(n): row for n, row in sw["table"].items()}
    ns = sorted(table)
    measured = ", ".join(f"{_dur(table[n]['measured_s'])} on {n}" for n in ns)
    predicted = ", ".join(_dur(table[n]["predicted_s"]) for n in ns)
    ratios = ", ".join(f"{table[n]['measured_over_predicted']:.2f}" for n in ns)
    runs = {int(n): run for n, run in sw["runs"].items()}
    per_case = {n: runs[n]["in_case_s"] / runs[1]["in_case_s"] for n in runs}
    slowest = max(per_case, key=per_case.get)
    identical = all(run.get("identical_to_first_run") for run in runs.values())
    speedup = table[1]["measured_s"] / table[ns[-1]]["measured_s"]
    tree = rec.get("tree", {}).get("commit") or mi["commit"]
    impacts = rec["sections"]["impacts"]["rows"]
    top = str(ns[-1])

    def x(row: dict) -> str:
        return f"{row['threads'][top]['speedup']:.1f}×"

    grids = [r for r in impacts if "grid" in r["workload"]]
    one_thread = [r["threads"]["1"]["wall_s"] / _impacts(r["workload"]) for r in grids]
    laws = {r["workload"].rsplit(", ", 1)[-1]: r for r in rec["sections"]["law"]["rows"]}
    bit = all(t["bit_identical_to_1_thread"] for s in ("impacts", "law")
              for r in rec["sections"][s]["rows"] for t in r["threads"].values())  # fmt: skip
    return (
        f"**On {mi['cpu_count']} cores** (`python3 benchmarks/device_scaling.py`, one run on a "
        f"lent {mi['cpu_count']}-core machine, Python {mi['python']}, numba "
        f"{mi['packages'].get('numba')}, load {mi['load'][0]:.1f} at the start, "
        f"{rec['started'][:10]}, tree {tree[:7]}, kernels compiled before the timing; numbers "
        f"from `reports/bench/device_scaling.json`): the same {sw['cases']}-case map took "
        f"{measured} workers (**{speedup:.1f}×** one worker). The model fitted to the 1- and "
        f"2-worker runs alone predicted {predicted}: measured/predicted {ratios} — a case took "
        f"up to {per_case[slowest]:.2f}× its one-worker time (at {slowest} workers), which the "
        "model (a case costs the same on any number of workers) does not hold. "
        f"{'Every' if identical else '**Not every**'} run's results were identical to the "
        f"first. `solve_impacts` on {top} numba threads: {x(impacts[0])} one thread on "
        f"{impacts[0]['workload']}, {' and '.join(x(r) for r in grids)} on the grids "
        f"({_sig(min(one_thread) * 1e6)}–{_sig(max(one_thread) * 1e6)} µs an impact on one thread: little "
        f"work per task), and the general-law batch (Hunt–Crossley) "
        + ", ".join(f"{x(r)} on {k} speeds" for k, r in laws.items())
        + f"; {'all' if bit else '**not all**'} bit for bit the one-thread results."
    )


def batch_sixteen_cores(records: dict) -> str:
    """performance: goal 5's batch against the parallel peer on a 16-core machine
    (`benchmarks.bench_batch_peer --threads`, batch_peer_16cores.json)."""
    rec = records["batch_peer_16cores.json"]
    # The record is input: its text reaches the page through markdown_text (no raw HTML, no
    # unsafe link), its numbers through a float format (a string there fails in one line).
    md = markdown_text
    mi = rec["machine"]
    tree = md(rec.get("tree", {}).get("commit") or mi["commit"])
    rows = []
    for r in rec["rows"]:
        ths = list(r["ratio"])
        ours = ", ".join(f"{r['us_per_impact'][t]:.2f}" for t in ths)
        peer = ", ".join(f"{r['peer_us_per_impact'][t]:.1f}" for t in ths)
        ratio = ", ".join(f"{r['ratio'][t]:.1f}×" for t in ths)
        full = r.get("ours_full", {}).get("ratio", {})  # absent in a /1 record: not stated
        full_txt = ", ".join(f"{full[t]:.1f}×" for t in ths if t in full)
        names = ", ".join(md(k) for k in sorted({r["peer"][t] for t in ths}))
        rtol = "full accuracy" if r["ours_rtol"] is None else f"rtol {r['ours_rtol']:.0e}"
        rows.append(
            f"{md(r['row'])}: ours at {rtol} (error {r['ours_max_rel_error']:.1e}) "
            f"{ours} µs an impact on {md(', '.join(ths))} threads, the fastest peer "
            f"({names}) {peer} µs: **{ratio}**"
            + (f" (ours at full accuracy: {full_txt})" if full_txt else "")
            + f"; goal ≥ {rec['goal_ratio']:g}× {batch_goal(r)}"
        )
    loads = [x for run in rec.get("runs", []) for x in run.get("load", [])]
    load = f"load {min(loads):.1f}–{max(loads):.1f}" if loads else "load not recorded"
    return (
        f"**On {mi['cpu_count']:d} cores** (`python -m benchmarks.bench_batch_peer --rows ROW "
        f"--threads 1,4,16 --blocks {rec['blocks']:d}`, one run per row on a lent "
        f"{mi['cpu_count']:d}-core machine, {md(mi.get('cpu', 'processor not recorded'))}, "
        f"Python {md(mi['python'])}, numba {md(mi['packages'].get('numba'))}, {load}, tree "
        f"{tree[:7]}; numbers from `reports/bench/batch_peer_16cores.json`): "
        + "; ".join(rows)
        + ". The README judges goal 5 on the 2-core record (`reports/bench/batch_peer.json`, "
        "above); this one shows the ratio on more threads and another processor."
    )


def _impacts(workload: str) -> int:
    """The number of impacts a workload of device_scaling names ('grid 50 zeta x 2000 v0')."""
    words = workload.replace("x", " ").split()
    nums = [int(w) for w in words if w.isdigit()]
    return nums[0] * nums[1] if "grid" in workload else nums[0]


def sweep_sizing(records: dict) -> str:
    """performance: worker-hours of a 10^5-case map, from sweep.json's own sizing."""
    rec = records["sweep.json"]
    eff, o = rec["busy_efficiency"], rec["model"]["engine_per_case_single_s"]
    sz = rec["sizing_1e5"]
    big, ours = sz["0.3 s cases"], sz["these cases"]
    return (
        "**Sizing a 10⁵-case map.** Worker-hours = cases × (case time + overhead) / busy "
        f"fraction: 10⁵ × ({_dur(big['case_s'])} + {_dur(o)}) / {eff:.2f} ≈ "
        f"{big['core_hours']:.1f} worker-hours for cases of {_dur(big['case_s'])} (an example "
        f"case time; {ours['core_hours']:.1f} for the benchmark's {_dur(ours['case_s'])} cases; "
        f"the benchmark prints both). So {big['workers_for_1_hour']} single-thread workers "
        f"finish it in about an hour, 32 in about {60 * big['hours_on_32_workers']:.0f} minutes "
        "(e.g. 4 machines × 8 cores: `dask worker ... --nworkers 8 --nthreads 1` on each). "
        f"Only 1–2 workers were measured; one scheduler and client handle a result in about "
        f"{_dur(o)} here (`reports/bench/sweep.json`: {_provenance(rec)}, load "
        f"{_sweep_load(rec['runs']['1']):.1f}), which keeps up with some "
        f"{big['case_s'] / o:.0f} workers on {_dur(big['case_s'])} cases; for more, split the "
        "map into several specs, one client each."
    )


@dataclass(frozen=True)
class Block:
    """One generated block: its page (from the repository root), its name and renderer."""

    page: str
    name: str
    records: tuple[str, ...]
    render: Callable[[dict], str]


BLOCKS = (
    Block("README.md", "smoke-time", ("commands.json",), smoke_time),
    Block("docs/getting-started.md", "report-from-time", ("commands.json",), report_from_time),
    Block("docs/adapter-protocol.md", "gate-times", ("commands.json", "codes.json"), gate_times),
    Block(
        "docs/performance.md", "batch-16-cores", ("batch_peer_16cores.json",), batch_sixteen_cores
    ),
    Block("docs/performance.md", "sweep-2-cores", ("sweep.json",), sweep_two_cores),
    Block("docs/performance.md", "sweep-16-cores", ("device_scaling.json",), sweep_sixteen_cores),
    Block("docs/performance.md", "sweep-sizing", ("sweep.json",), sweep_sizing),
)


def load_records(root: Path = ROOT) -> dict:
    """Every record the blocks read, by file name (HCVInputError naming a missing one)."""
    records = {}
    for name in sorted({r for b in BLOCKS for r in b.records}):
        path = root / BENCH / name
        try:
            records[name] = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise HCVInputError(f"{path}: {exc}") from exc
    return records


def _markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}:start -->", f"<!-- {name}:end -->"


def render(block: Block, records: dict) -> str:
    """The block's body from its records."""
    return block.render(records)


def rewrite_page(text: str, page: str, records: dict) -> str:
    """``text`` (the page ``page``) with each of its blocks rewritten from ``records``."""
    for b in BLOCKS:
        if b.page == page:
            start, end = _markers(b.name)
            readme_block(text, start, end)  # HCVInputError when the markers are missing
            i, j = text.find(start) + len(start), text.find(end)
            text = text[:i] + "\n" + render(b, records) + "\n" + text[j:]
    return text


def stale_blocks(pages: dict[str, str], records: dict) -> list[str]:
    """``page: name`` of every block whose text differs from its records."""
    out = []
    for b in BLOCKS:
        start, end = _markers(b.name)
        if readme_block(pages[b.page], start, end) != render(b, records).strip("\n"):
            out.append(f"{b.page}: {b.name}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m reference_impl.report.docs_blocks", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if out of date")
    args = ap.parse_args(argv)
    try:
        records = load_records()
        pages = {p: (ROOT / p).read_text() for p in sorted({b.page for b in BLOCKS})}
        new = {p: rewrite_page(t, p, records) for p, t in pages.items()}
    except (OSError, KeyError, TypeError, ValueError, HCVInputError) as exc:
        print(f"docs_blocks: error: {exc}", file=sys.stderr)
        return 2
    if args.check:
        stale = stale_blocks(pages, records)
        for s in stale:
            print(f"docs_blocks: {s} differs from its record", file=sys.stderr)
        return 1 if stale else 0
    for p, t in new.items():
        if t != pages[p]:
            (ROOT / p).write_text(t)
    return 0


if __name__ == "__main__":
    sys.exit(main())
