"""Hostile results files: the report trusts no string (issue 36).

A results.json is the file users share, and ``hcv report`` carries the previous one's
code sections, so it may come from anyone (a pull request). Two classes here (the third,
paths, is ``test_hostile_report_paths.py``):

2. links and markup: only relative links inside the report and http(s) links survive;
   raw ``<script>``/``<iframe>`` shows as text in index.html, index.md, erratum.md and
   the README's verdict table (the Markdown is rendered by markdown-it, CommonMark, with
   raw HTML on and every link allowed, so what a Markdown viewer would make of it shows);
3. the schema: malformed documents (empty claims, ``adapters: [1]``, missing keys, wrong
   types) and random deletions and type swaps of the committed document's fields
   (Hypothesis) give one line naming the JSON path of the field (exit status 2, nothing
   written) or a rendered report, never a traceback.

Fast: nothing is measured; each case renders the committed results at most once.
"""

from __future__ import annotations

import copy
import json
from html.parser import HTMLParser

import pytest
from hypothesis import HealthCheck, given, settings
from markdown_it import MarkdownIt

from reference_impl.errors import HCVInputError
from reference_impl.report import _erratum, _render, check_results, read_results, render_from
from reference_impl.report._text import markdown_text, safe_href
from reference_impl.report.readme_table import verdict_table
from verification._hostile_report_cases import (
    BASE,
    CLAIM,
    COMMITTED,
    REPORTS,
    committed_copy,
    refused,
    run_from,
    source,
)
from verification.assertions import assert_true
from verification.strategies import json_mutations


@pytest.fixture
def committed():
    """A fresh copy of the (trimmed) committed results."""
    return committed_copy()


# ----------------------------------------------------------------------------------
# 2. links and markup
# ----------------------------------------------------------------------------------
_SAFE = "[ok](https://example.org/a) [rel](figures/fig1.png#x)"
_HOSTILE = (
    "[a](javascript:alert(1)) [b](JaVaScRiPt:alert%281%29) [c](data:text/html;base64,PHM+) "
    "[d](file:///etc/passwd) [e](vbscript:msgbox) [f](//evil.example/x) [g](&#106;avascript:x) "
    "[h](/etc/passwd) [i](../../x) [j]( javascript:x) [k](<javascript:x>) <javascript:x> "
    "<script>alert(1)</script> <iframe src=x></iframe> <img src=x onerror=alert(1)> "
    "<a href='javascript:x'>l</a> " + _SAFE
)
# The hrefs a page may hold: its own anchors and the two safe links of _HOSTILE.
_ALLOWED_HREFS = {"https://example.org/a", "figures/fig1.png#x"}


def _hostile_doc(committed) -> dict:
    doc = copy.deepcopy(committed)
    doc["title"] = "Report: " + _HOSTILE
    for c in doc["claims"]:
        for key in ("section", "statement", "rule", "headline"):
            c[key] = f"{c[key]} {_HOSTILE}"
        c["evidence"] = f"{c['evidence']} {_HOSTILE}"
    doc["figure_captions"] = {k: _HOSTILE for k in doc["figure_captions"]}
    doc["hard_cases"]["accuracy"] = [_HOSTILE] + doc["hard_cases"]["accuracy"]
    doc["environment"]["python"] = _HOSTILE
    return doc


class _Tags(HTMLParser):
    """Every start tag of a page with its attributes (entities decoded), as a browser sees it."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, list]] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, attrs))


def _markup(page_html: str) -> list[str]:
    """What in an HTML page would run or leave the report: a script or iframe element, an
    event attribute (on...), an href other than the page's anchors and the allowed links."""
    parser = _Tags()
    parser.feed(page_html)
    bad = []
    for tag, attrs in parser.tags:
        if tag in ("script", "iframe"):
            bad.append(f"<{tag}>")
        bad += [f"{tag} {k}=" for k, _ in attrs if k.startswith("on")]
        bad += [f"{tag} href={v!r}" for k, v in attrs
                if k == "href" and not (v or "").startswith("#") and v not in _ALLOWED_HREFS]  # fmt: skip
    return bad


def _markdown_html(text: str) -> str:
    """CommonMark with raw HTML on and every link allowed: what a lax viewer shows."""
    md = MarkdownIt("commonmark", {"html": True})
    md.validateLink = lambda url: True
    return md.render(text)


def test_links_and_markup_of_a_results_file_are_neutralised(committed, tmp_path):
    doc = _hostile_doc(committed)
    src = source(tmp_path, doc)
    out = tmp_path / "out"
    render_from(src / "results.json", out)
    pages = {
        "index.html": (out / "index.html").read_text(),
        "index.md": _markdown_html((out / "index.md").read_text()),
        "erratum.md": _markdown_html((out / "erratum.md").read_text()),
        "README verdict table": _markdown_html(verdict_table(doc)),
    }
    found = {name: _markup(page)[:4] for name, page in pages.items() if _markup(page)}
    # The strings did reach every page, shown as text, and the safe links survived.
    shown = {name: "&lt;script&gt;" in page and 'href="https://example.org/a"' in page
             for name, page in pages.items()}  # fmt: skip
    assert_true(
        not found and all(shown.values()),
        got=f"live markup or links {found}; hostile text shown and safe link kept: {shown}",
        should="no script/iframe/event attribute, only relative links inside the report "
        "and http(s) links, the hostile text visible as text",
        claim=CLAIM,
        call="render_from(hostile results.json), verdict_table",
    )


