"""What `benchmarks.bench_exact` prints: a line per row, its peers, the batch, the machine."""

from __future__ import annotations

__all__ = ["numbalsoda_note", "print_result"]


def numbalsoda_note() -> str:
    """Whether the numbalsoda column is there (`benchmarks._peers`), and why not."""
    try:
        import numbalsoda  # noqa: F401
    except ImportError:
        return (
            "not installed: 0.3.4 has no wheel for Python 3.11 and its source build needs a "
            "Fortran compiler (apt-get install gfortran; then pip install numbalsoda)"
        )
    return (
        "installed: the numbalsoda column (its dop853 on the regularised equations; no "
        "events or dense output, so events by sampling and re-integration)"
    )


def _kernel_note(r: dict) -> str:
    if r.get("kernel_us") is None:
        return ""
    return f" (compiled call alone {r['kernel_us']:.1f} us)"


def _peers_note(r: dict, dps: int) -> str:
    """Every peer's time, rung and worst error over the set; the set and its proxy check."""
    cols = " | ".join(
        f"{k} {p['us']:.1f} us (rtol {p['rtol']:.0e}, set {p['max_rel_error']:.1e}"
        f"{'' if p['at_equal_error'] else ', best'})"
        for k, p in r["peers"].items()
    )
    s = r["equal_error_set"]
    pc = s["proxy_check"]
    return (
        f"    peers: {cols}; denominator {r['peer_name']}; set of {s['impacts']}"
        f" ({s['refused_by_ours']} refused by ours), ours vs {dps} digits on"
        f" {pc['impacts']}: {pc['proxy_max_rel_error']:.1e}, bounds"
        f" {'held' if pc['bounds_held'] else 'BROKEN'}"
    )


def print_result(res: dict) -> None:
    print(f"ours vs compiled DOP853 at equal error; truth: {res['truth']}; {res['timing']}")
    print(
        f"{'scene':22s} {'ours us':>8s} {'prep us':>8s} {'error':>8s} {'peer us':>8s}"
        f" {'its err':>8s} {'rtol':>7s} {'ratio':>8s} {'scipy us':>9s}  goal"
    )
    for r in res["families"]:
        prep = f"{r['prepared_us']:8.1f}" if "prepared_us" in r else f"{'-':>8s}"
        ratio = r.get("prepared_ratio", r["ratio"])
        best = "" if r["peer_at_equal_error"] else " (peer's best)"
        print(
            f"{r['scene']:22s} {r['ours_us']:8.1f} {prep} {r['ours_max_rel_error']:8.1e}"
            f" {r['peer_us']:8.1f} {r['peer_max_rel_error']:8.1e} {r['peer_rtol']:7.0e}"
            f" {ratio:7.1f}x {r['scipy_us']:9.0f}  {r['goal']}: "
            f"{'met' if r['goal_met'] else 'NOT met'}{best}{_kernel_note(r)}"
        )
        print(_peers_note(r, res["truth_dps"]))
    for r in res["laws"]:
        best = "" if r["peer_at_equal_error"] else " (peer's best)"
        print(
            f"{r['law']:22s} {r['ours_us']:8.1f} {r['prepared_us']:8.1f}"
            f" {r['ours_max_rel_error']:8.1e}"
            f" {r['peer_us']:8.1f} {r['peer_max_rel_error']:8.1e} {r['peer_rtol']:7.0e}"
            f" {r['prepared_ratio']:7.2f}x {r['scipy_us']:9.0f}  {r['goal']}: "
            f"{'met' if r['goal_met'] else 'NOT met'}{best}"
        )
        print(_peers_note(r, res["truth_dps"]))
    for b in res["batch"]:
        print(
            f"solve_impacts, {b['workload']}: {b['us_per_impact_1_thread']:.2f} us/impact on 1"
            f" thread (CPU {b['cpu_us_per_impact_1_thread']:.2f}),"
            f" {b['us_per_impact_all_threads']:.2f} on {b['threads']}"
            f" ({b['parallel_speedup']:.2f}x, identical: {b['bit_identical_to_1_thread']})"
            f"  {b['goal']}: {'met' if b['goal_met'] else 'NOT met'}"
            + (
                ""
                if b["implied_serial_fraction"] is None
                else f" (implied serial part {b['implied_serial_fraction']:.1%})"
            )
        )
    mi = res["machine"]
    print(
        f"machine: {mi['platform']}, {mi['cpu_count']} cpus, load {res['load_average_1min']}"
        f" before, {res['load_average_1min_after']} after, commit {mi['commit']}"
        f"; numbalsoda: {res['numbalsoda']}"
    )
