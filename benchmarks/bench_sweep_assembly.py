"""Benchmark of assembly ensembles on ``hcv sweep`` (issue 39, section 5): 2 workers over 1.

Run:  python -m benchmarks.bench_sweep_assembly [--json FILE] [--quick]

Workload: a ``task = "dt-crit"`` sweep of undamped Hertz chains between two walls (the
chain-hertz scene's spheres; N = 2 and 5), 16 lanes per ensemble at the report's two
horizons (1e4 and 1e5 steps), cut into
groups of 4 lanes (`reference_impl.sweep._assembly`: 16 cases of similar size). It runs
through the engine of ``hcv sweep`` (`open_client` + `iter_outcomes` with `run_case`) on
a `LocalCluster` of 1 worker and of 2 workers, each warmed first (imports and the
assembly kernel compiled), and the same sweep with one case per ensemble and horizon
(``lane_group`` = all lanes: 4 unequal cases) on 2 workers, the grouping's reference.

Figures: wall time of each, the speed-up T(1 worker) / T(2 workers) (goal >= 1.8 on an
idle 2-core machine), the CPU seconds inside the cases, contact updates per second, and
the load average (1, 5, 15 min) and commit beside them: on a machine shared with other
work the wall times are upper bounds and the speed-up a lower bound. Beside them, what the
split into tasks allows whatever the load: the speed-up on 2 idle workers predicted from
each case's CPU seconds (measured on 1 worker) by scheduling the cases in the order the
engine submits them onto the first free worker (`_predicted_speedup`).
"""

from __future__ import annotations

import argparse
import os
import time

# The package is imported inside the functions: the local cluster's processes are spawned
# and import this module as their __main__ (see benchmarks/bench_sweep.py).

_SPEC = """
task = "dt-crit"
[assembly]
horizons = {horizons}
lanes = 16
lane_group = {group}
[scene]
name = "bench-sweep-assembly"
kind = "chain"
n = 2
mass = 4.1103e-3
walls = "both"
velocities = 1.0
[scene.potential]
family = "power"
k = 1.0879e10
p = 1.5
[sweep]
n = [2, 5]
"""
# Horizons (steps): full, the report's own ensembles (`sec6_assemblies.FULL_HORIZONS`:
# 1e4 and 1e5 steps, ~25 s of work), so that the fixed cost of each task (~0.1 s of
# scheduling and transfer) weighs as in the sweeps users run (at 3e3 and 1e4 steps, 2.5 s
# of work, it alone held 2 idle workers to 1.75x, measured at c31e15c); and --quick (a
# check that it runs).
_HORIZONS = [10_000, 100_000]
_HORIZONS_QUICK = [500, 1_000]
# Lanes per case: 4 groups of the 16 lanes.
_GROUP = 4
_GOAL_SPEEDUP = 1.8


def _load() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def _warm(dask_worker=None) -> float:
    """Load the package and compile the assembly kernel in a worker (time in s)."""
    t = time.perf_counter()
    from reference_impl.sweep import parse_spec, run_case

    spec = parse_spec(_SPEC.format(horizons=[50], group=16), "warm")
    run_case(spec.cases[0].payload())
    return time.perf_counter() - t


def _payloads(horizons: list[int], group: int) -> list[dict]:
    from reference_impl.sweep import parse_spec

    spec = parse_spec(_SPEC.format(horizons=horizons, group=group), "bench-sweep-assembly")
    return [c.payload() for c in spec.cases]