@pytest.mark.parametrize(
    "text",
    [
        "x\n> [r]: javascript:alert(1)\n\n[y][r]",  # a definition inside a block quote
        "x\n- [r]: javascript:alert(1)\n\n[y][r]",  # inside a list item
        "x\n1. [r]: javascript:alert(1)\n\n[y][r]",  # inside an ordered list item
        "[r\\]]: javascript:alert(1)\n\n[y][r\\]]",  # an escaped "]" in the label
        "[r\\\\]: javascript:alert(1)\n\n[y][r\\\\]",  # an escaped backslash before "]"
        "> > [r]: javascript:alert(1)\n\n[y][r]",  # nested block quotes
    ],
)
def test_a_link_definition_in_any_container_stays_text(text):
    """CommonMark reads a link reference definition inside block quotes and list items too,
    and it defines the label for the whole page: each was a live javascript: link of
    index.md and erratum.md (the rule escaped only a definition at a line's start)."""
    page = _markdown_html(markdown_text(text))
    assert_true(
        "href" not in page,
        got=repr(page),
        should="no link (the definition shown as text)",
        claim=CLAIM,
        call=f"markdown_text({text!r}) rendered by CommonMark",
    )


@pytest.mark.parametrize(
    "target, safe",
    [
        ("repro/thm1_period.py", True),
        ("figures/fig1.png#x", True),
        ("#claims", True),
        ("https://example.org/a?b=1", True),
        ("http://example.org", True),
        ("javascript:alert(1)", False),
        ("JAVASCRIPT:x", False),
        ("data:text/html,x", False),
        ("file:///etc/passwd", False),
        ("vbscript:x", False),
        ("//evil.example/x", False),
        ("/etc/passwd", False),
        ("../x", False),
        ("a/../../x", False),
        ("&#106;avascript:x", False),
        ("java\tscript:x", False),
        ("https://", False),
        ("", False),
    ],
)
def test_safe_href_allows_relative_inside_and_http_only(target, safe):
    assert_true(
        safe_href(target) is safe,
        got=f"safe_href({target!r}) = {safe_href(target)}",
        should=str(safe),
        claim=CLAIM,
        call="report._text.safe_href",
    )


# ----------------------------------------------------------------------------------
# 3. the schema
# ----------------------------------------------------------------------------------
def _malform(case: str, d: dict) -> None:
    if case == "claims: []":
        d["claims"] = []
    elif case == "adapters: [1]":
        d["adapters"] = [1]
    elif case == "table1: []":
        d["table1"] = []
    elif case == "a drift as text":
        d["fig1"]["runs"][0]["drift"] = "x"
    elif case == "work_precision_summary: []":
        d["work_precision_summary"] = []
    elif case == "no damping-law speeds":
        d["damping_laws"]["speeds"] = []
    elif case == "no total time":
        d["timings_seconds"] = {}
    elif case == "no packages":
        del d["environment"]["packages"]
    elif case == "a code without variants":
        d["steps_per_contact"][0] = {"adapter": "x"}
    elif case == "a claim without tests":
        del d["claims"][0]["tests"]
    elif case == "a caption as a number":
        d["figure_captions"] = {"work_precision_families.png": 5}
    elif case == "a hard case as a number":
        d["hard_cases"]["cases"][0] = 1
    elif case == "a scene as a list":
        d["dt_crit_map"][0]["scene"] = ["x"]
    elif case == "an asked e as text":
        d["codes_side_by_side"]["calibration"][0]["asked"] = "x"
    elif case == "no fig1 claim":
        d["claims"] = [c for c in d["claims"] if c["id"] != "fig1"]
    else:
        raise AssertionError(case)


MALFORMED = [
    ("claims: []", "$.claims"),
    ("adapters: [1]", "$.adapters[0]"),
    ("table1: []", "$.table1"),
    ("a drift as text", "$.fig1.runs[0].drift"),
    ("work_precision_summary: []", "$.work_precision_summary"),
    ("no damping-law speeds", "$.damping_laws.speeds"),
    ("no total time", "$.timings_seconds: 'total' is missing"),
    ("no packages", "$.environment: 'packages' is missing"),
    ("a code without variants", "$.steps_per_contact[0]: 'variants' is missing"),
    ("a claim without tests", "$.claims[0]: 'tests' is missing"),
    ("a caption as a number", "$.figure_captions"),
    ("a hard case as a number", "$.hard_cases.cases[0]"),
    ("a scene as a list", "$.dt_crit_map[0].scene"),
    ("an asked e as text", "$.codes_side_by_side.calibration[0].asked"),
    ("no fig1 claim", "$.claims: has no entry"),
]


