"""``hcv report``: one run of every verification, written as HTML, Markdown and JSON.

`build_report` runs the claim measurements, Table 1, Fig. 1, the critical-step
map, the speed-against-error study and the hard cases on the embedded default
scenes, and writes into ``out_dir``:

* ``index.html`` -- one self-contained page (figures embedded as data URIs);
* ``index.md`` -- the same content for a code host (figures linked);
* ``erratum.md`` -- the referee's erratum (`_erratum`), also a section of both pages;
* ``results.json`` -- machine-readable results (claims, table1, dt_crit_map,
  work_precision, hard_cases, environment, ...);
* ``figures/*.png``.

Every number in the output is computed by the run that writes it; the only
numbers typed in are the paper's own (`reference_impl.studies.paper`) and the
tolerances of the verdict rules (stated next to each verdict). Each claim's
verdict is its module's ``measure()`` (`reference_impl.claims`): the report
loops over the registry and the tests assert on the same measurements.

Nothing is written before the arguments are checked (`validate_report_args`)
and the provenance is taken; the report is written into a temporary directory
beside ``out_dir`` and swapped in only when complete, so an error or Ctrl-C
leaves the previous report intact.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import time
from collections.abc import Callable
from pathlib import Path

from reference_impl.bench.report import plot_speed_error, result_to_dict
from reference_impl.bench.runner import run_bench
from reference_impl.claims import (
    CLAIMS,
    VERDICTS,
    sec6_dt_safe_bound,
    sec10_stiffening_domain,
    table1,
    thm2_harmonic,
)
from reference_impl.claims import fig1 as fig1_claim
from reference_impl.errors import HCVInputError
from reference_impl.report import _dtmap, _erratum, _fig1, _hardcases, _laws, _render, _wp
from reference_impl.report._common import claim_tests, g, jsonable, records
from reference_impl.report._files import scripts_href, swap_in, validate_report_args
from reference_impl.report._hardcases import _cases
from reference_impl.report._steps import resolution_study
from reference_impl.report._wp import QUICK_SKIP
from reference_impl.report.readme_table import ROOT, readme_block
from reference_impl.studies.dtcrit_map import coverage
from reference_impl.studies.workprecision import (
    IVP_METHODS,
    IVP_RTOLS,
    VERLET_STEPS,
    default_scenes,
)
from reference_impl.sweep._map import map_case, map_frame, map_items

__all__ = ["build_report", "quick_drops", "validate_report_args"]


def quick_drops() -> list[str]:
    """What --quick leaves out, read from the settings of each study (shown in the report)."""

    def cov(quick):
        return {c.label: c.velocities for c in coverage(quick)}

    full, quick = cov(False), cov(True)
    gone_cases = [k for k in full if k not in quick]
    fewer_speeds = [
        f"{k} ({len(quick[k])} of {len(full[k])} speeds)"
        for k in quick
        if k in full and len(quick[k]) < len(full[k])
    ]
    kept_rtols = set(IVP_RTOLS[::2])
    kept_steps = set(VERLET_STEPS[::2])

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
    out = {}
    for sc in default_scenes():
        out[sc.name] = f"{sc.potential!r}, m = {sc.m:g} kg, v0 = {sc.v0:g} m/s, ζ = {sc.zeta:g}"
    return out


# Processes of the background map: the claims and hard cases run here meanwhile (about a
# third of the map's CPU time), so on 2 cores a second map worker uses the core this
# process frees (quick report, machine at load 2-3: the wait for the map fell from 23 s
# to 16 s; the same table). The timed study starts only when all of them are done.
_MAP_WORKERS = 2


def _start_map(quick: bool):
    """Run the searches of the critical-step map in forked processes (>= 2 CPUs); None
    otherwise. Returns the pool and one future per search, in the map's order."""
    import multiprocessing as mp
    import os
    from concurrent.futures import ProcessPoolExecutor

    if (os.cpu_count() or 1) < 2 or "fork" not in mp.get_all_start_methods():
        return None
    try:
        pool = ProcessPoolExecutor(max_workers=_MAP_WORKERS, mp_context=mp.get_context("fork"))
        return pool, [pool.submit(map_case, item) for item in map_items(quick=quick)]
    except (OSError, RuntimeError):
        return None


