"""``hcv report``: one run of every verification, its results.json, then the report's pages.

`build_report` measures the claims, Table 1, Fig. 1, the critical-step map, the
speed-against-error study, the hard cases, the damping laws and, with ``--adapter``, the
contact codes; it writes into ``out_dir``:

* ``results.json`` -- every result, schema ``hcv-results/1.3``
  (`reference_impl.report._schema`);
* ``figures/*.png`` -- drawn from the same results;
* ``index.html``, ``index.md``, ``erratum.md`` -- rendered from results.json by
  `reference_impl.report` (which computes nothing: ``hcv report --from`` re-renders);
* ``bench/*.json`` -- each code's scorecard.

The studies are those of `reference_impl.studies` (hard cases, sensitivity, laws,
work-precision), the claims' own measurements (`reference_impl.claims`), the map
(`_map`) and the codes' resolution study (`_steps`). Every number in the output is
computed by the run that writes it, except the code sections when no code is asked:
those are carried from the previous report in ``out_dir`` (checked as input), marked with
the commit and date they come from (``results["carried"]``).

Nothing is written before the arguments are checked (`validate_report_args`) and the
provenance is taken; the report is written into a temporary directory beside ``out_dir``
and swapped in only when complete, so an error or Ctrl-C leaves the previous report intact.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import time
from collections.abc import Callable
from pathlib import Path

from reference_impl import _procs
from reference_impl._format import g, jsonable
from reference_impl.bench.scorecard._json import result_to_dict
from reference_impl.bench.scorecard.compare import plot_speed_error
from reference_impl.bench.scorecard.runner import run_bench
from reference_impl.campaign import (
    _assembly,
    _codes,
    _drawing,
    _environment,
    _map,
    _steps,
    _truths,
)
from reference_impl.claims import (
    CLAIMS,
    VERDICTS,
    _scan,
    sec6_assemblies,
    sec6_dt_safe_bound,
    sec10_stiffening_domain,
    table1,
    thm2_harmonic,
)
from reference_impl.claims import fig1 as fig1_claim
from reference_impl.errors import HCVInputError
from reference_impl.report import (
    SCHEMA,
    _assemblies,
    _dtmap,
    _fig1,
    _hardcases,
    _laws,
    _wp,
    bench_json_name,
    check_results,
    read_results,
    write_pages,
)
from reference_impl.report._files import scripts_href, swap_in, validate_report_args
from reference_impl.report._inputs import read_report_file
from reference_impl.report.readme_table import ROOT, readme_block, rewrite_readme
from reference_impl.stability.recommend import RECOMMEND_FACTOR, RECOMMEND_FACTOR_SINGULAR
from reference_impl.stability.search import SearchGrid
from reference_impl.studies import hardcases, laws, sensitivity, wp_summary
from reference_impl.studies.dtcrit_map import coverage
from reference_impl.studies.paper import FIG1
from reference_impl.studies.workprecision import (
    IVP_METHODS,
    IVP_RTOLS,
    VERLET_STEPS,
    default_scenes,
)

__all__ = ["CARRIED", "build_report", "quick_drops", "readme_rewritten_by", "validate_report_args"]

# The fields of results.json that a run without codes carries from the previous report.
CARRIED = ("adapters", "steps_per_contact", "steps_per_contact_settings", "codes_side_by_side")


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
        f"work-precision: scene {', '.join(wp_summary.QUICK_SKIP)} dropped; solve_ivp methods "
        f"{', '.join(m for m in IVP_METHODS if m not in ('DOP853', 'RK45'))} "
        f"dropped; rtol {', '.join(g(r) for r in IVP_RTOLS if r not in kept_rtols)} dropped; "
        f"Verlet at {', '.join(str(n) for n in VERLET_STEPS if n not in kept_steps)} steps per "
        f"contact dropped",
        f"critical-step map: {len(gone_cases)} power laws dropped "
        f"({', '.join(gone_cases)}); fewer speeds for {', '.join(fewer_speeds)}",
        f"hard cases: {len(hardcases.case_labels(True))} of {len(hardcases.case_labels(False))} "
        "cases, shorter sweeps",
        f"assemblies: the linear closed forms on {len(_assembly.linear_cases(True))} of "
        f"{len(_assembly.linear_cases(False))} cases (the table's claim states its own quick "
        "cases and horizon)",
    ]


def _scene_info() -> dict:
    out = {}
    for sc in default_scenes():
        out[sc.name] = f"{sc.potential!r}, m = {sc.m:g} kg, v0 = {sc.v0:g} m/s, ζ = {sc.zeta:g}"
    return out


def _records(df) -> list[dict]:
    """DataFrame rows as JSON-ready dicts."""
    return [jsonable(r) for r in df.to_dict(orient="records")]


def _bench_adapter(spec: str, out: Path, fig_dir: Path) -> dict:
    """Run `hcv bench` on one adapter; its JSON goes to out/bench/, its plot to figures/."""
    rel = bench_json_name(spec)
    (out / "bench").mkdir(parents=True, exist_ok=True)
    result = run_bench(spec, json_path=out / rel)
    name = None
    if result.speed_error:
        name = f"bench_{Path(rel).stem}.png"
        plot_speed_error(result.speed_error, fig_dir / name)
    return {"result": result_to_dict(result), "figure": name}


def _carry(out: Path, adapters) -> tuple[dict | None, str]:
    """The code sections of the previous report in ``out`` when no code is asked.

    Returns
    -------
    (dict or None, str)
        The carried fields (`CARRIED`, ``figures``, ``carried``) and a line saying what was
        carried or why nothing was; None when there is nothing to carry.
    """
    prev = out / "results.json"
    if adapters or not prev.is_file():
        return None, ""
    try:  # the whole document, and the figures carried as files (the only ones read)
        old = read_results(prev, "previous report", files=False)
        if not old["adapters"] and not old["steps_per_contact"]:
            return None, ""
        figures = [f for f in old["figures"] if Path(f).name.startswith(("bench_", "steps_"))]
        for rel in figures:
            where = f"previous report {str(prev)!r}: $.figures[{old['figures'].index(rel)}]"
            read_report_file(out, rel, where, head_only=True)
    except HCVInputError as exc:
        return None, f"the previous report's code sections are not carried: {exc}"
    env = old["environment"]
    source = old["carried"] or {
        "git_commit": env.get("git_commit"),
        "git_dirty": env.get("git_dirty"),
        "generated_utc": old["generated_utc"],
        "adapters": [d.get("adapter") for d in old["adapters"]],
    }
    source = {
        **source,
        "sections": [*CARRIED, "assemblies.code_advice"],
        "reason": "no --adapter given",  # the notice says "not run by this report" itself
    }
    data = {k: old.get(k) for k in CARRIED}  # codes_side_by_side: absent from older files
    data.update(figures=figures, carried=source)
    data["code_advice"] = (old.get("assemblies") or {}).get("code_advice")  # 1.2 and later
    names = ", ".join(str(a) for a in source["adapters"])
    return data, (
        f"contact codes ({names}): not run; their sections are carried from the report of "
        f"{source['generated_utc']} (commit {str(source['git_commit'])[:12]})"
    )


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
        Empty: the previous report's code sections in ``out_dir`` are carried, marked.
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
        The content of ``results.json`` (JSON-ready, schema ``hcv-results/1.3``).

    Raises
    ------
    HCVInputError
        A bad argument (unknown adapter, unwritable or non-directory ``out_dir``),
        before anything is run or written.
    """
    out, adapters = validate_report_args(out_dir, adapters, force=force)
    readme_path = _readme_for(out, readme)
    carried, note = _carry(out, adapters)
    if note and progress is not None:
        progress(note)
    # Provenance first: the temporary directory must not make the checkout look dirty.
    env = _environment.environment({"thm2_random_KM": thm2_harmonic.SEED_KM})
    busy = _environment.load_note(env.get("load_average_start"), env.get("cpu_count"))
    if busy and progress is not None:
        progress(busy)
    with swap_in(out) as tmp:
        if carried is not None:  # the carried figures move in again with the new report
            (tmp / "figures").mkdir()
            for rel in carried["figures"]:  # checked again as they are read: never a link
                (tmp / rel).write_bytes(read_report_file(out, rel, f"previous report: {rel}"))
        results = _build(tmp, quick, progress, adapters, env, workers, carried, scripts_href(out))
    if readme_path is not None:
        # The speed block follows the committed benchmark (nox -s bench), when present.
        bench_json = Path(out) / "bench" / "exact.json"
        bench = json.loads(bench_json.read_text()) if bench_json.is_file() else None
        startup_json = Path(out) / "bench" / "startup.json"
        startup = json.loads(startup_json.read_text()) if startup_json.is_file() else None
        wp_json = Path(out) / "bench" / "workprecision.json"  # the speed block's figure
        wp = json.loads(wp_json.read_text()) if wp_json.is_file() else None
        bp_json = Path(out) / "bench" / "batch_peer.json"  # the batch against the parallel peer
        bp = json.loads(bp_json.read_text()) if bp_json.is_file() else None
        readme_path.write_text(
            rewrite_readme(results, readme_path.read_text(), bench, startup, wp, bp)
        )
        docs = ROOT / "docs" / "assemblies.md"  # its generated block, beside the README's
        if readme_path == ROOT / "README.md" and docs.is_file():
            docs.write_text(_assemblies.rewrite_docs(results, docs.read_text()))
    return results


