"""Tool tests of ``hcv report``'s rendered blocks: the adapter section and the README's
speed block.

Fast: the adapter section is rendered from two hand-made bench documents shaped like
LAMMPS' and Kratos' (no code is run); the speed block from the committed benchmark JSON.
The run itself (arguments, the swap, the verdict block): ``test_tools_report.py``. No claim
marks: these are not evidence for any claim.
"""

from __future__ import annotations

import json
from pathlib import Path

from reference_impl.report.readme_table import batch_goal, readme_block
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]


# ----------------------------------------------------------------------------------
# The adapter section (hcv report --adapter lammps --adapter kratos), rendered from
# two hcv-bench/1 documents shaped like the real ones (no code is run).
# ----------------------------------------------------------------------------------
def _metric(variant, scene, metric, status, measured, expected, error, tolerance, at_v0=0.1):
    return {
        "variant": variant,
        "scene": scene,
        "metric": metric,
        "status": status,
        "value": error,
        "reference": expected,
        "measured": measured,
        "expected": expected,
        "error": error,
        "at_v0": at_v0,
        "tolerance": tolerance,
        "explanation": {"fail": f"{metric} off by {error}", "skip": "scene not supported"}.get(
            status, ""
        ),
    }


LMP = "lammps[velocity,wall]"
KRA = "kratos[hertz,Symplectic_Euler]"
E_ASKED = 0.7292476142876709  # the asked restitution of scene hertz-damped
DOCS = [
    {
        "adapter": "lammps",
        "summary": {"pass": 1, "fail": 1, "skip": 2},
        "metrics": [
            _metric(
                LMP,
                "hertz-damped",
                "restitution_asked",
                "fail",
                0.5992461627,
                E_ASKED,
                0.178,
                "rtol 0.02",
            ),
            _metric(
                LMP,
                "hertz-damped",
                "restitution_exact",
                "pass",
                0.5992461627,
                0.59833,
                0.00153,
                "rtol 0.01",
            ),
            _metric(LMP, "hertz-walls", "energy_drift", "skip", None, None, None, ""),
            _metric(LMP, "two-spheres", "restitution_asked", "skip", None, None, None, ""),
        ],
    },
    {
        "adapter": "kratos",
        "summary": {"pass": 2, "fail": 0, "skip": 0},
        "metrics": [
            _metric(
                KRA,
                "hertz-damped",
                "restitution_asked",
                "pass",
                0.7290012345,
                E_ASKED,
                0.000338,
                "rtol 0.02",
            ),
            _metric(
                KRA, "hertz-walls", "energy_drift", "pass", 1e-9, 0.0, 1e-9, "atol 1e-06", None
            ),
        ],
    },
]


def _adapter_section(fmt: str) -> str:
    from reference_impl.report import _render

    blocks = _render._adapters({"adapters": DOCS, "figures": []})
    out: list[str] = []
    if fmt == "md":
        _render._md(blocks, out)
    else:
        _render._html(blocks, Path("/nonexistent"), out)
    return "\n".join(out)


def _md_table_after(md: str, heading: str) -> list[list[str]]:
    """Cells of the first markdown table after ``heading`` (bold marks removed)."""
    lines = md[md.index(heading) :].splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("| "))
    rows = []
    for ln in lines[start:]:
        if not ln.startswith("|"):
            break
        if not ln.startswith("|---"):
            rows.append([c.strip().strip("*") for c in ln.strip("|").split(" | ")])
    return rows


