"""``hcv report``: one run of every verification, written as HTML, Markdown and JSON.

`build_report` runs the claim measurements, Table 1, Fig. 1, the critical-step
map, the speed-against-error study and the hard cases on the embedded default
scenes, and writes into ``out_dir``:

* ``index.html`` -- one self-contained page (figures embedded as data URIs);
* ``index.md`` -- the same content for a code host (figures linked);
* ``results.json`` -- machine-readable results (claims, table1, dt_crit_map,
  work_precision, hard_cases, environment, ...);
* ``figures/*.png``.

Every number in the output is computed by the run that writes it; the only
numbers typed in are the paper's own (`reference_impl.paper`) and the
tolerances of the verdict rules (stated next to each verdict).
"""

from __future__ import annotations

import datetime as _dt
import json
import time
from collections.abc import Callable
from pathlib import Path

from ..claims import CLAIMS, VERDICTS
from ..dtcrit_map import coverage
from ._common import claim_tests, jsonable, records

__all__ = ["build_report", "quick_drops"]

def quick_drops() -> list[str]:
    """What --quick leaves out, read from the settings of each study (shown in the report)."""
    from ..workprecision import IVP_METHODS, IVP_RTOLS, VERLET_STEPS
    from ._common import g
    from ._hardcases import _cases

    def cov(quick):
        return {c.label: c.velocities for c in coverage(quick)}

    full, quick = cov(False), cov(True)
    gone_cases = [k for k in full if k not in quick]
    fewer_speeds = [f"{k} ({len(quick[k])} of {len(full[k])} speeds)" for k in quick
                    if k in full and len(quick[k]) < len(full[k])]
    kept_rtols = set(IVP_RTOLS[::2])
    kept_steps = set(VERLET_STEPS[::2])
    from ._wp import QUICK_SKIP

    return [
        f"work-precision: scene {', '.join(QUICK_SKIP)} dropped; solve_ivp methods {', '.join(m for m in IVP_METHODS if m not in ('DOP853', 'RK45'))} "
        f"dropped; rtol {', '.join(g(r) for r in IVP_RTOLS if r not in kept_rtols)} dropped; "
        f"Verlet at {', '.join(str(n) for n in VERLET_STEPS if n not in kept_steps)} steps per "
        f"contact dropped",
        f"critical-step map: {len(gone_cases)} power laws dropped "
        f"({', '.join(gone_cases)}); fewer speeds for {', '.join(fewer_speeds)}",
        f"hard cases: {len(_cases(True))} of {len(_cases(False))} cases, shorter sweeps",
    ]


def _scene_info() -> dict:
    from ..workprecision import default_scenes

    out = {}
    for sc in default_scenes():
        out[sc.name] = f"{sc.potential!r}, m = {sc.m:g} kg, v0 = {sc.v0:g} m/s, ζ = {sc.zeta:g}"
    return out


def _start_map(quick: bool):
    """Run `dt_crit_map` in a forked process when there are >= 2 CPUs; None otherwise."""
    import multiprocessing as mp
    import os
    from concurrent.futures import ProcessPoolExecutor

    from ._dtmap import run_map

    if (os.cpu_count() or 1) < 2 or "fork" not in mp.get_all_start_methods():
        return None
    try:
        pool = ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("fork"))
        return pool, pool.submit(run_map, quick)
    except (OSError, RuntimeError):
        return None


def _finish_map(background):
    pool, future = background
    try:
        return future.result()
    finally:
        pool.shutdown()


def _bench_adapter(spec: str, out: Path, fig_dir: Path) -> dict:
    """Run `hcv bench` on one adapter; its JSON goes to out/bench/, its plot to figures/."""
    from ..bench.report import plot_speed_error, result_to_dict
    from ..bench.runner import run_bench

    safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in str(spec))[:60]
    (out / "bench").mkdir(parents=True, exist_ok=True)
    result = run_bench(spec, json_path=out / "bench" / f"{safe}.json")
    name = None
    if result.speed_error:
        name = f"bench_{safe}.png"
        plot_speed_error(result.speed_error, fig_dir / name)
    return {"result": result_to_dict(result), "figure": name}