def readme_rewritten_by(out_dir: str | Path) -> Path | None:
    """The README whose generated blocks `build_report` (``readme="auto"``) rewrites when
    it writes into ``out_dir``: the checkout's README.md for its ``reports/``, else None.
    """
    out = Path(os.path.realpath(Path(out_dir).expanduser()))  # as validate_report_args
    try:
        return _readme_for(out, "auto")
    except HCVInputError:  # unreadable or unwritable: build_report refuses to run
        return None


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
    out: Path,
    quick: bool,
    progress,
    adapters,
    env: dict,
    workers: int = 0,
    carried=None,
    repro=None,
) -> dict:
    """Run everything and write the report into ``out`` (a fresh directory).

    ``carried`` holds the previous report's code sections (`_carry`); ``repro`` is the link
    from the final directory to the referee's scripts (None: not there, named unlinked).
    """
    sec6 = sec6_dt_safe_bound

    def say(text: str) -> None:
        _procs.raise_if_terminated()  # a SIGTERM whose interrupt a finaliser swallowed
        if progress is not None:
            progress(text)

    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    timings: dict[str, float] = {}

    # The stages `timed` announces, so that a log shows "stage k of n" (claims but
    # section 6, Fig. 1, hard cases, sweeps, their figure, the map, its figure, the
    # criterion study, speed against error and its figures, one per adapter).
    # 9 fixed stages, 2 of the damping-law study, 2 of the assemblies (linear checks,
    # figures), one per adapter and the steps study and the codes side by side
    chain_codes = _assembly.advice_codes(adapters)
    n_stages = len(CLAIMS) - 1 + 9 + 2 + 2 + len(adapters) + (2 if adapters else 0)
    n_stages += 1 if chain_codes else 0
    n_stages += 1 if workers == 0 else 0  # waiting for the truths computed in the background
    stage = [0]

    loads: dict[str, list] = {}  # the load beside every timing (issue 41)

    def load_1min() -> float | None:
        avg = _environment.load_average()
        return None if avg is None else avg[0]

    def timed(name: str, fn, *args, **kw):
        stage[0] += 1
        say(f"{name} (stage {min(stage[0], n_stages)} of {n_stages})")
        start = load_1min()
        t0 = time.perf_counter()
        res = fn(*args, **kw)
        timings[name] = time.perf_counter() - t0
        loads[name] = [start, load_1min()]
        return res

    # The critical-step map (pure computation, no timings) runs in background processes
    # while the claims, Fig. 1 and the hard cases run here; the timed speed-against-
    # error study runs afterwards, alone.
    # With workers > 0 the map runs on a local Dask cluster after the claims instead.
    background = _map.start_map(quick) if workers == 0 else None
    # Behind the map's searches, the same processes compute the 30-digit truths of the
    # speed-against-error study (`_truths`: ~3/4 of its CPU time, none of it timed).
    truths = None
    if background is not None:
        try:
            truths = _truths.submit_truths(background[0], quick)
        except (OSError, RuntimeError):  # a broken pool: the study computes them itself
            truths = None

    measured: dict = {}
    try:
        if background is not None:
            say(f"critical-step map: started in {_map.MAP_WORKERS} background processes")
        for c in CLAIMS:
            if c.id != sec6.ID:  # section 6 is measured on the map below
                measured[c.id] = timed(f"claim {c.id}", c.measure, quick)
        timed(
            "Fig. 1: figure",
            _fig1.fig1_figure,
            fig1_claim.runs(),
            fig_dir / "fig1.png",
            FIG1,
            fig1_claim.RTOL,
        )
        hard = timed("hard cases", hardcases.run_hard_cases, quick, say)
        sweeps = timed("hard cases: sweeps", hardcases.run_sweeps, quick, say)
        u_star = float(sec10_stiffening_domain.root_over_a())
        timed(
            "hard cases: figure",
            _hardcases.sweeps_figure,
            sweeps,
            fig_dir / "hard_cases.png",
            u_star,
            hardcases.SETTINGS,
        )
    except BaseException:
        if background is not None:
            background[0].shutdown(wait=False, cancel_futures=True)
        raise

    try:
        dmap = None
        if background is not None:
            try:
                dmap = timed(
                    "critical-step map (waiting for the background processes)",
                    _map.finish_map,
                    background,
                    close=truths is None,
                )
            except Exception:  # a broken worker: measure here instead
                dmap = None
        if dmap is None:
            dmap = timed("critical-step map", _map.run_map, quick, say, workers)
        measured[sec6.ID] = sec6.verdict_from_map(dmap)
        timed("critical-step map: figure", _dtmap.map_figure, dmap, fig_dir / "dt_crit_map.png")
        sens = timed("critical step against the criterion", sensitivity.run_sensitivity, quick)
        if truths is not None:
            try:  # all of them before the timed study starts: nothing runs beside its timings
                timed(
                    "speed against error: truths (waiting for the background processes)",
                    _truths.collect_truths,
                    truths,
                    quick,
                )
            except Exception:  # a broken worker: the study computes the truths itself
                pass
    finally:
        if truths is not None:
            background[0].shutdown(wait=False, cancel_futures=True)

    wp = timed("speed against error", wp_summary.run_wp, quick, say)
    # Its figures (the largest drawing of the report) are drawn in a forked process while
    # the stages below run here (`_drawing`): the same function on the same data.
    wp_draw = (wp, fig_dir, _scene_info(), wp_summary.scene_families())
    drawing = _drawing.start(_wp.wp_figures, *wp_draw)
    try:
        law_rows = timed("damping laws: restitution against speed", laws.laws_results, quick)
        timed("damping laws: figure", _laws.laws_figure, law_rows, fig_dir / _laws.FIGURE)
        # Assemblies: the nonlinear table and P_fail curves are the claim's measurement (run
        # with the claims above); this stage adds the linear closed forms and the figures.
        asm_linear = timed("assemblies: linear closed forms", _assembly.linear_checks, quick)
        asm_rows = measured[sec6_assemblies.ID].figures["rows"]
        asm_figs = timed("assemblies: figures", _assemblies.assemblies_figures, asm_rows, fig_dir)
    except BaseException:
        _drawing.cancel(drawing)
        raise
    wp_figs = timed(
        "speed against error: figures"
        + (" (waiting for the background process)" if drawing else ""),
        _drawing.finish,
        drawing,
        _wp.wp_figures,
        *wp_draw,
    )

    tests = _scan.claim_tests()
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
    steps = (
        timed("steps per contact", _steps.resolution_study, adapters, fig_dir) if adapters else []
    )

    side = (
        timed("codes side by side", _codes.codes_side_by_side, adapters, say) if adapters else None
    )
    advice = (  # issue 39 section 4: None when no code that runs chains is asked
        timed("assemblies: the codes' step advice", _assembly.code_advice, chain_codes)
        if chain_codes
        else None
    )

    figures = ["fig1.png", "dt_crit_map.png"] + [n for n, _ in wp_figs] + ["hard_cases.png"]
    figures.append(_laws.FIGURE)
    figures += [f.split("/")[-1] for f in asm_figs]
    figures += [b["figure"] for b in bench if b.get("figure")]
    figures += [c["figure"] for c in steps if c.get("figure")]
    figures = [f"figures/{n}" for n in figures]
    codes = {
        "adapters": [b["result"] for b in bench],
        "steps_per_contact": steps,
        "steps_per_contact_settings": _steps.settings() if adapters else None,
        "codes_side_by_side": side,
        "carried": None,
    }
    if carried is not None:
        codes = {k: carried[k] for k in (*CARRIED, "carried")}
        figures += carried["figures"]
        advice = carried["code_advice"]
    results = {
        "schema": SCHEMA,
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
        "dt_crit_map": _records(dmap),
        "dt_crit_sensitivity": _records(sens),
        "dt_crit_map_coverage": [
            {"family": c.family, "case": c.label, "m": c.m, "velocities": list(c.velocities)}
            for c in coverage(quick)
        ],
        "dt_crit_settings": {
            "recommend_factor": RECOMMEND_FACTOR,
            "recommend_factor_singular": RECOMMEND_FACTOR_SINGULAR,
            "search_resolution": SearchGrid().resolution,
        },
        "work_precision": _records(wp),
        "work_precision_summary": [jsonable(r) for r in wp_summary.wp_summary(wp)],
        "work_precision_settings": wp_summary.settings_text(quick),
        "work_precision_scenes": _scene_info(),
        "work_precision_families": {
            "dop853_rtol": wp_summary.SUMMARY_RTOL,
            "rows": wp_summary.family_summary(_records(wp)),
        },
        "hard_cases": {
            "cases": [jsonable(r) for r in hard],
            "sweeps": jsonable(sweeps),
            "accuracy": hardcases.lost_accuracy(hard, sweeps["speed"] + sweeps["depth"]),
            "settings": hardcases.SETTINGS,
        },
        "damping_laws": law_rows,
        "assemblies": {
            "claim": sec6_assemblies.ID,
            "linear": asm_linear,
            "figures": dict(zip(("p_fail", "factor"), asm_figs, strict=True)),
            # Issue 39 section 4: the codes' step advice on chains (a list), run with the
            # codes or carried from the previous report with their other sections.
            "code_advice": advice,
        },
        "figures": figures,
        "figure_captions": {n: cap for n, cap in wp_figs},
        "environment": env,
        **codes,
    }
    timings["total"] = time.perf_counter() - t_start
    results["timings_seconds"] = timings
    results["stage_loads"] = loads
    _environment.record_end(results["environment"], say)
    say("writing results.json, index.html, index.md, erratum.md")
    results = jsonable(results)
    # The renderer reads only checked documents, this run's too: a study writing a field
    # the schema (report/results.schema.json) does not describe fails here, in one line.
    check_results(results, "results.json of this run", base=out)
    (out / "results.json").write_text(
        json.dumps(results, indent=1, allow_nan=False, ensure_ascii=False) + "\n"
    )
    write_pages(results, out, fig_dir, repro)
    return results
