"""``hcv report``: the quick report is produced, complete and well formed.

One quick report with our reference adapter (``build_report(quick=True,
adapters=["reference"])``) is built into a temporary directory for the whole module
(building a second one for the adapter's scorecard took a third of the suite's report
time, issue 20); the tests then check the files,
the fields of results.json, the claim ids and verdicts, the Table 1
structure, the consistency of verdicts with the rows they summarise, and that
index.html is well-formed, self-contained HTML. Marked ``slow``: deselect with
``-m 'not slow'``.
"""

from __future__ import annotations

import json
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest

pytest.importorskip("matplotlib")

from reference_impl.campaign import build_report  # noqa: E402
from reference_impl.claims import VERDICTS  # noqa: E402
from reference_impl.studies.paper import TABLE1_PRINTED, table1_cells  # noqa: E402
from verification.assertions import assert_true  # noqa: E402

pytestmark = pytest.mark.slow

# The issues' list, spelled out here on purpose (not read from the registry);
# sec6-assemblies is issue 39's claim (section 6 in chains and packings).
CLAIM_IDS = (
    "thm1-period",
    "thm2-harmonic",
    "km-cancellation",
    "thm3-damping-iff",
    "sec6-dt-safe-bound",
    "sec6-assemblies",
    "sec7-effective-mass",
    "sec9-power-law",
    "sec10-stiffening-domain",
    "table1",
    "fig1",
)
CLAIM_FIELDS = {"id", "section", "statement", "verdict", "evidence"}
TOP_FIELDS = {"claims", "table1", "dt_crit_map", "work_precision", "environment"}
TABLE1_COLUMNS = ("delta_max", "max_force", "dt_safe")
PACKAGES = ("numpy", "scipy", "mpmath", "numba", "pandas", "matplotlib", "sympy")
# Elements without an end tag in HTML.
VOID = {
    "area",
    "base",
    "br",
    "col",
    "embed",
    "hr",
    "img",
    "input",
    "link",
    "meta",
    "source",
    "track",
    "wbr",
}
CALL = "build_report(tmp, quick=True, adapters=['reference'])"


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    messages: list[str] = []
    # The reference adapter adds its scorecard for test_report_with_adapter_has_scorecard
    # (a few seconds) and leaves every other part of the quick report as it is.
    results = build_report(out, quick=True, progress=messages.append, adapters=["reference"])
    return out, results, messages


def _strict_json(path: Path):
    def refuse(token):
        raise ValueError(f"non-standard JSON constant {token!r} in {path.name}")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_files_are_written(report):
    out, results, messages = report
    for name in ("index.html", "index.md", "erratum.md", "results.json"):
        p = out / name
        assert_true(
            p.is_file() and p.stat().st_size > 0,
            got=f"{p} missing or empty",
            should="written",
            claim="report",
            call=CALL,
        )
    figs = results["figures"]
    assert_true(
        len(figs) >= 4,
        got=f"{figs}",
        should="fig1, map, work-precision, hard cases",
        claim="report",
        call=CALL,
    )
    for rel in figs:
        data = (out / rel).read_bytes()
        assert_true(
            data[:8] == b"\x89PNG\r\n\x1a\n",
            got=f"{rel}: {data[:8]!r}",
            should="a PNG file",
            claim="report",
            call=CALL,
        )
    assert_true(
        len(messages) > 5,
        got=f"{len(messages)} progress messages",
        should="progress reported while running",
        claim="report",
        call=CALL,
    )


