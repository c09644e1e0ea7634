"""The load beside the timings a report run measures (issue 41, section 2).

The main job re-measured the work-precision timings at load 15 on 2 cores, 3-10x slower
than the committed ones, without a word. A run records the load average at its start and
end and numba's cache at its start in ``results.json``'s environment, prints a warning
line when the load exceeds the cores, and the README's verdict block states the run's
time with them (the main job's time has that one home). Fast: the build is a stub.
"""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest

import reference_impl.campaign as campaign
from reference_impl.campaign import _environment
from reference_impl.report.readme_table import verdict_table
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
REPORTS = ROOT / "reports"


def test_the_environment_records_load_and_compile_cache():
    env = _environment.environment({})
    load, cache = env["load_average_start"], env["compile_cache_start"]
    assert_true(
        (load is None or (len(load) == 3 and all(x >= 0 for x in load)))
        and isinstance(cache["entries"], int)
        and cache["entries"] >= 0,
        got=f"load {load!r}, cache {cache!r}",
        should="three load averages >= 0 (or None where unknown), a count of cache entries",
        claim="report",
        call="campaign._environment.environment",
    )


@pytest.mark.parametrize(
    "load, cores, warns",
    [([15.0, 12.0, 9.0], 2, True), ([1.9, 3.0, 3.0], 2, False), (None, 2, False)],
)
def test_a_load_above_the_cores_is_a_warning(load, cores, warns):
    note = _environment.load_note(load, cores)
    assert_true(
        (note is not None) == warns and (not warns or f"load {load[0]:g} on {cores}" in note),
        got=repr(note),
        should="a warning naming the load and cores" if warns else "None",
        claim="report",
        call=f"load_note({load}, {cores})",
    )


def test_the_readme_block_states_the_runs_time_load_and_cache():
    results = json.loads((REPORTS / "results.json").read_text())
    r = copy.deepcopy(results)
    r["environment"].update(
        load_average_start=[15.0, 9.0, 8.0],
        load_average_end=[14.2, 10.0, 8.5],
        compile_cache_start={"dir": "/x", "entries": 0},
        cpu_count=2,
    )
    r["timings_seconds"]["total"] = 929.4
    r["carried"] = {"git_commit": "y" * 40}
    footer = verdict_table(r).splitlines()[-1]
    old = copy.deepcopy(r)
    for k in ("load_average_start", "load_average_end", "compile_cache_start"):
        del old["environment"][k]
    old_footer = verdict_table(old).splitlines()[-1]
    assert_true(
        "; 929 s wall on 2 cores at load 15 to 14.2, empty compile cache" in footer
        and "load not recorded, compile cache not recorded" in old_footer,
        got=f"{footer!r}; without the records: {old_footer!r}",
        should="the run's time, cores, load at start and end and cache state; 'not recorded' "
        "for a file written before",
        claim="report",
        call="readme_table.verdict_table",
    )


def test_a_run_records_the_load_at_its_end_and_warns(tmp_path, monkeypatch):
    """build_report with the measurements replaced by the committed results: the written
    results.json holds the load at the start and end; a load above the cores is one line
    of the progress at each."""
    if not (REPORTS / "results.json").is_file():
        pytest.skip("reports/results.json not generated")
    committed = json.loads((REPORTS / "results.json").read_text())
    out = tmp_path / "rep"

    def fake_build(tmp, quick, progress, adapters, env, workers=0, carried=None, repro=None):
        r = copy.deepcopy(committed)
        r["environment"] = env
        (tmp / "figures").mkdir(exist_ok=True)
        for rel in r["figures"]:
            shutil.copyfile(REPORTS / rel, tmp / rel)
        _environment.record_end(r["environment"], progress)  # as _build ends
        (tmp / "results.json").write_text(json.dumps(r))
        return r

    monkeypatch.setattr(campaign, "_build", fake_build)
    monkeypatch.setattr(_environment, "load_average", lambda: [15.0, 12.0, 9.0])
    messages: list[str] = []
    campaign.build_report(out, readme=None, progress=messages.append)
    env = json.loads((out / "results.json").read_text())["environment"]
    warnings = [m for m in messages if m.startswith("warning: load 15")]
    assert_true(
        env["load_average_start"] == [15.0, 12.0, 9.0]
        and env["load_average_end"] == [15.0, 12.0, 9.0]
        and len(warnings) == 2,
        got=f"start {env.get('load_average_start')}, end {env.get('load_average_end')}, "
        f"warnings {warnings}",
        should="both loads recorded, a warning at the start and at the end",
        claim="report",
        call="build_report (stub build) at load 15 on 2 cores",
    )


@pytest.mark.parametrize(
    "pair, cores, warns",
    [([15.2, 14.8], 2, True), ([0.4, 1.1], 2, False), ([1.5, 2.5], 2, True)],
)
def test_every_timing_has_its_load_beside_it(pair, cores, warns):
    """hcv-results/1.3: each stage's load at start and end is shown beside its time, and
    the speed-against-error section says the load its timings ran at, warning over the
    cores (issue 41: 'record the load beside every timing')."""
    from reference_impl.report import _render, check_results

    if not (REPORTS / "results.json").is_file():
        pytest.skip("reports/results.json not generated")
    r = json.loads((REPORTS / "results.json").read_text())
    r["environment"]["cpu_count"] = cores
    r["stage_loads"] = {k: list(pair) for k in r["timings_seconds"] if k != "total"}
    r["stage_loads"]["speed against error"] = list(pair)
    check_results(r, "test document with stage loads")
    md = _render.markdown(r)
    sentence = _render.wp_load_sentence(r)
    rows = [ln for ln in md.splitlines() if ln.startswith("| speed against error |")]
    flagged = f"over {cores} cores" in (rows[0] if rows else "")
    assert_true(
        sentence is not None
        and sentence in md
        and f"{pair[0]:g} to {pair[1]:g} on {cores} cores" in sentence
        and ("above the cores" in sentence) == warns
        and flagged == warns,
        got=f"sentence {sentence!r}, timing row {rows[:1]}",
        should=f"the load {pair} beside the timing, a warning {'' if warns else 'not '}given",
        claim="report",
        call="_render.markdown(results with stage_loads)",
    )


def test_a_stage_load_that_is_not_a_pair_of_loads_is_refused():
    from reference_impl.errors import HCVInputError
    from reference_impl.report import check_results

    if not (REPORTS / "results.json").is_file():
        pytest.skip("reports/results.json not generated")
    r = json.loads((REPORTS / "results.json").read_text())
    r["stage_loads"] = {"speed against error": [-1.0, "high"]}
    with pytest.raises(HCVInputError, match=r"stage_loads"):
        check_results(r, "test document")