@pytest.mark.parametrize("case, needle", MALFORMED)
def test_a_malformed_document_is_one_line_naming_its_json_path(
    committed, tmp_path, capsys, case, needle
):
    if not committed["steps_per_contact"] or not committed.get("codes_side_by_side"):
        pytest.skip("the committed report has no contact codes")
    doc = copy.deepcopy(committed)
    _malform(case, doc)
    src = source(tmp_path, doc)
    out = tmp_path / "out"
    code, err, _ = run_from(src, out, capsys)
    refused(code, err, out, needle, [], [], f"hcv report --from ({case})")


@pytest.mark.parametrize(
    "where, literal",
    [
        ("confirm_horizon", "1e999"),  # parses to inf; the renderer takes int() of it
        ("v0", "1" + "0" * 400),  # an integer no float can hold; the renderer formats it
    ],
)
def test_a_number_out_of_range_is_one_line_naming_its_json_path(
    committed, tmp_path, capsys, where, literal
):
    doc = copy.deepcopy(committed)
    if where == "confirm_horizon":
        i = next(i for i, x in enumerate(doc["dt_crit_sensitivity"]) if x["scene"] != "impact")
        doc["dt_crit_sensitivity"][i]["confirm_horizon"] = "@BIG@"
        needle = f"$.dt_crit_sensitivity[{i}].confirm_horizon"
    else:
        doc["fig1"]["runs"][0]["v0"] = "@BIG@"
        needle = "$.fig1.runs[0].v0"
    src = source(tmp_path, doc)
    (src / "results.json").write_text(json.dumps(doc).replace('"@BIG@"', literal))
    out = tmp_path / "out"
    code, err, _ = run_from(src, out, capsys)
    refused(code, err, out, needle, [], [], f"hcv report --from ({where} = {literal[:8]}...)")


@pytest.mark.parametrize(
    "case, needle",
    [
        # json.loads reads "\\ud800" as a lone surrogate: the pages could not be written
        # (UnicodeEncodeError, a traceback, after the checks had passed).
        ("a lone surrogate in the title", "$.title: 'a\\ud800b' holds a lone surrogate"),
        ("a lone surrogate in a key", "$.figure_captions: 'x\\udfffy.png' holds a lone"),
        # Python keeps the last of a repeated key, other readers the first, and the file is
        # copied as it is: another reader of the copy would see the poisoned figures.
        ("figures given twice", "not JSON (the key 'figures' is given twice in one object)"),
        # int() of a 5000-digit minor raised ValueError (Python's 4300-digit limit).
        ("a 5000-digit minor version", "has schema 'hcv-results/1.999"),
        # Each listed figure is read, checked and copied: 1e5 repeats of one ran past 120 s.
        ("a figure listed 100000 times", "$.figures: lists an entry twice"),
    ],
)
def test_unwritable_text_repeated_keys_and_endless_lists_are_one_line(
    committed, tmp_path, capsys, case, needle
):
    doc = copy.deepcopy(committed)
    if case == "a lone surrogate in the title":
        doc["title"] = "@LONE@"
    elif case == "a lone surrogate in a key":
        doc["figure_captions"]["@LONE@"] = "a caption"
    elif case == "a 5000-digit minor version":
        doc["schema"] = "hcv-results/1." + "9" * 5000
    elif case == "a figure listed 100000 times":
        doc["figures"] += ["figures/fig1.png"] * 100_000
    src = source(tmp_path, doc)
    text = json.dumps(doc)
    text = text.replace('"@LONE@"', '"a\\ud800b"' if "title" in case else '"x\\udfffy.png"')
    if case == "figures given twice":
        text = text.replace('"figures": [', '"figures": ["/proc/self/environ"], "figures": [', 1)
    (src / "results.json").write_text(text)
    out = tmp_path / "out"
    code, err, _ = run_from(src, out, capsys)
    refused(code, err, out, needle, [], [], f"hcv report --from ({case})")


@settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(doc=json_mutations(BASE))
def test_random_deletions_and_type_swaps_are_refused_or_rendered(doc):
    """Each example: one line (HCVInputError) or a rendered report, never another error."""
    if not COMMITTED.is_file():
        pytest.skip("reports/results.json not generated")
    try:
        check_results(doc)
    except HCVInputError as exc:
        assert_true(
            "\n" not in str(exc) and str(exc).startswith("results"),
            got=repr(str(exc))[:300],
            should="one line",
            claim=CLAIM,
            call="check_results(mutated document)",
        )
        return
    pages = {**doc, "repro_scripts": None}
    try:
        _render.markdown(pages)
        _erratum.markdown(pages)
        _render.html_page(pages, REPORTS / "figures")
        verdict_table(doc)
    except Exception as exc:  # the test's point: a checked document always renders
        pytest.fail(f"got {type(exc).__name__}: {exc} rendering a document check_results "
                    "accepted, should render [report, check_results + renderers]")  # fmt: skip


def test_the_committed_document_validates_with_its_files(committed):
    back = read_results(REPORTS / "results.json")
    assert_true(
        back == json.loads(COMMITTED.read_text()),
        got="read_results(reports/results.json) refused or changed it",
        should="the committed results.json valid against results.schema.json, figures checked",
        claim=CLAIM,
        call="read_results",
    )