def test_results_json_fields_and_claims(report):
    out, results, _ = report
    data = _strict_json(out / "results.json")
    assert_true(
        TOP_FIELDS <= set(data),
        got=f"fields {sorted(data)}",
        should=f"at least {sorted(TOP_FIELDS)}",
        claim="report",
        call=CALL,
    )
    ids = [c["id"] for c in data["claims"]]
    assert_true(
        sorted(ids) == sorted(CLAIM_IDS) and len(ids) == len(set(ids)),
        got=f"claim ids {ids}",
        should=f"exactly {list(CLAIM_IDS)}",
        claim="report",
        call=CALL,
    )
    for c in data["claims"]:
        assert_true(
            CLAIM_FIELDS <= set(c),
            got=f"{c['id']}: fields {sorted(c)}",
            should=f"{sorted(CLAIM_FIELDS)}",
            claim="report",
            call=CALL,
        )
        assert_true(
            c["verdict"] in VERDICTS and c["verdict"] in ("verified", "refuted", "inconclusive"),
            got=f"{c['id']}: verdict {c['verdict']!r}",
            should=f"one of {VERDICTS}",
            claim="report",
            call=CALL,
        )
        assert_true(
            isinstance(c["evidence"], str) and len(c["evidence"]) > 20,
            got=f"{c['id']}: evidence {c['evidence']!r}",
            should="one line of evidence",
            claim="report",
            call=CALL,
        )
    for c in data["claims"]:
        tools = [t for t in c["tests"] if not t.startswith("test_sec")]
        assert_true(
            bool(c["tests"]) and not tools,
            got=f"{c['id']}: tests {c['tests']}",
            should="claim tests of test_sec*.py only (evidence, not tool tests)",
            claim="report",
            call=CALL,
        )
        assert_true(
            (c["verdict"] == "refuted") == bool(c.get("counterexample")),
            got=f"{c['id']}: {c['verdict']} with counterexample {c.get('counterexample')}",
            should="a counterexample exactly when refuted",
            claim="report",
            call=CALL,
        )
    assert_true(
        data == results,
        got="results.json differs from the returned dict",
        should="identical",
        claim="report",
        call=CALL,
    )


def test_table1_rows(report):
    _, results, _ = report
    rows = results["table1"]
    assert_true(
        [r["v0"] for r in rows] == list(TABLE1_PRINTED),
        got=f"speeds {[r['v0'] for r in rows]}",
        should=f"{list(TABLE1_PRINTED)}",
        claim="report",
        call=CALL,
    )
    cells = {(c.v0, c.column): c for c in table1_cells()}
    for r in rows:
        for j, col in enumerate(TABLE1_COLUMNS):
            cell = r[col]
            ok = (
                cell["printed"] == TABLE1_PRINTED[r["v0"]][j]
                and isinstance(cell["match"], bool)
                and cell["match"] == cells[(r["v0"], col)].match
                and math.isfinite(float(cell["computed"]))
            )
            assert_true(
                ok,
                got=f"v0 = {r['v0']} {col}: {cell}",
                should="printed, computed and match flag of table1_cells()",
                claim="report",
                call=CALL,
            )
    verdict = next(c for c in results["claims"] if c["id"] == "table1")["verdict"]
    any_bad = any(not r[col]["match"] for r in rows for col in TABLE1_COLUMNS)
    assert_true(
        verdict == ("refuted" if any_bad else "verified"),
        got=f"verdict {verdict}, mismatching cells: {any_bad}",
        should="refuted exactly when a cell mismatches",
        claim="report",
        call=CALL,
    )


def test_map_and_work_precision_rows(report):
    _, results, _ = report
    rows = results["dt_crit_map"]
    need = {"case", "v0", "scene", "dt_safe", "dt_crit", "ratio", "holds", "degenerate"}
    assert_true(
        bool(rows) and all(need <= set(r) for r in rows),
        got=f"{len(rows)} rows, fields {sorted(rows[0]) if rows else []}",
        should=f"rows with {sorted(need)}",
        claim="report",
        call=CALL,
    )
    verdict = next(c for c in results["claims"] if c["id"] == "sec6-dt-safe-bound")["verdict"]
    assert_true(
        all("failure_kind" in r for r in rows),
        got="map rows without failure_kind",
        should="every row classified (runaway, bounded, accuracy or none)",
        claim="report",
        call=CALL,
    )
    # Only a confirmed runaway strictly below dt_safe (holds false) is an instability.
    runaways = [
        r for r in rows if not r["degenerate"] and r["failure_kind"] == "runaway" and not r["holds"]
    ]
    want = "refuted" if runaways else "verified"
    assert_true(
        verdict == want,
        got=f"verdict {verdict} with {len(runaways)} runaways below the bound",
        should=f"{want} (refuted exactly when a runaway lies below the bound)",
        claim="report",
        call=CALL,
    )
    wp = results["work_precision"]
    need = {
        "scene",
        "method",
        "setting",
        "seconds",
        "err_contact_time",
        "err_restitution",
        "err_max_penetration",
        "err_trajectory",
    }
    methods = {r["method"] for r in wp}
    assert_true(
        bool(wp)
        and all(need <= set(r) for r in wp if r.get("seconds") is not None)
        and {"exact", "RK45", "DOP853", "Verlet"} <= methods,
        got=f"{len(wp)} rows, methods {sorted(methods)}",
        should="rows with errors and times for exact, RK45, DOP853 and Verlet",
        claim="report",
        call=CALL,
    )