def _finish_map(background):
    """The map's table from the background searches (`dt_crit_map_on_cluster`'s table)."""

    pool, futures = background
    try:
        frame = map_frame([f.result() for f in futures])
    except BaseException:
        # Ctrl-C, SIGTERM or a broken worker: the searches not yet started are dropped and
        # no running one is waited for (shutdown() would wait up to a search's length).
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    return frame


def _bench_adapter(spec: str, out: Path, fig_dir: Path) -> dict:
    """Run `hcv bench` on one adapter; its JSON goes to out/bench/, its plot to figures/."""

    safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in str(spec))[:60]
    (out / "bench").mkdir(parents=True, exist_ok=True)
    result = run_bench(spec, json_path=out / "bench" / f"{safe}.json")
    name = None
    if result.speed_error:
        name = f"bench_{safe}.png"
        plot_speed_error(result.speed_error, fig_dir / name)
    return {"result": result_to_dict(result), "figure": name}


def build_report(
    out_dir: str | Path = "reports",
    quick: bool = False,
    progress: Callable[[str], None] | None = None,
    adapters=(),
    readme: str | Path | None = "auto",
    workers: int = 0,
    force: bool = False,
) -> dict:
    """Run every verification and write the report; returns the results dict.

    Parameters
    ----------
    out_dir : str or Path
        Output directory (a symlink is followed). The report's files are moved in
        when the run completes; files it did not write are kept, and a directory
        holding files it does not own is refused unless ``force`` (see
        `reference_impl.report._files`).
    quick : bool
        Smaller study (see `quick_drops`), for CI and ``hcv report --quick``.
    progress : callable, optional
        Called with a short description before each step (e.g. a rich status).
    adapters : sequence of str
        Contact codes to benchmark (as for ``hcv bench``: a registered name,
        ``package.module:Class`` or ``cmd:COMMAND``); each scorecard becomes a
        section of the report, its JSON goes to ``bench/`` and its plot to ``figures/``.
    readme : str, Path or None
        README whose ``<!-- verdicts:start/end -->`` block is regenerated from this
        run's results (`readme_table`). "auto": the checkout's README.md when
        ``out_dir`` is the checkout's ``reports/``; None: leave any README alone.
    workers : int
        0 (default): the critical-step map runs in two background processes beside the claims.
        N > 0: it runs on a local Dask cluster of N processes (``hcv sweep``'s engine;
        needs the ``sweep`` extra), which pays off on machines with more than 2 cores.
    force : bool
        Write into a directory that holds files the report did not write (its
        manifest does not list them); files of the report's names are replaced.

    Returns
    -------
    dict
        The content of ``results.json`` (JSON-ready).

    Raises
    ------
    HCVInputError
        A bad argument (unknown adapter, unwritable or non-directory ``out_dir``),
        before anything is run or written.
    """
    out, adapters = validate_report_args(out_dir, adapters, force=force)
    readme_path = _readme_for(out, readme)
    from reference_impl.report._environment import environment

    # Provenance first: the temporary directory must not make the checkout look dirty.
    env = environment({"thm2_random_KM": thm2_harmonic.SEED_KM})
    with swap_in(out) as tmp:
        results = _build(
            tmp, quick, progress, adapters, env, sec6_dt_safe_bound, workers, scripts_href(out)
        )
    if readme_path is not None:
        from reference_impl.report.readme_table import rewrite_readme

        # The speed block follows the committed benchmark (nox -s bench), when present.
        bench_json = Path(out) / "bench" / "exact.json"
        bench = json.loads(bench_json.read_text()) if bench_json.is_file() else None
        startup_json = Path(out) / "bench" / "startup.json"
        startup = json.loads(startup_json.read_text()) if startup_json.is_file() else None
        readme_path.write_text(rewrite_readme(results, readme_path.read_text(), bench, startup))
    return results


