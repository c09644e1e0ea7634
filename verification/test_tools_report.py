"""Tool tests of ``hcv report``: arguments checked before writing, the swap, the README's
verdict block, the committed report's files.

Fast: the heavy sections are replaced by a stub that writes a tiny report
(`_fake_build`), so only the file handling is exercised. The adapter section and the
README's speed block: ``test_tools_report_blocks.py``. No claim marks: these are not
evidence for any claim.
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
        "bench/batch_peer_16cores.json",  # bench_batch_peer --threads 1,4,16 (16-core machine)
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