def test_environment(report):
    _, results, _ = report
    env = results["environment"]
    need = {
        "python",
        "machine",
        "platform",
        "cpu_count",
        "git_commit",
        "packages",
        "hypothesis_profile",
        "seeds",
    }
    assert_true(
        need <= set(env)
        and all(p in env["packages"] for p in PACKAGES)
        and env["packages"]["numpy"],
        got=f"environment fields {sorted(env)}, packages {env.get('packages')}",
        should=f"{sorted(need)} and versions of {PACKAGES}",
        claim="report",
        call=CALL,
    )


class _Checker(HTMLParser):
    """Balanced-tag checker that also collects resource URLs."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.urls: list[tuple[str, str, str]] = []
        self.images = 0

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name in ("src", "href", "srcset", "data", "action", "poster") and value:
                self.urls.append((tag, name, value))
        if tag == "img":
            self.images += 1
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in VOID:
            self.errors.append(f"end tag for void element </{tag}> at {self.getpos()}")
        elif not self.stack or self.stack[-1] != tag:
            self.errors.append(
                f"</{tag}> at {self.getpos()} closes {self.stack[-1] if self.stack else 'nothing'}"
            )
        else:
            self.stack.pop()


def test_html_is_well_formed_and_self_contained(report):
    out, results, _ = report
    text = (out / "index.html").read_text()
    chk = _Checker()
    chk.feed(text)
    chk.close()
    assert_true(
        not chk.errors and not chk.stack and text.lstrip().lower().startswith("<!doctype html>"),
        got=f"errors {chk.errors[:5]}, unclosed {chk.stack}",
        should="balanced tags in a doctype'd document",
        claim="report",
        call="index.html",
    )
    # What the page loads must be embedded; a hyperlink loads nothing: the erratum links each
    # claim's independent script (repro/NAME.py beside the committed report), nothing else.
    external = [
        u
        for u in chk.urls
        if not (
            u[2].startswith("data:image/png;base64,")
            or u[2].startswith("#")
            or (u[:2] == ("a", "href") and re.fullmatch(r"repro/\w+\.py", u[2]))
        )
    ]
    assert_true(
        not external,
        got=f"external resources {external[:5]}",
        should="only data: URIs, in-page anchors and links to the repro/ scripts",
        claim="report",
        call="index.html",
    )
    imgs = [u for u in chk.urls if u[0] == "img"]
    assert_true(
        chk.images == len(results["figures"]) == len(imgs)
        and all(u[2].startswith("data:image/png;base64,") for u in imgs),
        got=f"{chk.images} <img>, {len(results['figures'])} figures",
        should="every figure embedded as a data: URI",
        claim="report",
        call="index.html",
    )
    assert_true(
        "http://" not in text and "https://" not in text,
        got="an http(s) URL in the page",
        should="none (opens offline)",
        claim="report",
        call="index.html",
    )


def test_report_links_only_files_that_are_there(report):
    """Every relative link of index.md, erratum.md and index.html names a file in the output
    directory: a report written outside the checkout's reports/ does not link to the
    referee's repro/*.py (issue 26 item 6), which are not there."""
    import re

    out, _, _ = report
    for name, pattern in (
        ("index.md", r"\]\(([^)\s]+)\)"),
        ("erratum.md", r"\]\(([^)\s]+)\)"),
        ("index.html", r'(?:href|src)="([^"]+)"'),
    ):
        links = re.findall(pattern, (out / name).read_text())
        local = [t for t in links if not t.startswith(("#", "http:", "https:", "data:", "mailto:"))]
        missing = sorted({t for t in local if not (out / t.split("#")[0]).exists()})
        assert_true(
            not missing,
            got=f"links to missing {missing[:5]}",
            should="only existing files",
            claim="report",
            call=f"{CALL}: {name}",
        )


