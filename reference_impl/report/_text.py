"""Text of a results document made safe for the report's pages (issue 36).

Every string of a results.json reaches ``index.html``, ``index.md``, ``erratum.md`` and the
README's verdict table; the file is shared and may come from anyone, so:

* a link survives only when its target is `safe_href`: a relative path inside the report
  (no scheme, no leading ``/``, no ``..``) or an ``http(s)://host/...`` address; any other
  (``javascript:``, ``data:``, ``file:``, ``vbscript:``, ``//host``, entity-encoded
  tricks) is left as plain text;
* in Markdown (`markdown_text`) raw HTML cannot open: ``<`` before a letter, ``/``, ``!``
  or ``?`` (CommonMark's raw HTML and autolinks) is written ``&lt;`` and shows as text, an
  unsafe ``[text](target)`` has its ``(`` escaped, and a link reference definition
  its ``[``: a ``[label]`` (escaped brackets allowed in it) followed by ``:``, at the
  start of a line or of the text, after any block quote and list markers (CommonMark reads
  a definition inside ``> `` and ``- `` too, and it defines the label for the whole page;
  the writer applies `markdown_text` to each whole line it composes, so its own ``:`` is
  seen). In HTML every string is escaped
  (`html.escape`) by the writer.

Inside a Markdown code span ``&lt;`` shows as written: a hostile string may render
oddly there, never as markup. The report's own text has none of these, so the committed
pages are unchanged.
"""

from __future__ import annotations

import re

__all__ = ["markdown_text", "safe_href"]

# A relative link inside the report: letters, digits and URL punctuation, nothing that
# can start a scheme (":"), an entity (";"), a tag or an attribute break.
_RELATIVE = re.compile(r"[A-Za-z0-9_.~/#?=&%+-]+")
# An http(s) address: a host, then characters that cannot break out of an attribute.
_HTTP = re.compile(r"https?://[A-Za-z0-9.-]+(:[0-9]{1,5})?([/?#][A-Za-z0-9_.~/#?=&%+:@!$,;*-]*)?")
# CommonMark raw HTML (open or closing tag, comment, declaration, processing instruction)
# and autolinks all start with "<" and one of these.
_TAG_START = re.compile(r"<(?=[A-Za-z/!?])")
# A Markdown inline link's "](" and its destination (up to a space or a parenthesis).
_MD_LINK = re.compile(r"\]\((\s*<?)([^\s()<>]*)")
# A link reference definition "[label]: ..." at the start of a line or of the text, after
# any block quote (">") and list ("-", "+", "*", "1.", "1)") markers: the "[" of a label
# (no unescaped bracket inside, backslash escapes allowed) that a ":" follows.
_MD_DEFINITION = re.compile(
    r"(?m)^((?:[ \t]*(?:>|(?:[-+*]|\d{1,9}[.)])(?=[ \t])))*[ \t]*)"
    r"\[(?=(?:[^\[\]\\]|\\[\s\S])*\]:)"
)


def safe_href(target: str) -> bool:
    """True when ``target`` may be a link of the report (relative inside it, or http(s))."""
    if _HTTP.fullmatch(target):
        return True
    if not _RELATIVE.fullmatch(target) or target.startswith("/"):
        return False
    path = re.split(r"[?#]", target, maxsplit=1)[0]
    return ".." not in path.split("/")


def _link(m: re.Match) -> str:
    return m[0] if not m[1].strip() and safe_href(m[2]) else "]\\(" + m[1] + m[2]


def markdown_text(text: str) -> str:
    """``text`` for a Markdown page: no raw HTML, no unsafe link, shown as written."""
    text = _TAG_START.sub("&lt;", str(text))
    text = _MD_LINK.sub(_link, text)
    return _MD_DEFINITION.sub(r"\1\\[", text)
