"""`benchmarks.bench_batch_peer`: what its record holds (issue 38, goal 5), not how fast.

Its quick mode runs (on fewer impacts still, to stay cheap), and the record must have
every row, every field the README's batch line reads, a ratio that is the record's own
peer time over ours at each thread count, and a goal verdict that a run on a sample below
the issue's standard (1000 impacts, 50 against mpmath) never claims. Bad sizes are
refused in one line, exit status 2, before any work. The speed itself is measured by the
benchmark, never here.
"""

from __future__ import annotations

import contextlib
import io
import json

import pytest

from benchmarks import bench_batch_peer as bbp
from reference_impl.report.readme_table import speed_table
from verification.assertions import assert_true

# Fields of a row that the README's line and a reader of the record use.
_ROW_KEYS = {
    "row",
    "ours_rtol",
    "ours_rungs",
    "ours_full",
    "potential",
    "m",
    "damping",
    "impacts",
    "threads",
    "ours_wall_s",
    "ours_cpu_s",
    "ours_max_rel_error",
    "equal_error_target",
    "sample",
    "peers",
    "peer",
    "peer_rtol",
    "peer_at_equal_error",
    "peer_max_rel_error",
    "ratio",
    "ratio_cpu",
    "us_per_impact",
    "peer_us_per_impact",
    "goal",
    "goal_met",
    "goal_not_met_because",
    "ratio_short_of_goal",
    "load_average_1min",
    "load_average_1min_after",
}
_RECORD_KEYS = {
    "schema",
    "rows",
    "impacts",
    "blocks",
    "peers",
    "ours_rtols",
    "equal_error",
    "timing",
    "goal_ratio",
    "goal_met",
    "load_average_1min",
    "load_average_1min_after",
    "machine",
}


_ARGV = ["--quick", "--impacts", "200", "--sample", "8", "--mp-subset", "1"]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """(exit status, what it printed, its record) of one quick run on 200 impacts."""
    path = tmp_path_factory.mktemp("bench") / "batch_peer.json"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = bbp.main([*_ARGV, "--json", str(path)])
    return code, out.getvalue(), json.loads(path.read_text()) if path.is_file() else {}


