"""``hcv report --from results.json``: the report renders, the studies compute (issue 30).

The committed ``reports/results.json`` carries ``"schema": "hcv-results/1"`` and every
field its documentation (`reference_impl.report._schema`) lists; re-rendering it runs
nothing and reproduces the committed ``index.md`` and ``erratum.md`` byte for byte; a
malformed file is refused in one line, before anything is written. A run without codes
carries the previous report's code sections, marked (issue 26 item 4). Fast: nothing is
measured (the build is replaced by a stub where one is needed).
"""

from __future__ import annotations

import copy
import json
import re
import shutil
from pathlib import Path

import pytest

import reference_impl.campaign as campaign
from reference_impl.campaign import _environment
from reference_impl.cli import main
from reference_impl.errors import HCVInputError
from reference_impl.report import _render, _schema, read_results, render_from
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
REPORTS = ROOT / "reports"
CALL = "render_from(reports/results.json)"


@pytest.fixture(scope="module")
def committed():
    if not (REPORTS / "results.json").is_file():
        pytest.skip("reports/results.json not generated")
    return json.loads((REPORTS / "results.json").read_text())


def test_committed_results_carry_the_schema_and_every_documented_field(committed):
    assert_true(
        committed.get("schema") == _schema.SCHEMA and read_results(REPORTS / "results.json"),
        got=f"schema {committed.get('schema')!r}",
        should=repr(_schema.SCHEMA),
        claim="report",
        call="reports/results.json",
    )
    doc = _schema.__doc__
    undocumented = [k for k in _schema.FIELDS if f"``{k}``" not in doc]
    unlisted = sorted(set(committed) - set(_schema.FIELDS))
    assert_true(
        not undocumented and not unlisted,
        got=f"fields without documentation {undocumented}, written but not in the schema "
        f"{unlisted}",
        should="every field written, listed and documented",
        claim="report",
        call="report._schema",
    )


# The erratum's link to a claim's script, written only where the scripts lie (`scripts_href`).
_SCRIPT_LINK = re.compile(r", \[\w+\.py\]\(repro/\w+\.py\)|, <a href=\"repro/\w+\.py\">\w+\.py</a>")


def test_render_from_reproduces_the_committed_pages(committed, tmp_path):
    """Into a directory holding the referee's scripts (as reports/ does): byte for byte;
    anywhere else: the same but for the links to those scripts, which are not there."""
    out = tmp_path / "x"
    shutil.copytree(REPORTS / "repro", out / "repro")
    render_from(REPORTS / "results.json", out, force=True)  # beside repro/, not its own
    bare = tmp_path / "bare"
    render_from(REPORTS / "results.json", bare)
    for name in ("index.md", "index.html", "erratum.md", "results.json"):
        want = (REPORTS / name).read_text()
        unlinked = _SCRIPT_LINK.sub("", want)
        assert_true(
            (out / name).read_text() == want and (bare / name).read_text() == unlinked,
            got=f"{name} differs from the committed one",
            should="identical (the pages are rendered from results.json alone; without "
            "repro/ beside them, without the links to it)",
            claim="report",
            call=CALL,
        )
    for rel in committed["figures"]:
        assert_true(
            (out / rel).read_bytes() == (REPORTS / rel).read_bytes(),
            got=f"{rel} missing or different",
            should="copied",
            claim="report",
            call=CALL,
        )
    html = (out / "index.html").read_text()
    text = re.sub(r"<[^>]+>", "", html)
    raw = re.findall(r".{30}\]\(.{20}", text)[:3]
    assert_true(
        "](" not in text and '<a href="repro/' in html,
        got=f"raw Markdown links: {raw}",
        should="links rendered as <a href> in index.html",
        claim="report",
        call=CALL,
    )


def test_cli_report_from_writes_the_pages(committed, tmp_path, capsys):
    code = main(["report", "--from", str(REPORTS / "results.json"), "--out", str(tmp_path / "y")])
    assert_true(
        code == 0 and (tmp_path / "y" / "index.html").is_file(),
        got=f"exit {code}, stderr {capsys.readouterr().err!r}",
        should="exit 0 and the pages written",
        claim="report",
        call="hcv report --from reports/results.json --out DIR",
    )


def _bad(committed, case):
    r = copy.deepcopy(committed)
    if case == "no schema":
        del r["schema"]
    elif case == "other schema":
        r["schema"] = "hcv-results/99"
    elif case == "other major":
        r["schema"] = "hcv-results/2.0"
    elif case == "newer minor":
        r["schema"] = "hcv-results/1.99"
    elif case == "missing field":
        del r["dt_crit_map"]
    elif case == "bad verdict":
        r["claims"][0]["verdict"] = "maybe"
    elif case == "figure outside":
        r["figures"].append("../../etc/passwd")
    return r