def test_markdown_links_existing_figures(report):
    out, results, _ = report
    md = (out / "index.md").read_text()
    for rel in results["figures"]:
        assert_true(
            f"]({rel})" in md and (out / rel).is_file(),
            got=f"{rel} not linked",
            should="every figure linked from index.md",
            claim="report",
            call="index.md",
        )
    for cid in CLAIM_IDS:
        assert_true(
            f"| {cid} |" in md,
            got=f"{cid} missing from the ledger",
            should="a ledger row per claim",
            claim="report",
            call="index.md",
        )


def test_dt_crit_sensitivity_rows(report):
    """The criterion study (factor, N, tol) is in results.json, one row per criterion."""
    _, results, _ = report
    rows = results["dt_crit_sensitivity"]
    assert {r["scene"] for r in rows} == {"two-sided", "two-walls", "impact"}
    assert all(isinstance(r["ratio"], float) for r in rows)


def test_report_with_adapter_has_scorecard(report):
    """``hcv report --adapter`` adds the adapter's scorecard, JSON and plot to the report."""
    tmp_path, results, _ = report  # the module's report, built with our reference adapter
    docs = results["adapters"]
    assert len(docs) == 1 and docs[0]["adapter"].startswith("reference")
    assert docs[0]["summary"]["pass"] > 0
    md = (tmp_path / "index.md").read_text()
    assert "Contact codes benchmarked" in md and "| reference" in md
    assert "### Side by side" in md and "| measured | expected | error | tolerance |" in md
    assert (tmp_path / "bench").is_dir() and any((tmp_path / "bench").glob("*.json"))


def test_progress_names_every_stage_with_its_count(report):
    """Off a terminal ``hcv report`` prints these lines (issue 17, first hour item 4)."""
    import re

    _, _, messages = report
    stages = [re.search(r"\(stage (\d+) of (\d+)\)", m) for m in messages]
    counts = [(int(s.group(1)), int(s.group(2))) for s in stages if s]
    assert counts, f"got {messages[:5]}, should name stages with counts [{CALL}]"
    n = counts[0][1]
    assert [k for k, _ in counts] == list(range(1, n + 1)), (
        f"got stages {counts}, should be 1..{n} in order [{CALL}]"
    )


def test_a_run_without_adapters_keeps_another_runs_figures(tmp_path):
    from reference_impl.report._files import swap_in

    out = tmp_path / "reports"
    (out / "figures").mkdir(parents=True)
    (out / "figures" / "bench_kratos.png").write_bytes(b"kratos")
    (out / "figures" / "fig1.png").write_bytes(b"old")
    with swap_in(out) as new:
        (new / "figures").mkdir()
        (new / "figures" / "fig1.png").write_bytes(b"new")
    assert (out / "figures" / "bench_kratos.png").read_bytes() == b"kratos"
    assert (out / "figures" / "fig1.png").read_bytes() == b"new"


def test_report_into_an_uncreatable_directory_is_one_line_exit_2(tmp_path):
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    r = subprocess.run(
        [sys.executable, "-m", "reference_impl.cli", "report", "--out", "/proc/x", "--quick"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
        env={**os.environ, "PYTHONPATH": str(root)},
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "/proc/x" in r.stderr, r.stderr


def test_results_json_is_of_the_documented_schema(report):
    """results.json names its schema and reads back through the renderer's check (issue 30)."""
    from reference_impl.report import SCHEMA, read_results

    out, results, _ = report
    back = read_results(out / "results.json")
    assert_true(
        back["schema"] == SCHEMA and back == json.loads(json.dumps(results)),
        got=f"schema {back.get('schema')!r}",
        should=f"{SCHEMA!r}, identical to the returned dict",
        claim="report",
        call=CALL,
    )