def test_quick_record_has_every_row_and_its_ratio_from_the_measured_times(quick):
    code, printed, rec = quick
    argv = _ARGV
    assert_true(
        code == 0 and _RECORD_KEYS <= rec.keys() and rec["schema"] == bbp.SCHEMA,
        got=f"exit {code}, keys {sorted(rec)}",
        should=f"exit 0 and {sorted(_RECORD_KEYS)}, schema {bbp.SCHEMA}",
        claim="bench",
        call=f"bench_batch_peer {' '.join(argv)}",
    )
    assert_true(
        [r["row"] for r in rec["rows"]] == list(bbp.ROWS) and rec["blocks"] == 1,
        got=f"rows {[r['row'] for r in rec['rows']]}, blocks {rec['blocks']}",
        should=f"rows {list(bbp.ROWS)}, 1 block (--quick)",
        claim="bench",
        call="bench_batch_peer --quick",
    )
    for r in rec["rows"]:
        call = f"bench_batch_peer --quick, row {r['row']}"
        assert_true(
            _ROW_KEYS <= r.keys()
            and r["impacts"] == 200
            and r["peer"].keys() == r["ratio"].keys()
            and all(k in r["peers"] for k in r["peer"].values()),
            got=f"missing {sorted(_ROW_KEYS - r.keys())}, impacts {r.get('impacts')}",
            should="every row field, 200 impacts, the denominator among the row's peers",
            claim="bench",
            call=call,
        )
        for th, ratio in r["ratio"].items():
            peer = r["peers"][r["peer"][th]]
            # the fastest at equal error; none there: the most accurate
            ok = [p for p in r["peers"].values() if p["at_equal_error"]]
            best = min(p["max_rel_error"] for p in r["peers"].values())
            fastest = min(
                p["wall_s"][th]
                for p in (ok or [p for p in r["peers"].values() if p["max_rel_error"] == best])
            )
            want = peer["wall_s"][th] / r["ours_wall_s"][th]
            want_cpu = peer["cpu_s"][th] / r["ours_cpu_s"][th]
            assert_true(
                ratio == want
                and r["ratio_cpu"][th] == want_cpu
                and ratio > 0.0
                and peer["wall_s"][th] == fastest,
                got=f"ratio {ratio!r}, CPU {r['ratio_cpu'][th]!r}, peer {r['peer'][th]}",
                should=f"{want!r} and {want_cpu!r} (the record's peer time / ours), the "
                "fastest peer at equal error on that many threads",
                claim="bench",
                call=f"{call}, {th} thread(s)",
            )
            assert_true(
                f"{r['row']}, 200 impacts, {th} thread(s)" in printed
                and f"ratio {ratio:.1f}x" in printed,
                got=printed,
                should=f"a ratio line of {r['row']} on {th} thread(s) with {ratio:.1f}x",
                claim="bench",
                call=call,
            )
        # A sample of 8 with 1 against mpmath is a check that it runs: never the goal.
        assert_true(
            not r["goal_met"]
            and any("a check, not a measurement" in g for g in r["goal_not_met_because"]),
            got=f"goal_met {r['goal_met']}, because {r['goal_not_met_because']}",
            should="not met, the small sample named as the reason",
            claim="bench",
            call=call,
        )
        for name, peer in r["peers"].items():
            assert_true(
                peer["identical_to_serial_on_sample"] and peer["no_end"] == 0,
                got=f"identical {peer['identical_to_serial_on_sample']}, no end {peer['no_end']}",
                should="the serial peer's bits on the sample, every contact ended",
                claim="bench",
                call=f"{call}, {name}",
            )


def test_ours_rung_is_the_loosest_within_the_floor_and_full_accuracy_is_beside_it(quick):
    """Ours is timed at the loosest rung of `OURS_RTOLS` (walked from full accuracy to the
    first over the floor) whose error is within `EQUAL_ERROR_FLOOR`, that error is the one the
    peers are held to, and full accuracy is recorded beside it with its own ratio."""
    _code, printed, rec = quick
    for r in rec["rows"]:
        call = f"bench_batch_peer --quick, row {r['row']}"
        rungs = r["ours_rungs"]
        within = [g["max_rel_error"] <= bbp.EQUAL_ERROR_FLOOR for g in rungs]
        # every rung tried but the last is within the floor; the last is the first over it
        # unless the ladder ran out
        walked = all(within[:-1]) and (not within[-1] or len(rungs) == len(bbp.OURS_RTOLS))
        pick = [g["rtol"] for g, ok in zip(rungs, within, strict=True) if ok]
        want_rtol = pick[-1] if pick else None
        want_err = next(g["max_rel_error"] for g in rungs if g["rtol"] == want_rtol)
        assert_true(
            [g["rtol"] for g in rungs] == list(bbp.OURS_RTOLS[: len(rungs)])
            and walked
            and r["ours_rtol"] == want_rtol
            and r["ours_max_rel_error"] == want_err
            and r["equal_error_target"] >= want_err,
            got=f"rtol {r['ours_rtol']}, error {r['ours_max_rel_error']!r}, rungs {rungs}",
            should=f"rtol {want_rtol} (the loosest within {bbp.EQUAL_ERROR_FLOOR:g}), its "
            f"error {want_err!r}, a target at least that",
            claim="bench",
            call=call,
        )
        full = r["ours_full"]
        for th, ratio in full["ratio"].items():
            peer = r["peers"][r["peer"][th]]
            want = peer["wall_s"][th] / full["wall_s"][th]
            same = r["ours_rtol"] is not None or full["wall_s"][th] == r["ours_wall_s"][th]
            assert_true(
                ratio == want and same and full["max_rel_error"] == rungs[0]["max_rel_error"],
                got=f"full-accuracy ratio {ratio!r} on {th} thread(s), error "
                f"{full['max_rel_error']!r}",
                should=f"{want!r} (the same peer's time / ours at full accuracy), its error "
                f"{rungs[0]['max_rel_error']!r} (the first rung), ours' own time where the "
                "rung is full accuracy",
                claim="bench",
                call=call,
            )
        assert_true(
            f"ours at rtol {r['ours_rtol']}" in printed and "at full accuracy" in printed,
            got=printed,
            should=f"a line naming ours' rtol {r['ours_rtol']} and its full-accuracy time",
            claim="bench",
            call=call,
        )


