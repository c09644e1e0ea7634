"""Every figure the README and the site state has one home (issue 41, section 2).

A stated figure is a number followed by a unit of time or size (s, min, ms, µs, MB) in
README.md or docs/*.md, outside fenced code and outside a generated block (``<!--
NAME:start -->`` ... ``<!-- NAME:end -->``, rewritten from a record with its commit,
load and cache state: `reference_impl.report.readme_table` and
`reference_impl.report.docs_blocks`). Outside those, a figure is no measurement (a limit,
a default, a goal, a physical quantity of an example: `_NOT_MEASURED`, each with what it
is). A new figure outside that list fails (a measured one goes into a generated block),
and so does an entry no page states any more (the list only shrinks). Each block of
`docs_blocks` is the text its committed record gives (a stale block fails).
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import pytest

from reference_impl.errors import HCVInputError
from reference_impl.report import docs_blocks
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_BLOCK = re.compile(r"<!-- ([\w-]+):start -->.*?<!-- \1:end -->", re.S)
_FENCE = re.compile(r"```.*?```", re.S)
# A number (a range too: 1.2–1.5 s) followed by its unit; not part of a word or a power.
FIGURE = re.compile(
    r"(?<![\w.^*-])\d+(?:[.,]\d+)?(?:\s?[–-]\s?\d+(?:\.\d+)?)?\s?(?:s|min|MB|µs|ms)\b"
)

# (page, figure as written): what it is. Not measurements: nothing to re-measure.
_NOT_MEASURED = {
    ("adapter-protocol.md", "5 s"): "the grace period before an adapter is killed (code)",
    ("adapter-protocol.md", "60 s"): "the default run timeout (tolerances.toml)",
    ("getting-started.md", "35 s"): "an example of a progress line's form",
    ("getting-started.md", "256 MB"): "HCV_CACHE_MAX_MB's default",
    ("getting-started.md", "64 MB"): "the free-space floor of the cache",
    ("scenes.md", "1.26966 s"): "a solved damping strength (s/m), not a time",
    ("performance.md", "1 s"): "issue 38's goal for hcv solve's CPU time, not a measurement",
    ("scenes.md", "2221 s"): "a solved damping strength of an example law",
    ("scenes.md", "20 s"): "the strength A of an example law",
    ("scenes.md", "293 s"): "the contact time of that example (a physical result)",
    ("scenes.md", "1 MB"): "the size limit of a scene file",
    ("sweeps.md", "10 s"): "the scheduler's connect timeout",
    ("performance.md", "8 µs"): "issue 27's goal",
}


def stated_figures(text: str) -> list[str]:
    """The figures ``text`` states outside fenced code and generated blocks."""
    text = _FENCE.sub("", _BLOCK.sub("", text))
    return [" ".join(m.group(0).split()) for m in FIGURE.finditer(text)]


def _found() -> set[tuple[str, str]]:
    return {(p.name, f) for p in PAGES for f in stated_figures(p.read_text())}


def test_every_stated_figure_has_a_home():
    homeless = sorted(_found() - set(_NOT_MEASURED))
    assert_true(
        not homeless,
        got=f"figures outside a generated block: {homeless}",
        should="none: put a measured figure in a generated block (its record's commit, "
        "load and cache state beside it), or list a limit, default or goal in _NOT_MEASURED",
        claim="docs",
        call="stated_figures(README.md, docs/*.md)",
    )


def test_the_lists_name_only_figures_still_stated():
    gone = sorted(set(_NOT_MEASURED) - _found())
    assert_true(
        not gone,
        got=f"listed but no longer stated: {gone}",
        should="each entry of _NOT_MEASURED stated on its page (drop the rest)",
        claim="docs",
        call="test_docs_figures lists",
    )


def test_the_scan_finds_figures_and_skips_blocks_and_code():
    text = (
        "The job took 104 s wall (1.33 MB); a range 1.2–1.5 s; q**2.5 s is not one.\n"
        "<!-- x:start -->\n220 s\n<!-- x:end -->\n```bash\nsleep 5 s\n```\n8 µs, 3 min."
    )
    got = stated_figures(text)
    assert_true(
        got == ["104 s", "1.33 MB", "1.2–1.5 s", "8 µs", "3 min"],
        got=str(got),
        should="['104 s', '1.33 MB', '1.2–1.5 s', '8 µs', '3 min']",
        claim="docs",
        call="stated_figures(a planted text)",
    )


def _pages() -> dict[str, str]:
    return {b.page: (ROOT / b.page).read_text() for b in docs_blocks.BLOCKS}


def test_every_generated_block_is_its_record():
    stale = docs_blocks.stale_blocks(_pages(), docs_blocks.load_records(ROOT))
    assert_true(
        not stale,
        got=f"blocks differing from their record: {stale}",
        should="none (run python -m reference_impl.report.docs_blocks)",
        claim="docs",
        call="docs_blocks.stale_blocks(committed pages, reports/bench/*.json)",
    )


def test_every_block_states_its_commit_and_load():
    records = docs_blocks.load_records(ROOT)
    missing = [
        b.name
        for b in docs_blocks.BLOCKS
        if not re.search(r"(commit|tree) [0-9a-f]{7}", body := docs_blocks.render(b, records))
        or not re.search(r"load \d", body)
    ]
    assert_true(
        not missing,
        got=f"blocks without a commit or a load: {missing}",
        should="each block names its record's commit and the load beside its timings",
        claim="docs",
        call="docs_blocks.render(every block)",
    )


def test_a_stale_block_fails_and_is_rewritten():
    records = docs_blocks.load_records(ROOT)
    pages = _pages()
    body = docs_blocks.render(docs_blocks.BLOCKS[0], records)
    planted = dict(pages)
    page = docs_blocks.BLOCKS[0].page
    planted[page] = pages[page].replace(body, body.replace(" s wall", " s  wall", 1))
    stale = docs_blocks.stale_blocks(planted, records)
    fixed = docs_blocks.rewrite_page(planted[page], page, records)
    assert_true(
        stale == [f"{page}: {docs_blocks.BLOCKS[0].name}"] and fixed == pages[page],
        got=f"stale {stale}, rewritten back: {fixed == pages[page]}",
        should=f"['{page}: {docs_blocks.BLOCKS[0].name}'], True",
        claim="docs",
        call="docs_blocks.stale_blocks(a page with one block edited by hand)",
    )


def test_a_timing_at_a_load_above_the_cores_says_so():
    records = docs_blocks.load_records(ROOT)
    busy, quiet = copy.deepcopy(records), copy.deepcopy(records)
    for rec, load in ((busy, 15.0), (quiet, 0.5)):
        for row in rec["commands.json"]["cases"]:
            for run in [row["cold_run"], *row["warm_runs"]]:
                run["load_before"] = run["load_after"] = load
        rec["commands.json"]["machine"]["cpu_count"] = 2
    warn = "exceeded the 2 cores"
    got = (warn in docs_blocks.smoke_time(busy), warn in docs_blocks.smoke_time(quiet))
    assert_true(
        got == (True, False),
        got=f"warning at load 15, at load 0.5: {got}",
        should="(True, False): a warning only where the load exceeds the cores",
        claim="docs",
        call="docs_blocks.smoke_time(planted loads on 2 cores)",
    )


def test_a_page_without_its_markers_is_refused():
    records = docs_blocks.load_records(ROOT)
    with pytest.raises(HCVInputError, match="smoke-time"):
        docs_blocks.rewrite_page("no markers here", "README.md", records)


def test_a_missing_record_is_named(tmp_path):
    # every record is missing from an empty directory: the first, in name order, is named
    first = sorted({r for b in docs_blocks.BLOCKS for r in b.records})[0]
    with pytest.raises(HCVInputError, match=rf"reports/bench/{re.escape(first)}"):
        docs_blocks.load_records(tmp_path)


def test_a_hostile_16_core_batch_record_is_escaped_or_refused():
    """The 16-core batch record is input: HTML and a link in its text reach the page escaped;
    a string where a time should be is refused (TypeError/ValueError, which `main` turns into
    one line and exit 2), never printed as a figure."""
    records = docs_blocks.load_records(ROOT)
    bad = copy.deepcopy(records)
    rec = bad["batch_peer_16cores.json"]
    rec["rows"][0]["row"] = "<script>alert(1)</script>"
    rec["machine"]["cpu"] = "[x](javascript:alert(1))"
    text = docs_blocks.batch_sixteen_cores(bad)
    assert_true(
        "<script>" not in text and "](javascript:" not in text,
        got=text[:300],
        should="no raw <script> and no javascript: link on the page",
        claim="docs",
        call="docs_blocks.batch_sixteen_cores(HTML in row and cpu)",
    )
    rec["rows"][0]["us_per_impact"] = dict.fromkeys(rec["rows"][0]["us_per_impact"], "fast")
    with pytest.raises((TypeError, ValueError)):
        docs_blocks.batch_sixteen_cores(bad)