def _readme_for(out: Path, readme) -> Path | None:
    """The README to update (checked before anything runs), or None."""

    if readme is None:
        return None
    if readme == "auto":
        path = ROOT / "README.md"
        if out != (ROOT / "reports").absolute() or not path.is_file():
            return None
        try:
            readme_block(path.read_text())
        except HCVInputError:  # a README without the verdict block is left alone
            return None
    else:
        path = Path(readme)
    try:
        readme_block(path.read_text())
    except OSError as exc:
        raise HCVInputError(f"README {str(path)!r} cannot be read ({exc})") from None
    if not os.access(path, os.W_OK):
        raise HCVInputError(f"README {str(path)!r} is not writable")
    return path


def _build(
    out: Path, quick: bool, progress, adapters, env: dict, sec6, workers: int = 0, repro=None
) -> dict:
    """Run everything and write the report into ``out`` (a fresh, empty directory).

    ``repro`` is the link from the final directory to the referee's scripts (None: they are
    not there, and the report names them without a link).
    """

    def say(text: str) -> None:
        if progress is not None:
            progress(text)

    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    timings: dict[str, float] = {}

    # The stages `timed` announces, so that a log shows "stage k of n" (claims but
    # section 6, Fig. 1, hard cases, sweeps, their figure, the map, its figure, the
    # criterion study, speed against error and its figures, one per adapter).
    # 9 fixed stages, 2 of the damping-law study, one per adapter and the steps study
    n_stages = len(CLAIMS) - 1 + 9 + 2 + len(adapters) + (1 if adapters else 0)
    stage = [0]

    def timed(name: str, fn, *args, **kw):
        stage[0] += 1
        say(f"{name} (stage {min(stage[0], n_stages)} of {n_stages})")
        t0 = time.perf_counter()
        res = fn(*args, **kw)
        timings[name] = time.perf_counter() - t0
        return res

    # The critical-step map (pure computation, no timings) runs in background processes
    # while the claims, Fig. 1 and the hard cases run here; the timed speed-against-
    # error study runs afterwards, alone.
    # With workers > 0 the map runs on a local Dask cluster after the claims instead.
    background = _start_map(quick) if workers == 0 else None
    if background is not None:
        say(f"critical-step map: started in {_MAP_WORKERS} background processes")

    measured: dict = {}
    try:
        for c in CLAIMS:
            if c.id != sec6.ID:  # section 6 is measured on the map below
                measured[c.id] = timed(f"claim {c.id}", c.measure, quick)
        timed("Fig. 1: figure", _fig1.fig1_figure, fig1_claim.runs(), fig_dir / "fig1.png")
        hard = timed("hard cases", _hardcases.run_hard_cases, quick, say)
        sweeps = timed("hard cases: sweeps", _hardcases.run_sweeps, quick, say)
        u_star = float(sec10_stiffening_domain.root_over_a())
        timed(
            "hard cases: figure",
            _hardcases.sweeps_figure,
            sweeps,
            fig_dir / "hard_cases.png",
            u_star,
        )
    except BaseException:
        if background is not None:
            background[0].shutdown(wait=False, cancel_futures=True)
        raise

    dmap = None
    if background is not None:
        try:
            dmap = timed(
                "critical-step map (waiting for the background processes)", _finish_map, background
            )
        except Exception:  # a broken worker: measure here instead
            dmap = None
    if dmap is None:
        dmap = timed("critical-step map", _dtmap.run_map, quick, say, workers)
    sec6.use_map(quick, dmap)
    measured[sec6.ID] = sec6.measure(quick)
    timed("critical-step map: figure", _dtmap.map_figure, dmap, fig_dir / "dt_crit_map.png")
    sens = timed("critical step against the criterion", _dtmap.run_sensitivity, quick)

    wp = timed("speed against error", _wp.run_wp, quick, say)
    wp_figs = timed("speed against error: figures", _wp.wp_figures, wp, fig_dir, _scene_info())
    laws = timed("damping laws: restitution against speed", _laws.run_laws, quick)
    timed("damping laws: figure", _laws.laws_figure, laws, fig_dir / _laws.FIGURE)

    tests = claim_tests()
    claims = []
    for c in CLAIMS:
        m = measured[c.id]
        if m.verdict not in VERDICTS:
            raise ValueError(f"claim {c.id}: verdict {m.verdict!r} is not one of {VERDICTS}")
        d = m.to_dict()
        claims.append(
            {
                "id": c.id,
                "section": c.section,
                "statement": c.statement,
                "verdict": d["verdict"],
                "evidence": d["evidence"],
                "rule": d["rule"],
                "tests": tests.get(c.id, []),
                "measured": d["measured"],
                "counterexample": d["counterexample"],
                "headline": d["headline"],
            }
        )

    bench = [timed(f"benchmark of {spec}", _bench_adapter, spec, out, fig_dir) for spec in adapters]
    steps = timed("steps per contact", resolution_study, adapters, fig_dir) if adapters else []

    figures = ["fig1.png", "dt_crit_map.png"] + [n for n, _ in wp_figs] + ["hard_cases.png"]
    figures.append(_laws.FIGURE)
    figures += [b["figure"] for b in bench if b.get("figure")]
    figures += [c["figure"] for c in steps if c.get("figure")]
    results = {
        "title": "Verification report: Hidden Harmonic Structure, Universal Damping, and "
        "Stability Bounds in Nonlinear Contact Dynamics (Y. T. Feng)",
        "generated_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "mode": "quick" if quick else "full",
        "quick_drops": quick_drops() if quick else [],
        "claims": claims,
        "table1": measured[table1.ID].figures["rows"],
        "fig1": {
            "runs": fig1_claim.table(),
            "rtol": fig1_claim.RTOL,
            "atol": fig1_claim.ATOL,
            "figure": "figures/fig1.png",
        },
        "dt_crit_map": records(dmap),
        "dt_crit_sensitivity": records(sens),
        "dt_crit_map_coverage": [
            {"family": c.family, "case": c.label, "m": c.m, "velocities": list(c.velocities)}
            for c in coverage(quick)
        ],
        "work_precision": records(wp),
        "work_precision_summary": [jsonable(r) for r in _wp.wp_summary(wp)],
        "work_precision_settings": _wp.settings_text(quick),
        "work_precision_scenes": _scene_info(),
        "hard_cases": {
            "cases": [jsonable(r) for r in hard],
            "sweeps": jsonable(sweeps),
            "accuracy": _hardcases.lost_accuracy(hard, sweeps["speed"] + sweeps["depth"]),
        },
        "damping_laws": laws,
        "figures": [f"figures/{n}" for n in figures],
        "figure_captions": {n: cap for n, cap in wp_figs},
        "environment": env,
        "adapters": [b["result"] for b in bench],
        "steps_per_contact": steps,
    }
    timings["total"] = time.perf_counter() - t_start
    results["timings_seconds"] = timings
    say("writing index.html, index.md, results.json")
    results = jsonable(results)
    (out / "results.json").write_text(
        json.dumps(results, indent=1, allow_nan=False, ensure_ascii=False) + "\n"
    )
    # Where the referee's scripts lie depends on the final directory, not on the results:
    # the pages get it, results.json does not (copied elsewhere, it would link wrongly).
    pages = {**results, "repro_scripts": repro}
    (out / "index.md").write_text(_render.markdown(pages))
    (out / "erratum.md").write_text(_erratum.markdown(pages))
    (out / "index.html").write_text(_render.html_page(pages, fig_dir))
    return results
