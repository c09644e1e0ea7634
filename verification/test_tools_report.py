"""Tool tests of ``hcv report``: arguments checked before writing, the swap, the README block.

Fast: the heavy sections are replaced by a stub that writes a tiny report
(`_fake_build`), so only the file handling is exercised; the adapter section is
rendered from two hand-made bench documents shaped like LAMMPS' and Kratos'. No
claim marks: these are not evidence for any claim.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import reference_impl.campaign as report
from reference_impl import cli
from reference_impl.campaign import _environment, build_report
from reference_impl.errors import HCVInputError
from reference_impl.report._files import MANIFEST
from reference_impl.report.readme_table import END, START, readme_block, rewrite_readme
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
CALL = "build_report"


def _fake_build(out, quick, progress, adapters, env, workers=0, carried=None, repro=None):
    """Stand-in for the measurements: writes the report's files into ``out``."""
    (out / "figures").mkdir()
    (out / "figures" / "fig1.png").write_bytes(b"new")
    results = {
        "claims": [
            {
                "id": "table1",
                "section": "10",
                "verdict": "refuted",
                "evidence": "new run",
                "headline": "new run",
            }
        ],
        "environment": env,
        "mode": "quick",
        "generated_utc": "now",
    }
    for name in ("results.json", "index.md", "index.html"):
        (out / name).write_text(json.dumps(results))
    return results


def _old_report(d: Path) -> dict[str, bytes]:
    (d / "figures").mkdir(parents=True)
    (d / "figures" / "old.png").write_bytes(b"old")
    for name in ("results.json", "index.md", "index.html"):
        (d / name).write_text("old " + name)
    (d / "NOTES.txt").write_text("not the report's")
    (d / "bench").mkdir()
    (d / "bench" / "exact.json").write_text("{}")  # written by nox -s bench, not the report
    # What the previous run wrote, as its manifest lists it (NOTES.txt and bench/ are not).
    files = ["figures/old.png", "index.html", "index.md", "results.json"]
    (d / MANIFEST).write_text(json.dumps({"files": files}))
    return _snapshot(d)