def test_adapter_section_shows_codes_side_by_side():
    """The side-by-side table comes first, a column per code's variant, the measured
    restitution (6 digits) and its verdict in each cell; then each code's own table."""
    md = _adapter_section("md")
    call = "_render._adapters(two bench documents)"
    sbs = _md_table_after(md, "Side by side")
    header = sbs[0]
    assert_true(
        header == ["scene", "metric", "reference", LMP, KRA],
        got=str(header),
        should="scene, metric, reference and one column per variant",
        claim="report",
        call=call,
    )
    by_key = {(r[0], r[1]): r for r in sbs[1:]}
    row = by_key[("hertz-damped", "restitution_asked")]
    assert_true(
        row[2:] == ["0.729248", "0.599246 FAIL", "0.729001 pass"],
        got=str(row),
        should="asked 0.729248, lammps measured 0.599246 FAIL, kratos measured 0.729001 pass",
        claim="report",
        call=call,
    )
    drift = by_key[("hertz-walls", "energy_drift")]
    assert_true(
        drift[3] == "-" and drift[4].endswith("pass"),
        got=str(drift),
        should="'-' for lammps (skipped), a pass for kratos",
        claim="report",
        call=call,
    )
    assert_true(
        "no variant ran (every metric skipped): two-spheres (first reason given: scene not supported)"
        in md
        and "hertz-walls (" not in md,
        got=md,
        should="two-spheres (skipped by every variant) named, hertz-walls (run by kratos) not",
        claim="report",
        call=call,
    )
    assert_true(
        md.index("Side by side") < md.index("### lammps:") < md.index("### kratos:"),
        got="section order wrong",
        should="side by side first, then lammps, then kratos",
        claim="report",
        call=call,
    )
    own = _md_table_after(md, "### lammps:")
    cols = own[0]
    rows = {r[2]: dict(zip(cols, r, strict=True)) for r in own[1:]}
    got = rows.get("restitution_asked", {})
    assert_true(
        cols[3:8] == ["measured", "expected", "error", "tolerance", "at v0 (m/s)"]
        and got.get("measured") == "0.599246"
        and got.get("expected") == "0.729248"
        and got.get("error") == "0.178"
        and got.get("tolerance") == "rtol 0.02"
        and got.get("result") == "FAIL"
        and "energy_drift" not in rows,
        got=str(own),
        should="measured / expected / error / tolerance columns, skips left out",
        claim="report",
        call=call,
    )


def test_adapter_section_html_has_side_by_side_table():
    """The HTML page carries the same side-by-side table, failures marked."""
    page = _adapter_section("html")
    call = "_render._adapters -> _html"
    head = f"<th>{LMP}</th><th>{KRA}</th>"
    assert_true(
        head in page
        and '<td class="bad">0.599246 FAIL</td>' in page
        and '<td class="good">0.729001 pass</td>' in page
        and page.index("Side by side") < page.index("lammps: 1 pass"),
        got=page[:2000],
        should="a side-by-side table with a column per variant, before the per-code tables",
        claim="report",
        call=call,
    )


def test_readme_speed_block_is_the_committed_benchmark():
    """The README's speed figures are rendered from reports/bench/exact.json, never typed."""
    from reference_impl.report.readme_table import SPEED_END, SPEED_START, speed_table

    bench_json = ROOT / "reports" / "bench" / "exact.json"
    readme = (ROOT / "README.md").read_text()
    assert_true(
        bench_json.is_file(),
        got=f"no {bench_json.relative_to(ROOT)}",
        should="the benchmark JSON behind the README's speed block (nox -s bench)",
        claim="report",
        call="readme_table",
    )
    wp_json = ROOT / "reports" / "bench" / "workprecision.json"
    wp = json.loads(wp_json.read_text()) if wp_json.is_file() else None
    bp_json = ROOT / "reports" / "bench" / "batch_peer.json"
    bp = json.loads(bp_json.read_text()) if bp_json.is_file() else None
    want = speed_table(json.loads(bench_json.read_text()), wp, bp)
    assert_true(
        readme_block(readme, SPEED_START, SPEED_END) == want,
        got="README speed block differs from reports/bench/exact.json (and workprecision.json, "
        "batch_peer.json)",
        should="identical (run python -m reference_impl.report.readme_table)",
        claim="report",
        call="readme_table",
    )