def test_thread_counts_are_parsed_and_a_bad_one_refused():
    top = bbp.numba.config.NUMBA_NUM_THREADS
    got = bbp._parse_threads("2,1,1")
    assert_true(
        got == (1, 2) or top < 2,
        got=f"{got}",
        should="(1, 2): sorted, distinct",
        claim="bench",
        call="_parse_threads('2,1,1')",
    )


def test_rows_are_parsed_in_the_table_order():
    got = bbp._parse_rows("hunt-crossley, linear")
    assert_true(
        got == ("linear", "hunt-crossley"),
        got=f"{got}",
        should="('linear', 'hunt-crossley'): ROWS' order, spaces dropped",
        claim="bench",
        call="_parse_rows('hunt-crossley, linear')",
    )


def test_readme_speed_block_states_each_row_its_ratio_and_why_the_goal_is_not_met(quick):
    """The README's speed block, given the record (`readme_table.speed_table`): a line per
    row with ours, the peer and the ratio on each thread count as the record has them, the
    reasons the goal is not met, and that a one-block run is a check, not a measurement."""
    _code, _printed, rec = quick
    bench = {"families": [], "laws": [], "batch": [], "machine": {}}
    text = speed_table(bench, None, rec)
    for r in rec["rows"]:
        ratios = ", ".join(
            f"{x:.1f}× on {th} thread{'s' if th != '1' else ''}" for th, x in r["ratio"].items()
        )
        for want in (
            f"- `solve_impacts`, {r['row']} (200 impacts): ours",
            f"; ratio {ratios} (goal ≥ 10×: **not met**: ",
            "a check, not a measurement",
        ):
            assert_true(
                want in text,
                got=text,
                should=f"a line containing {want!r}",
                claim="bench",
                call=f"speed_table(batch_peer={r['row']})",
            )
    assert_true(
        "benchmarks.bench_batch_peer --json reports/bench/batch_peer.json" in text
        and "a check that it runs, not a measurement" in text,
        got=text,
        should="the command that measures it, and a one-block run called a check",
        claim="bench",
        call="speed_table(batch_peer)",
    )


def test_bad_sizes_are_refused_in_one_line(capsys):
    for argv, word in (
        (["--impacts", "0"], "--impacts 0"),
        (["--quick", "--blocks", "-1"], "--blocks -1"),
        (["--quick", "--sample", "5", "--mp-subset", "6"], "--mp-subset 6"),
        (["--quick", "--threads", "1,0"], "0 outside"),
        (["--quick", "--threads", "1,x"], "'x' is not a count"),
        (["--quick", "--threads", "100000"], "100000 outside"),
        (["--quick", "--rows", "linear,viscous"], "'viscous' is not one of"),
    ):
        code = bbp.main(argv)
        err = capsys.readouterr().err.strip()
        assert_true(
            code == 2 and word in err and len(err.splitlines()) == 1,
            got=f"exit {code}, stderr {err!r}",
            should=f"exit 2 and one line naming {word!r}",
            claim="bench",
            call=f"bench_batch_peer {' '.join(argv)}",
        )
