"""What a reader trips over on a page, found in a real browser (headless Chromium).

Helper of ``verification/test_browser.py``: :func:`inspect_pages` opens HTML files in
Debian's ``/usr/bin/chromium`` through Playwright (its Python package drives a browser
installed elsewhere through ``executable_path``; nothing is downloaded) and lists, per
page, the defects of issue 31: images that do not decode, raw Markdown in the rendered
text, links and anchors that lead nowhere, horizontal scrolling at 1280 px, errors in the
console, and a print to PDF that fails.
"""

from __future__ import annotations

import html.parser
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlsplit
from urllib.request import url2pathname

__all__ = [
    "CHROMIUM",
    "INSTALL_LINE",
    "VIEWPORT_WIDTH",
    "PageDefects",
    "dead_file_links",
    "inspect_pages",
]

CHROMIUM = Path("/usr/bin/chromium")
INSTALL_LINE = "apt-get install chromium && pip install -e '.[docs]'"
VIEWPORT_WIDTH = 1280  # px: the narrowest desktop window the report and the site must fit

# The flags of a quiet, reproducible headless run: no GPU, no network of its own, no
# profile left behind (the user-data directory is a temporary one, removed after).
_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]

# Text outside code that still carries Markdown syntax: a link `[text](target)` or bold
# `**text**` that the renderer passed through. Code (pre, code, kbd, samp) may hold both
# legitimately, so it is left out; and `**` counts only where it opens or closes a word,
# as bold is written (`**refuted**`), not between two characters of a word, as a Python
# power is (`Expression('k*q**2.5/2.5')`, which the report prints in figure captions).
_RAW_MARKDOWN_JS = r"""
() => {
  const skip = new Set(['PRE', 'CODE', 'KBD', 'SAMP', 'SCRIPT', 'STYLE', 'TEXTAREA', 'NOSCRIPT']);
  const found = [];
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    let inCode = false;
    for (let e = n.parentElement; e; e = e.parentElement) {
      if (skip.has(e.tagName)) { inCode = true; break; }
    }
    if (inCode) continue;
    const t = n.textContent;
    for (const mark of [/\]\(/, /(^|[\s(\[{"'])\*\*[^\s*]|[^\s*]\*\*($|[\s.,;:!?)\]}"'])/]) {
      const m = mark.exec(t);
      if (m) found.push(t.slice(Math.max(0, m.index - 40), m.index + 40).trim());
    }
  }
  return found;
}
"""

_IMAGES_JS = r"""
async () => {
  const imgs = Array.from(document.images);
  for (const i of imgs) i.loading = 'eager';
  await Promise.all(imgs.map(i => i.decode().catch(() => null)));
  return imgs.filter(i => !(i.complete && i.naturalWidth > 0))
             .map(i => (i.getAttribute('src') || '').slice(0, 80));
}
"""

_LINKS_JS = r"""
() => Array.from(document.querySelectorAll('a[href]'))
        .map(a => [a.getAttribute('href'), a.href])
"""

_ANCHOR_EXISTS_JS = r"""
(id) => document.getElementById(id) !== null || document.getElementsByName(id).length > 0
"""

_OVERFLOW_JS = r"""
() => document.documentElement.scrollWidth - document.documentElement.clientWidth
"""


@dataclass
class PageDefects:
    """What one page shows a reader that it should not.

    Attributes
    ----------
    broken_images : list of str
        The ``src`` (first 80 characters) of each image whose natural width is 0.
    raw_markdown : list of str
        Rendered text around each ``](`` or ``**`` outside code.
    dead_links : list of str
        Each internal anchor or relative link whose target file or id does not exist.
    overflow_px : int
        Horizontal scroll at a 1280 px wide window, in CSS pixels (0: none).
    console_errors : list of str
        Console messages of type error and uncaught page errors.
    pdf_bytes : int
        Size of the page printed to PDF (0 when printing failed).
    """

    broken_images: list[str] = field(default_factory=list)
    raw_markdown: list[str] = field(default_factory=list)
    dead_links: list[str] = field(default_factory=list)
    overflow_px: int = 0
    console_errors: list[str] = field(default_factory=list)
    pdf_bytes: int = 0