def test_speed_block_names_the_strongest_peer_and_both_calls():
    """Issue 38, goal 6: each row's one-shot and prepared figure, the fastest peer of the
    row named (not only the plain DOP853), and the work-precision figure linked with what
    its record says of the run."""
    from reference_impl.report.readme_table import speed_table

    bench = json.loads((ROOT / "reports" / "bench" / "exact.json").read_text())
    fam = dict(
        bench["families"][0],
        peer_name="sundman",
        peers={"sundman": {"label": "numba DOP853 on the Sundman-regularised equations"}},
    )
    wp = {"panels": [{"impacts": 200}], "blocks": 1, "load_average_1min": 4.2, "machine": {}}
    text = speed_table({**bench, "families": [fam], "laws": []}, wp)
    for want in (
        f"| Sundman DOP853: {fam['peer_us']:.0f} µs |",
        f"a one-shot `solve_impact` takes {fam['ours_us']:.1f} µs",
        f"a `prepare(pot, m)` call {fam['prepared_us']:.1f} µs (the peer "
        f"{fam['prepared_ratio']:.1f}× as long)",
        "the fastest at equal error of Sundman DOP853 (numba DOP853 on the Sundman",
        "](reports/bench/workprecision.png)",
        "a check that it runs, not a measurement",
    ):
        assert_true(
            want in text,
            got=text,
            should=f"a line containing {want!r}",
            claim="report",
            call="speed_table",
        )


def test_speed_block_says_by_how_much_a_goal_is_not_met():
    """Issue 27's 'done when': a row whose goal is not met says by how much and why (the
    compiled call alone; the serial part a batch speedup implies), from the JSON's figures."""
    from reference_impl.report.readme_table import speed_table

    bench = json.loads((ROOT / "reports" / "bench" / "exact.json").read_text())
    # The peer reaching equal error is set, not read from the record (the record of a
    # quiet run may have a row whose peer never gets there: a third reason, named apart).
    fam = dict(
        bench["families"][0],
        goal_met=False,
        time_over_goal=1.754,
        kernel_us=9.04,
        peer_at_equal_error=True,
    )
    fam["ratio_short_of_goal"] = 0.5  # the ratio part of the goal is met: not named
    batch = dict(bench["batch"][0], goal_met=False, implied_serial_fraction=0.1561)
    # Not met on its error alone, and on bit-identity alone: those are the reasons given.
    err = dict(fam, time_over_goal=0.5, kernel_us=None, ours_max_rel_error=3e-14)
    odd = dict(batch, bit_identical_to_1_thread=False, implied_serial_fraction=-0.01)
    text = speed_table({**bench, "families": [fam, err], "laws": [], "batch": [batch, odd]})
    for want in (
        "**not met**: 1.75× the 8 µs, its compiled call alone 9.0 µs |",
        "**not met**: its error 3.0e-14 > 1e-14 |",
        "**not met**: Amdahl's serial part implied: 16 % of the one-thread time)",
        "**not met**: results differ from one thread's)",
    ):
        assert_true(
            want in text,
            got=text,
            should=f"a line containing {want!r}",
            claim="report",
            call="speed_table",
        )


def test_a_batch_row_no_peer_reaches_is_not_judged_and_a_short_one_not_met():
    """Goal 5's verdict per batch row (`readme_table.batch_goal`): "not judged" only where
    the single reason is that no peer reaches equal error; a ratio short of the goal, alone
    or beside it, is "not met"; no reason is "met"."""
    no_peer = "no peer reaches equal error (each compared at its most accurate rung)"
    short = "ratio 8.90x < 10x on 1 thread(s)"
    cases = (
        ({"goal_met": True, "peer_at_equal_error": True, "goal_not_met_because": []}, "met"),
        (
            {"goal_met": False, "peer_at_equal_error": False, "goal_not_met_because": [no_peer]},
            f"not judged: {no_peer}",
        ),
        (
            {"goal_met": False, "peer_at_equal_error": True, "goal_not_met_because": [short]},
            f"**not met**: {short}",
        ),
        (
            {
                "goal_met": False,
                "peer_at_equal_error": False,
                "goal_not_met_because": [short, no_peer],
            },
            f"**not met**: {short}; {no_peer}",
        ),
    )
    for row, want in cases:
        got = batch_goal(row)
        assert_true(
            got == want,
            got=repr(got),
            should=repr(want),
            claim="bench",
            call=f"batch_goal({row['goal_not_met_because']})",
        )