def build_report(out_dir: str | Path = "reports", quick: bool = False,
                 progress: Callable[[str], None] | None = None, adapters=()) -> dict:
    """Run every verification and write the report; returns the results dict.

    Parameters
    ----------
    out_dir : str or Path
        Output directory (created; existing report files are overwritten).
    quick : bool
        Smaller study (see `quick_drops`), for CI and ``hcv report --quick``.
    progress : callable, optional
        Called with a short description before each step (e.g. a rich status).
    adapters : sequence of str
        Contact codes to benchmark (as for ``hcv bench``: a registered name,
        ``package.module:Class`` or ``cmd:COMMAND``); each scorecard becomes a
        section of the report, its JSON goes to ``bench/`` and its plot to ``figures/``.

    Returns
    -------
    dict
        The content of ``results.json`` (JSON-ready).
    """
    from . import _dtmap, _fig1, _hardcases, _render, _verdicts, _wp
    from ._environment import environment

    def say(text: str) -> None:
        if progress is not None:
            progress(text)

    out = Path(out_dir)
    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    for old in fig_dir.glob("*.png"):  # figures of an earlier run must not linger
        old.unlink()
    t_start = time.perf_counter()
    timings: dict[str, float] = {}

    def timed(name: str, fn, *args, **kw):
        say(name)
        t0 = time.perf_counter()
        res = fn(*args, **kw)
        timings[name] = time.perf_counter() - t0
        return res

    # The critical-step map (pure computation, no timings) runs in a second process
    # while the claims, Fig. 1 and the hard cases run here; the timed speed-against-
    # error study runs afterwards, alone.
    background = _start_map(quick)
    if background is not None:
        say("critical-step map: started in a second process")

    try:
        verdicts: dict[str, dict] = {}
        verdicts["thm1-period"] = timed("Theorem 1 at 40 digits", _verdicts.thm1_period)
        verdicts["thm2-harmonic"] = timed("Theorem 2: x(τ) of integrated trajectories",
                                          _verdicts.thm2_harmonic)
        verdicts["km-cancellation"] = timed("K, M cancellation", _verdicts.km_cancellation)
        verdicts["thm3-damping-iff"] = timed("Theorem 3: restitution against impact speed",
                                             _verdicts.thm3_damping)
        verdicts["sec7-effective-mass"] = timed("section 7: effective mass",
                                                _verdicts.sec7_effective_mass)
        verdicts["sec9-power-law"] = timed("section 9: power laws", _verdicts.sec9_power_law)
        verdicts["sec10-stiffening-domain"] = timed("section 10: stiffening domain",
                                                    _verdicts.sec10_stiffening)
        verdicts["table1"], table1_rows = timed("Table 1 at 50 digits", _verdicts.table1)

        fig1_runs = timed("Fig. 1: RK45 runs at RelTol = AbsTol = 1e-13", _fig1.run_fig1)
        verdicts["fig1"] = _fig1.fig1_verdict(fig1_runs)
        timed("Fig. 1: figure", _fig1.fig1_figure, fig1_runs, fig_dir / "fig1.png")

        hard = timed("hard cases", _hardcases.run_hard_cases, quick, say)
        sweeps = timed("hard cases: sweeps", _hardcases.run_sweeps, quick, say)
        u_star = float(verdicts["sec10-stiffening-domain"]["measured"]["root_over_a"])
        timed("hard cases: figure", _hardcases.sweeps_figure, sweeps, fig_dir / "hard_cases.png",
              u_star)
    except BaseException:
        if background is not None:
            background[0].shutdown(wait=False, cancel_futures=True)
        raise

    dmap = None
    if background is not None:
        try:
            dmap = timed("critical-step map (waiting for the second process)", _finish_map,
                         background)
        except Exception:  # a broken worker: measure here instead
            dmap = None
    if dmap is None:
        dmap = timed("critical-step map", _dtmap.run_map, quick, say)
    verdicts["sec6-dt-safe-bound"] = _dtmap.sec6_verdict(dmap)
    timed("critical-step map: figure", _dtmap.map_figure, dmap, fig_dir / "dt_crit_map.png")
    sens = timed("critical step against the criterion", _dtmap.run_sensitivity, quick)

    wp = timed("speed against error", _wp.run_wp, quick, say)
    wp_figs = timed("speed against error: figures", _wp.wp_figures, wp, fig_dir, _scene_info())

    tests = claim_tests()
    claims = []
    for c in CLAIMS:
        v = verdicts[c.id]
        if v["verdict"] not in VERDICTS:
            raise ValueError(f"claim {c.id}: verdict {v['verdict']!r} is not one of {VERDICTS}")
        claims.append({"id": c.id, "section": c.section, "statement": c.statement,
                       "verdict": v["verdict"], "evidence": v["evidence"], "rule": v["rule"],
                       "tests": tests.get(c.id, []), "measured": v["measured"]})

    bench = [timed(f"benchmark of {spec}", _bench_adapter, spec, out, fig_dir)
             for spec in adapters]

    figures = ["fig1.png", "dt_crit_map.png"] + [n for n, _ in wp_figs] + ["hard_cases.png"]
    figures += [b["figure"] for b in bench if b.get("figure")]
    results = {
        "title": "Verification report: Hidden Harmonic Structure, Universal Damping, and "
                 "Stability Bounds in Nonlinear Contact Dynamics (Y. T. Feng)",
        "generated_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "mode": "quick" if quick else "full",
        "quick_drops": quick_drops() if quick else [],
        "claims": claims,
        "table1": table1_rows,
        "fig1": {"runs": _fig1.fig1_table(fig1_runs), "rtol": _fig1.RTOL, "atol": _fig1.ATOL,
                 "figure": "figures/fig1.png"},
        "dt_crit_map": records(dmap),
        "dt_crit_sensitivity": records(sens),
        "dt_crit_map_coverage": [{"family": c.family, "case": c.label, "m": c.m,
                                  "velocities": list(c.velocities)} for c in coverage(quick)],
        "work_precision": records(wp),
        "work_precision_summary": [jsonable(r) for r in _wp.wp_summary(wp)],
        "work_precision_settings": _wp.settings_text(quick),
        "work_precision_scenes": _scene_info(),
        "hard_cases": {"cases": [jsonable(r) for r in hard],
                       "sweeps": jsonable(sweeps),
                       "accuracy": _hardcases.lost_accuracy(hard, sweeps["speed"] + sweeps["depth"])},
        "figures": [f"figures/{n}" for n in figures],
        "figure_captions": {n: cap for n, cap in wp_figs},
        "environment": environment({"thm2_random_KM": _verdicts.SEED_KM}),
        "adapters": [b["result"] for b in bench],
    }
    timings["total"] = time.perf_counter() - t_start
    results["timings_seconds"] = timings
    say("writing index.html, index.md, results.json")
    results = jsonable(results)
    (out / "results.json").write_text(json.dumps(results, indent=1, allow_nan=False,
                                                  ensure_ascii=False) + "\n")
    (out / "index.md").write_text(_render.markdown(results))
    (out / "index.html").write_text(_render.html_page(results, fig_dir))
    return results