def _snapshot(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def _siblings(d: Path) -> list[str]:
    return sorted(p.name for p in d.parent.iterdir() if p.name != d.name)


@pytest.fixture
def fake(monkeypatch):
    monkeypatch.setattr(report, "_build", _fake_build)
    monkeypatch.setattr(
        _environment, "environment", lambda seeds: {"git_commit": "x", "git_dirty": False}
    )


@pytest.mark.parametrize("adapter", ["nosuchcode", "bad[spec", "no.such.module:Cls", "cmd:"])
def test_bad_adapter_refused_before_anything_is_written(tmp_path, monkeypatch, adapter):
    called = []
    monkeypatch.setattr(report, "_build", lambda *a: called.append(a))
    out = tmp_path / "rep"
    with pytest.raises(HCVInputError):
        build_report(out, quick=True, adapters=[adapter])
    assert_true(
        not out.exists() and not called and list(tmp_path.iterdir()) == [],
        got=f"out exists {out.exists()}, build ran {bool(called)}, {list(tmp_path.iterdir())}",
        should="nothing run, nothing written",
        claim="report",
        call=f"{CALL}(adapters=[{adapter!r}])",
    )


def test_cli_report_with_adapter_typo_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "rep"
    status = cli.main(["report", "--quick", "--out", str(out), "--adapter", "refrence"])
    err = capsys.readouterr().err
    assert_true(
        status == 2 and "refrence" in err and not out.exists(),
        got=f"status {status}, stderr {err!r}, out exists {out.exists()}",
        should="status 2, one line naming 'refrence', nothing written",
        claim="report",
        call="hcv report --adapter refrence",
    )


def test_out_dir_that_is_a_file_is_refused(tmp_path, fake):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(HCVInputError, match="not a directory"):
        build_report(f, quick=True)
    assert f.read_text() == "x"


def test_complete_run_swaps_in_and_keeps_foreign_files(tmp_path, fake):
    out = tmp_path / "rep"
    _old_report(out)
    build_report(out, quick=True)
    snap = _snapshot(out)
    assert_true(
        set(snap)
        == {
            MANIFEST,
            "NOTES.txt",
            "bench/exact.json",
            "figures/fig1.png",
            "index.html",
            "index.md",
            "results.json",
        }
        and snap["figures/fig1.png"] == b"new"
        and _siblings(out) == [],
        got=f"{sorted(snap)}, siblings {_siblings(out)}",
        should="the new report, NOTES.txt and bench/ kept, old figures gone, no temp dirs",
        claim="report",
        call=CALL,
    )


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_interrupted_run_leaves_the_old_report_intact(tmp_path, monkeypatch, fake, exc):
    out = tmp_path / "rep"
    before = _old_report(out)

    def half_then_fail(out_tmp, *args):
        (out_tmp / "results.json").write_text("half")
        raise exc

    monkeypatch.setattr(report, "_build", half_then_fail)
    with pytest.raises(type(exc)):
        build_report(out, quick=True)
    assert_true(
        _snapshot(out) == before and _siblings(out) == [],
        got=f"{sorted(_snapshot(out))}, siblings {_siblings(out)}",
        should="old report unchanged, temporary directory removed",
        claim="report",
        call=f"{CALL} interrupted by {type(exc).__name__}",
    )


def test_provenance_is_taken_before_anything_is_written(tmp_path, monkeypatch, fake):
    out = tmp_path / "rep"
    seen = []
    monkeypatch.setattr(
        _environment,
        "environment",
        lambda seeds: (
            seen.append(sorted(p.name for p in tmp_path.iterdir()))
            or {"git_commit": "x", "git_dirty": False}
        ),
    )
    build_report(out, quick=True)
    assert_true(
        seen == [[]],
        got=f"directory at provenance time: {seen}",
        should="empty (provenance first)",
        claim="report",
        call=CALL,
    )


def test_readme_block_is_rewritten_alone():
    text = f"intro\n{START}\nold table\n{END}\noutro\n"
    results = {
        "claims": [
            {
                "id": "fig1",
                "section": "10",
                "verdict": "refuted",
                "evidence": "e",
                "headline": "drift | 5e-13",
            }
        ]
    }
    new = rewrite_readme(results, text)
    assert new.startswith("intro\n" + START) and new.endswith(END + "\noutro\n")
    assert "| fig1 | 10 | **refuted** | drift \\| 5e-13 |" in readme_block(new)
    with pytest.raises(HCVInputError):
        readme_block("no markers")


# A ledger row of index.md: | id | section | ✘ refuted | ... (bold when flagged).
LEDGER_ROW = re.compile(
    r"^\| ([a-z0-9-]+) \| [^|]* \| (?:\*\*)?[✔✘?] "
    r"(verified|refuted|inconclusive)(?:\*\*)? \|",
    re.M,
)


def _ledger_verdicts(md: str) -> dict[str, str]:
    return {m.group(1): m.group(2) for m in LEDGER_ROW.finditer(md)}


def test_readme_index_and_results_agree():
    """The committed README block, reports/index.md and reports/results.json are one run."""
    results = json.loads((ROOT / "reports" / "results.json").read_text())
    readme = (ROOT / "README.md").read_text()
    assert_true(
        readme_block(rewrite_readme(results, readme)) == readme_block(readme),
        got="README verdict block differs from reports/results.json",
        should="identical (run python -m reference_impl.report.readme_table)",
        claim="report",
        call="readme_table",
    )
    want = {c["id"]: c["verdict"] for c in results["claims"]}
    got = _ledger_verdicts((ROOT / "reports" / "index.md").read_text())
    assert_true(
        got == want,
        got=f"index.md ledger {got}",
        should=f"results.json {want}",
        claim="report",
        call="reports/index.md",
    )


def test_report_run_rewrites_the_readme_block_from_its_results(tmp_path, fake):
    readme = tmp_path / "README.md"
    readme.write_text(f"intro\n{START}\nhand-written\n{END}\noutro\n")
    results = build_report(tmp_path / "rep", quick=True, readme=readme)
    text = readme.read_text()
    assert_true(
        readme_block(text) == readme_block(rewrite_readme(results, text))
        and "hand-written" not in text
        and text.startswith("intro\n")
        and text.endswith(f"{END}\noutro\n"),
        got=text,
        should="the block regenerated from this run, the rest untouched",
        claim="report",
        call=f"{CALL}(readme=...)",
    )


def test_readme_without_markers_is_refused_before_running(tmp_path, monkeypatch):
    called = []
    monkeypatch.setattr(report, "_build", lambda *a: called.append(a))
    readme = tmp_path / "README.md"
    readme.write_text("no block\n")
    with pytest.raises(HCVInputError, match="verdicts:start"):
        build_report(tmp_path / "rep", quick=True, readme=readme)
    assert not called and not (tmp_path / "rep").exists()


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


def test_committed_report_files_are_in_its_manifest():
    """The main job refuses to overwrite report-named files its manifest does not list, so a
    committed report file missing from reports/.hcv-report-manifest.json breaks ``hcv report``
    on a fresh clone. Files written by other commands are named here with their writer."""
    import json
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    tracked = subprocess.run(
        ["git", "ls-files", "reports"], cwd=root, capture_output=True, text=True
    ).stdout.split()
    if not tracked:
        pytest.skip("not a git checkout")
    owned = set(json.loads((root / "reports" / ".hcv-report-manifest.json").read_text())["files"])
    others = {
        ".hcv-report-manifest.json",  # the manifest itself
        "bench/exact.json",  # python -m benchmarks.bench_exact
        "bench/general_taylor.json",  # python -m benchmarks.bench_general_taylor
        "bench/sweep.json",  # python -m benchmarks.bench_sweep
        "bench/sweep_assembly.json",  # python -m benchmarks.bench_sweep_assembly
        "bench/assembly.json",  # python -m benchmarks.bench_assembly --json
        "bench/device_scaling.json",  # benchmarks/device_scaling.py (16-core machine)
        "bench/verlet.json",  # python -m benchmarks.bench_verlet
        "bench/startup.json",  # python -m benchmarks.bench_startup
        "bench/commands.json",  # python -m benchmarks.bench_startup --docs (docs_blocks)
        "bench/codes.json",  # python -m benchmarks.bench_codes (docs_blocks)
        "bench/workprecision.json",  # python -m benchmarks.bench_workprecision --json
        "bench/workprecision.png",  # python -m benchmarks.bench_workprecision --png
        "bench/batch_peer.json",  # python -m benchmarks.bench_batch_peer --json
        "bench/mujoco_calibrate.json",  # python -m reference_impl.campaign.mujoco_table
        "assemblies_1e6.json",  # python -m reference_impl.campaign.assembly_long
    }
    stray = [
        f
        for f in (t[len("reports/") :] for t in tracked)
        if f not in owned and f not in others and not f.startswith("repro/")
    ]
    assert not stray, f"got committed report files {stray} outside the manifest, should be none"


def test_committed_report_was_made_from_a_clean_commit():
    """Issue 17 point 3: the committed report names the commit it came from, with no
    uncommitted changes (``nox -s committed-report`` refuses a dirty tree)."""
    import json
    from pathlib import Path

    env = json.loads(
        (Path(__file__).resolve().parents[1] / "reports" / "results.json").read_text()
    )["environment"]
    assert_true(
        env.get("git_dirty") is False and len(str(env.get("git_commit", ""))) == 40,
        got=f"git_commit {env.get('git_commit')!r}, git_dirty {env.get('git_dirty')!r}",
        should="a 40-hex commit and git_dirty False",
        claim="report",
        call="reports/results.json environment",
    )