class _Hrefs(html.parser.HTMLParser):
    """The ``href`` of every ``<a>`` of a page."""

    def __init__(self) -> None:
        super().__init__()
        self.hrefs: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag == "a":
            self.hrefs += [v for k, v in attrs if k == "href" and v]


def dead_file_links(path: Path) -> list[str]:
    """Relative links of an HTML file whose target file does not exist, read from its
    source without a browser (anchors and ids are left to :func:`inspect_pages`).

    Parameters
    ----------
    path : Path
        The HTML file.

    Returns
    -------
    list of str
        Each such ``href`` as written.
    """
    parser = _Hrefs()
    parser.feed(path.read_text(encoding="utf-8", errors="replace"))
    dead = []
    for href in parser.hrefs:
        url = urlsplit(href)
        if url.scheme or url.netloc or not url.path:  # another site, mailto:, or "#id"
            continue
        target = (path.parent / url2pathname(unquote(url.path))).resolve()
        if target.is_dir():
            target = target / "index.html"
        if not target.is_file():
            dead.append(href)
    return dead


class _Ids(html.parser.HTMLParser):
    """The ids and names a page's links may point at."""

    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        for key, value in attrs:
            if key in ("id", "name") and value:
                self.ids.add(value)


def _ids_of(path: Path, cache: dict[Path, set[str]]) -> set[str]:
    if path not in cache:
        parser = _Ids()
        parser.feed(path.read_text(encoding="utf-8", errors="replace"))
        cache[path] = parser.ids
    return cache[path]


def _dead_links(page, links: list[list[str]], cache: dict[Path, set[str]]) -> list[str]:
    """Internal anchors and relative links of ``page`` whose target does not exist."""
    dead = []
    for raw, absolute in links:
        url = urlsplit(absolute)
        if url.scheme != "file":  # http(s), mailto: outside the page's files, not checked
            continue
        if raw.startswith("#"):
            frag = unquote(raw[1:])
            if frag and not page.evaluate(_ANCHOR_EXISTS_JS, frag):
                dead.append(raw)
            continue
        target = Path(url2pathname(url.path))
        if target.is_dir():
            target = target / "index.html"
        if not target.is_file():
            dead.append(raw)
        elif url.fragment and target.suffix == ".html":
            if unquote(url.fragment) not in _ids_of(target, cache):
                dead.append(raw)
    return dead


def inspect_pages(paths: list[Path]) -> dict[Path, PageDefects]:
    """Open each HTML file in headless Chromium and list its defects.

    Parameters
    ----------
    paths : list of Path
        HTML files to open (one browser for all of them).

    Returns
    -------
    dict
        Each path's :class:`PageDefects`.
    """
    from playwright.sync_api import sync_playwright

    results: dict[Path, PageDefects] = {}
    ids_cache: dict[Path, set[str]] = {}
    profile = tempfile.mkdtemp(prefix="hcv-chromium-")
    try:
        with sync_playwright() as pw:
            context = pw.chromium.launch_persistent_context(
                profile,
                executable_path=str(CHROMIUM),
                headless=True,
                args=_FLAGS,
                viewport={"width": VIEWPORT_WIDTH, "height": 900},
            )
            try:
                for path in paths:
                    results[path] = _inspect_one(context, Path(path).resolve(), ids_cache)
            finally:
                context.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)
    return results


def _inspect_one(context, path: Path, ids_cache: dict[Path, set[str]]) -> PageDefects:
    page = context.new_page()
    found = PageDefects()
    page.on(
        "console",
        lambda msg: found.console_errors.append(msg.text) if msg.type == "error" else None,
    )
    page.on("pageerror", lambda exc: found.console_errors.append(f"uncaught: {exc}"))
    try:
        page.goto(path.as_uri(), wait_until="load")
        found.broken_images = page.evaluate(_IMAGES_JS)
        found.raw_markdown = page.evaluate(_RAW_MARKDOWN_JS)
        found.dead_links = _dead_links(page, page.evaluate(_LINKS_JS), ids_cache)
        found.overflow_px = int(page.evaluate(_OVERFLOW_JS))
        try:
            pdf = page.pdf()
        except Exception as exc:  # noqa: BLE001 - a failed print is a finding, not a crash
            found.console_errors.append(f"print to PDF failed: {exc}")
            pdf = b""
        found.pdf_bytes = len(pdf) if pdf.startswith(b"%PDF-") else 0
    finally:
        page.close()
    return found