def _run(n: int, payloads: list[dict], tag: str) -> dict:
    """The sweep on a fresh, warmed n-worker LocalCluster: wall, CPU inside cases, updates."""
    from reference_impl.sweep import iter_outcomes, open_client, run_case

    with open_client(workers=n) as client:
        client.wait_for_workers(n)
        client.run(_warm)
        t0 = time.perf_counter()
        outs = list(
            iter_outcomes(
                client, run_case, payloads, keys=[f"asm-{tag}-{i}" for i in range(len(payloads))]
            )
        )
        wall = time.perf_counter() - t0
    failed = [o.error for o in outs if not o.ok]
    assert not failed, f"benchmark cases failed: {failed[:2]}"
    # contact_updates is the whole group's, repeated on each of its lanes' rows
    updates = sum(o.value[0]["contact_updates"] for o in outs)
    return {
        "workers": n,
        "cases": len(payloads),
        "wall_s": wall,
        "in_case_cpu_s": sum(o.cpu_seconds for o in outs),
        "contact_updates": updates,
        "updates_per_s": updates / wall,
        "workers_used": len({o.worker for o in outs}),
        "load_end": _load(),
        "case_cpu_s": [o.cpu_seconds for o in sorted(outs, key=lambda o: o.index)],
    }


def _predicted_speedup(cpu: list[float], workers: int = 2) -> float:
    """Total CPU over the makespan of the cases, in submission order, each on the first
    free of ``workers`` idle workers: the speed-up the split allows (no other load)."""
    free = [0.0] * workers
    for c in cpu:
        k = free.index(min(free))
        free[k] += c
    return sum(cpu) / max(free)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="also write the figures to this JSON file (with machine info)")
    ap.add_argument("--quick", action="store_true", help="short horizons (a check it runs)")
    args = ap.parse_args(argv)
    from benchmarks._record import write_json
    from reference_impl.provenance import machine_info

    info = machine_info()
    load0 = _load()
    print(f"machine: {info['cpu']}; {info['cpu_count']} logical cores; commit "
          f"{info['commit']}; load average {load0}")  # fmt: skip
    horizons = _HORIZONS_QUICK if args.quick else _HORIZONS
    grouped = _payloads(horizons, _GROUP)
    whole = _payloads(horizons, 16)
    runs = {
        "grouped_1": _run(1, grouped, "g1"),
        "grouped_2": _run(2, grouped, "g2"),
        "whole_2": _run(2, whole, "w2"),
    }
    for name, r in runs.items():
        print(f"{name}: {r['cases']} cases on {r['workers']} worker(s) in {r['wall_s']:.2f} s "
              f"(CPU in cases {r['in_case_cpu_s']:.2f} s, {r['updates_per_s']:.3g} contact "
              f"updates/s); load {r['load_end']}")  # fmt: skip
    speedup = runs["grouped_1"]["wall_s"] / runs["grouped_2"]["wall_s"]
    whole_speedup = runs["grouped_1"]["wall_s"] / runs["whole_2"]["wall_s"]
    predicted = _predicted_speedup(runs["grouped_1"]["case_cpu_s"])
    predicted_whole = _predicted_speedup(runs["whole_2"]["case_cpu_s"])
    print(
        f"speed-up 2 workers / 1, groups of {_GROUP} lanes: {speedup:.2f} (goal >= "
        f"{_GOAL_SPEEDUP} on an idle machine); one case per ensemble: {whole_speedup:.2f}"
    )
    print(
        f"predicted on 2 idle workers from the cases' CPU seconds: {predicted:.2f} with "
        f"groups of {_GROUP} lanes, {predicted_whole:.2f} with one case per ensemble"
    )
    if args.json:
        write_json(
            args.json,
            {
                "benchmark": "bench_sweep_assembly",
                "machine": info,
                "commit": info["commit"],
                "load_average_start": load0,
                "quick": args.quick,
                "horizons": horizons,
                "lanes": 16,
                "lane_group": _GROUP,
                "runs": runs,
                "speedup_2_over_1": speedup,
                "speedup_2_over_1_one_case_per_ensemble": whole_speedup,
                "predicted_speedup_2_idle": predicted,
                "predicted_speedup_2_idle_one_case_per_ensemble": predicted_whole,
                "goal_speedup": _GOAL_SPEEDUP,
            },
        )


if __name__ == "__main__":
    main()
