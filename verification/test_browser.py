"""The report and the documentation site as a person reads them (issue 31).

The site is built from ``docs/`` with warnings as errors (that test needs only the
``docs`` extra); the report committed in ``reports/index.html`` and every page of the
built site are then opened in headless Chromium (``verification/_browser.py``), and each
defect a reader would meet is its own test. A copy of the site with planted defects shows
that each check can fail.
"""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from verification._browser import (
    CHROMIUM,
    INSTALL_LINE,
    VIEWPORT_WIDTH,
    dead_file_links,
    inspect_pages,
)
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent
REPORT = ROOT / "reports" / "index.html"
DOCS = ROOT / "docs"

_NEEDS_SPHINX = pytest.mark.skipif(
    importlib.util.find_spec("sphinx") is None
    or importlib.util.find_spec("myst_parser") is None
    or importlib.util.find_spec("numpydoc") is None,
    reason="the docs build needs the docs extra: pip install -e '.[docs]'",
)


def _browser_or_skip() -> None:
    if not CHROMIUM.exists() or importlib.util.find_spec("playwright") is None:
        pytest.skip(f"no headless browser (needs {CHROMIUM} and playwright): {INSTALL_LINE}")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built from docs/ with warnings as errors (``nox -s docs`` does the same)."""
    if importlib.util.find_spec("sphinx") is None:
        pytest.skip("the docs build needs the docs extra: pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "sphinx",
            "-W",
            "--keep-going",
            "-q",
            "-b",
            "html",
            str(DOCS),
            str(out),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert proc.returncode == 0, (
        f"got exit status {proc.returncode} from the docs build, should be 0 with no "
        f"warning [sphinx -W --keep-going docs]:\n{proc.stderr[-4000:]}"
    )
    return out


@_NEEDS_SPHINX
def test_docs_build_without_warnings(site):
    """The site builds with warnings as errors and holds every page and the report."""
    pages = {p.name for p in site.glob("*.html")}
    expected = {
        "index.html",
        "getting-started.html",
        "scenes.html",
        "reference.html",
        "verlet.html",
        "benchmarking.html",
        "adapter-protocol.html",
        "performance.html",
        "verdicts.html",
        "contributing.html",
        "sweeps.html",
    }
    assert expected <= pages, (
        f"got pages {sorted(pages)}, should include {sorted(expected - pages)} [docs build]"
    )
    assert (site / "report" / "index.html").is_file(), (
        "got no report/index.html in the site, should hold the committed report [docs build]"
    )


@pytest.fixture(scope="module")
def report_defects() -> dict:
    """The committed report's defects (needs no site: the report is checked on its own)."""
    _browser_or_skip()
    return {"reports/index.html": inspect_pages([REPORT])[REPORT]}


def _site_pages(site: Path) -> list[Path]:
    """Every HTML page the site builds, in sub-directories too (the report's copy at
    ``report/index.html``, with the links to the referee's scripts beside it)."""
    return sorted(site.rglob("*.html"))


@pytest.fixture(scope="module")
def site_defects(site) -> dict:
    """Each page's defects, over every page of the built site."""
    _browser_or_skip()
    found = inspect_pages(_site_pages(site))
    return {str(p.relative_to(site)): d for p, d in found.items()}


@_NEEDS_SPHINX
def test_every_relative_link_of_the_built_site_names_a_file(site):
    """Without a browser: each page of the built site, its copy of the report included,
    links only to files the site holds (the report's copy linked to five repro/*.py
    scripts that the site did not hold, issue 41)."""
    pages = _site_pages(site)
    dead = {str(p.relative_to(site)): d for p in pages if (d := dead_file_links(p))}
    assert_true(
        not dead and site / "report" / "index.html" in pages,
        got=f"dead links {dict(list(dead.items())[:3])}; pages {len(pages)}",
        should="no dead link on any page, report/index.html among the pages",
        claim="docs",
        call="dead_file_links(every page of sphinx -b html docs)",
    )


@pytest.fixture
def defects(request, target) -> dict:
    """The defects of the pages of ``target`` ("report" or "site"), by page."""
    return request.getfixturevalue(f"{target}_defects")


TARGETS = ["report", "site"]


@pytest.mark.parametrize("target", TARGETS)
def test_every_image_decodes(defects, target):
    for page, d in defects.items():
        assert not d.broken_images, (
            f"got images with natural width 0 {d.broken_images}, should decode [{page}]"
        )