@pytest.mark.parametrize(
    "case, needle",
    [
        ("no schema", "has no schema field"),
        ("other schema", "hcv-results/99"),
        ("other major", "hcv-results/2.0"),
        ("newer minor", "hcv-results/1.99"),
        ("missing field", "'dt_crit_map' is missing"),
        ("bad verdict", "'maybe'"),
        ("figure outside", "../../etc/passwd"),
        ("not json", "not JSON"),
    ],
)
def test_a_malformed_results_file_is_one_line_exit_2_and_nothing_written(
    committed, tmp_path, capsys, case, needle
):
    src = tmp_path / "in" / "results.json"
    src.parent.mkdir()
    shutil.copytree(REPORTS / "figures", src.parent / "figures")
    src.write_text("{" if case == "not json" else json.dumps(_bad(committed, case)))
    out = tmp_path / "out"
    code = main(["report", "--from", str(src), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert_true(
        code == 2 and len(err) == 1 and needle in err[0] and not out.exists(),
        got=f"exit {code}, stderr {err}, out written: {out.exists()}",
        should=f"exit 2, one line naming {needle!r}, nothing written",
        claim="report",
        call=f"hcv report --from ({case})",
    )


def test_a_missing_figure_is_refused_before_writing(committed, tmp_path):
    src = tmp_path / "in" / "results.json"
    src.parent.mkdir()
    shutil.copyfile(REPORTS / "results.json", src)
    with pytest.raises(HCVInputError, match="figures/fig1.png"):
        render_from(src, tmp_path / "out")
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------
# A run without codes carries the previous report's code sections (issue 26 item 4)
# ----------------------------------------------------------------------------
def _previous_report(d: Path, committed) -> None:
    """A copy of the committed report (its results, figures and manifest)."""
    d.mkdir()
    for name in (
        "results.json",
        ".hcv-report-manifest.json",
        "index.md",
        "index.html",
        "erratum.md",
    ):
        shutil.copyfile(REPORTS / name, d / name)
    shutil.copytree(REPORTS / "figures", d / "figures")
    shutil.copytree(REPORTS / "bench", d / "bench")


def test_a_run_without_codes_carries_their_sections_marked(committed, tmp_path, monkeypatch):
    if not committed["adapters"]:
        pytest.skip("the committed report has no contact codes")
    out = tmp_path / "rep"
    _previous_report(out, committed)
    seen = {}

    def fake_build(tmp, quick, progress, adapters, env, workers=0, carried=None, repro=None):
        """The measurements replaced: the committed results with the carried fields."""
        seen["carried"] = carried
        r = copy.deepcopy(committed)
        r["figures"] = [f for f in r["figures"] if f not in carried["figures"]]
        for rel in r["figures"]:
            shutil.copyfile(REPORTS / rel, tmp / rel)
        r.update({k: carried[k] for k in (*campaign.CARRIED, "carried")})
        r["figures"] += carried["figures"]
        (tmp / "results.json").write_text(json.dumps(r))
        (tmp / "index.md").write_text(_render.markdown(r))
        return r

    monkeypatch.setattr(campaign, "_build", fake_build)
    monkeypatch.setattr(
        _environment, "environment", lambda seeds: {"git_commit": "y" * 40, "git_dirty": False}
    )
    messages: list[str] = []
    campaign.build_report(out, readme=None, progress=messages.append)
    c = seen["carried"]
    # The commit the code sections were measured at: the committed run's own, or, where
    # that run carried them itself (the README's main job runs no code), the one it names.
    commit = (committed["carried"] or committed["environment"])["git_commit"]
    md = (out / "index.md").read_text()
    manifest = json.loads((out / ".hcv-report-manifest.json").read_text())["files"]
    ok = (
        c is not None
        and c["adapters"] == committed["adapters"]
        # the codes' step advice on chains (issue 39 section 4) goes with them
        and c["code_advice"] == (committed.get("assemblies") or {}).get("code_advice")
        and "assemblies.code_advice" in c["carried"]["sections"]
        and c["carried"]["git_commit"] == commit
        and "Contact codes benchmarked" in md
        and f"commit {commit[:12]}" in md
        and all(f in manifest and (out / f).is_file() for f in c["figures"])
        and any("carried" in m for m in messages)
        # each section's notice says it once (it read "Not run by this report (no
        # --adapter given: the codes were not run by this report)")
        and max(ln.lower().count("not run by this report") for ln in md.splitlines()) == 1
    )
    assert_true(
        ok,
        got=f"carried {None if c is None else c['carried']}, section in index.md: "
        f"{'Contact codes benchmarked' in md}, messages {messages[:2]}",
        should=f"the code sections carried, marked with commit {commit[:12]}, figures kept",
        claim="report",
        call="build_report(out) without adapters",
    )


def test_asking_for_a_code_carries_nothing(committed, tmp_path):
    out = tmp_path / "rep"
    _previous_report(out, committed)
    data, note = campaign._carry(out, ["reference"])
    assert data is None and note == "", f"got {note!r}, should carry nothing when a code is asked"


@pytest.mark.parametrize("into_checkout", [True, False])
def test_the_final_line_names_every_file_written(into_checkout, tmp_path, monkeypatch, capsys):
    """`hcv report`'s last line names erratum.md, and the README where the run rewrites
    its generated blocks (into the checkout's reports/), not elsewhere. The build is a stub:
    only the line is checked here."""

    def fake_build_report(out, **kw):
        return {"claims": [], "timings_seconds": {"total": 1.0}}

    monkeypatch.setattr(campaign, "build_report", fake_build_report)
    out = REPORTS if into_checkout else tmp_path / "rep"
    code = main(["report", "--out", str(out)])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    readme = "README.md (its generated blocks)" in last
    assert_true(
        code == 0 and "erratum.md" in last and "results.json" in last and readme == into_checkout,
        got=f"exit {code}, {last!r}",
        should="exit 0, a line naming erratum.md and results.json"
        + (", and README.md" if into_checkout else ", not README.md"),
        claim="report",
        call=f"hcv report --out {'reports' if into_checkout else 'DIR'} (stub build)",
    )


def test_a_document_of_the_previous_minor_renders(committed, tmp_path, capsys):
    # Issue 37 item 4: a new field is a minor version; --from reads every older minor of
    # its major. The committed document relabelled "hcv-results/1" (1.0, before 1.1's
    # codes_side_by_side) without that field is what an older report wrote.
    old = copy.deepcopy(committed)
    old["schema"] = "hcv-results/1"
    old.pop("codes_side_by_side", None)
    src = tmp_path / "in" / "results.json"
    src.parent.mkdir()
    shutil.copytree(REPORTS / "figures", src.parent / "figures")
    src.write_text(json.dumps(old))
    code = main(["report", "--from", str(src), "--out", str(tmp_path / "out")])
    assert_true(
        code == 0 and (tmp_path / "out" / "index.html").is_file(),
        got=f"exit {code}, stderr {capsys.readouterr().err!r}",
        should="exit 0 and the pages written",
        claim="report",
        call="hcv report --from results.json (schema hcv-results/1)",
    )


def test_a_run_rewrites_the_readme_speed_block_with_its_work_precision_paragraph(
    committed, tmp_path, monkeypatch
):
    """The speed block `hcv report` writes into the README is the one `readme_table`
    writes from the same records: bench/exact.json, startup.json, workprecision.json and
    batch_peer.json (the main job of 2b81549 dropped the work-precision paragraph: it read
    only two)."""
    from reference_impl.report.readme_table import rewrite_readme

    if not (REPORTS / "bench" / "workprecision.json").is_file():
        pytest.skip("no committed reports/bench/workprecision.json")
    out = tmp_path / "rep"
    _previous_report(out, committed)
    readme = tmp_path / "README.md"
    readme.write_text((ROOT / "README.md").read_text())
    # The batch against the parallel peer (issue 38, goal 5): the committed record, else
    # one without rows, whose lines must reach the README all the same.
    bp = out / "bench" / "batch_peer.json"
    if not bp.is_file():
        bp.write_text(json.dumps({"rows": [], "goal_ratio": 10.0, "blocks": 1, "machine": {}}))

    def fake_build(tmp, quick, progress, adapters, env, workers=0, carried=None, repro=None):
        r = copy.deepcopy(committed)
        for rel in r["figures"]:
            shutil.copyfile(REPORTS / rel, tmp / rel)
        (tmp / "results.json").write_text(json.dumps(r))
        return r

    monkeypatch.setattr(campaign, "_build", fake_build)
    campaign.build_report(out, readme=readme, progress=None)
    records = [
        json.loads((out / "bench" / f"{n}.json").read_text())
        for n in ("exact", "startup", "workprecision", "batch_peer")
    ]
    should = rewrite_readme(committed, (ROOT / "README.md").read_text(), *records)
    got = readme.read_text()
    assert_true(
        got == should
        and "Work-precision, ours as a curve" in got
        and "benchmarks.bench_batch_peer --json" in got,
        got="the README's blocks differ from readme_table's with all four records",
        should="identical, the work-precision paragraph and the batch-peer lines kept",
        claim="report",
        call="build_report(out, readme=README)",
    )