@pytest.mark.parametrize("target", TARGETS)
def test_no_raw_markdown_in_rendered_text(defects, target):
    for page, d in defects.items():
        assert not d.raw_markdown, (
            f"got raw Markdown in the rendered text {d.raw_markdown[:5]}, should be "
            f"none outside code [{page}]"
        )


@pytest.mark.parametrize("target", TARGETS)
def test_every_internal_link_resolves(defects, target):
    for page, d in defects.items():
        assert not d.dead_links, (
            f"got links to no file or id {d.dead_links[:10]}, should all resolve [{page}]"
        )


@pytest.mark.parametrize("target", TARGETS)
def test_no_horizontal_scroll(defects, target):
    for page, d in defects.items():
        assert d.overflow_px <= 0, (
            f"got a horizontal scroll of {d.overflow_px} px at {VIEWPORT_WIDTH} px, "
            f"should be 0 [{page}]"
        )


@pytest.mark.parametrize("target", TARGETS)
def test_console_error_log_is_empty(defects, target):
    for page, d in defects.items():
        assert not d.console_errors, (
            f"got console errors {d.console_errors[:5]}, should be none [{page}]"
        )


@pytest.mark.parametrize("target", TARGETS)
def test_print_to_pdf(defects, target):
    for page, d in defects.items():
        assert d.pdf_bytes > 1000, (
            f"got a PDF of {d.pdf_bytes} bytes, should print to a PDF [{page}]"
        )


# Each defect planted in its own copy of a clean page: (the PageDefects field that must
# report it, the HTML planted before </body>).
_PLANTS = {
    "broken image": ("broken_images", '<img src="_static/no-such-figure.png" alt="planted">'),
    "raw Markdown link": ("raw_markdown", "<p>See [the erratum](erratum.md) for it.</p>"),
    "raw Markdown bold": ("raw_markdown", "<p>The claim is **refuted** as printed.</p>"),
    "dead anchor": ("dead_links", '<p><a href="#no-such-section">planted</a></p>'),
    "dead page": ("dead_links", '<p><a href="no-such-page.html">planted</a></p>'),
    "dead anchor on another page": ("dead_links", '<p><a href="scenes.html#nowhere">x</a></p>'),
    "wide block": ("overflow_px", '<div style="width:3000px">planted</div>'),
    "console error": ("console_errors", '<script>console.error("planted")</script>'),
}


def test_checks_fail_on_planted_defects(site, tmp_path):
    """A broken image, raw Markdown, dead links, a wide block and a console error, each
    planted in a copy of a clean page of the site, are each found; the clean page has none."""
    _browser_or_skip()
    copy = tmp_path / "site"
    shutil.copytree(site, copy, ignore=shutil.ignore_patterns("report"))
    clean = (copy / "index.html").read_text(encoding="utf-8")
    assert "</body>" in clean, "got no </body> in the site's index.html [planting]"
    pages = {}
    for i, (name, (_, snippet)) in enumerate(_PLANTS.items()):
        pages[name] = copy / f"planted-{i}.html"
        pages[name].write_text(clean.replace("</body>", snippet + "</body>", 1), encoding="utf-8")
    found = inspect_pages([copy / "index.html", *pages.values()])
    base = found[copy / "index.html"]
    assert not (
        base.broken_images
        or base.raw_markdown
        or base.dead_links
        or base.overflow_px > 0
        or base.console_errors
    ), f"got defects {base} on the clean copy of index.html, should be none [inspect_pages]"
    for name, page in pages.items():
        field, snippet = _PLANTS[name]
        value = getattr(found[page], field)
        assert value and value != getattr(base, field), (
            f"got {field} = {value!r} on a page with a planted {name} ({snippet!r}), "
            f"should report it [inspect_pages]"
        )


def test_dead_file_links_finds_a_missing_script_and_passes_the_others(tmp_path):
    """The browser-free link check can fail: a link to a script that is not there is
    found; links to a file there, a directory's index, an anchor and another site are not."""
    (tmp_path / "repro").mkdir()
    (tmp_path / "repro" / "fig1.py").write_text("")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "index.html").write_text("")
    page = tmp_path / "index.html"
    page.write_text(
        '<a href="repro/fig1.py">ok</a> <a href="repro/table1.py">gone</a> '
        '<a href="sub/">ok</a> <a href="#x">ok</a> <a href="https://arxiv.org/">ok</a> '
        '<a href="sub/index.html#y">ok</a>'
    )
    got = dead_file_links(page)
    assert_true(
        got == ["repro/table1.py"],
        got=str(got),
        should="['repro/table1.py']",
        claim="docs",
        call="dead_file_links(a page with one missing script)",
    )
