"""The HTML writer of the report's blocks: self-contained (CSS and images inline).

`html_lines` formats the blocks of `reference_impl.report._blocks` as
`reference_impl.report._blocks.markdown_lines` does for Markdown; `reference_impl.report._render`
builds the sections and the page around them.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

from reference_impl.report._inputs import figure_bytes
from reference_impl.report._text import safe_href

__all__ = ["CSS", "html_lines"]

# Wide tables (the contact codes side by side: 4400 px) scroll inside their own box, so the
# page itself never scrolls sideways at 1280 px (issue 31; verification/test_browser.py).
CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;max-width:1280px;
margin:1.5em auto;padding:0 1em;color:#1a1a1a;line-height:1.45}
h1{font-size:1.55em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:1.8em}
table{border-collapse:collapse;margin:.8em 0;font-size:.86em}
table{display:block;overflow-x:auto;max-width:100%}
th,td{border:1px solid #ccc;padding:.25em .5em;vertical-align:top;text-align:left}
th{background:#f2f2f2}td.bad{background:#fde0dc;color:#8a1c12;font-weight:600}
td.good{background:#e3f4e1}td.warn{background:#fff3cd}
table.ledger td:nth-child(3){white-space:nowrap;font-weight:700}
p.warn{background:#fff3cd;padding:.5em;border-left:4px solid #e0a800}
figure{margin:1em 0}figure img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.9em;color:#444}details{margin:.6em 0}summary{cursor:pointer;color:#124}
code{background:#f4f4f4;padding:0 .2em}nav a{margin-right:1em}
"""


# A Markdown link [text](target) of the blocks' text (the erratum names its scripts so).
_LINK = re.compile(r"\[([^\[\]]+)\]\(([^()\s]+)\)")


def _anchor(m: re.Match) -> str:
    """An escaped [text](target) as a link when the target is safe, else left as text."""
    return f'<a href="{m[2]}">{m[1]}</a>' if safe_href(html.unescape(m[2])) else m[0]


def _inline(text: str) -> str:
    """Escape, then render `code` spans and [text](target) links (outside code spans);
    a link whose target is not `safe_href` (javascript:, data:, ...) stays plain text."""
    parts = html.escape(text).split("`")
    return "".join(
        f"<code>{p}</code>" if i % 2 else _LINK.sub(_anchor, p) for i, p in enumerate(parts)
    )


def html_lines(blocks, fig_dir: Path, out: list[str]) -> None:
    """Append the HTML of ``blocks`` to ``out``; images are read from ``fig_dir`` (only the
    report's own regular PNG files: `reference_impl.report._inputs.figure_bytes`)."""
    for b in blocks:
        kind = b[0]
        if kind == "h":
            aid = f' id="{b[3]}"' if b[3] else ""
            out.append(f"<h{b[1]}{aid}>{_inline(b[2])}</h{b[1]}>")
        elif kind == "p":
            cls = f' class="{b[2]}"' if b[2] else ""
            out.append(f"<p{cls}>{_inline(b[1])}</p>")
        elif kind == "table":
            _, headers, rows, flags, cls = b
            c = f' class="{cls}"' if cls else ""
            out.append(
                f"<table{c}><thead><tr>"
                + "".join(f"<th>{_inline(h)}</th>" for h in headers)
                + "</tr></thead><tbody>"
            )
            for i, row in enumerate(rows):
                tds = []
                for j, cell in enumerate(row):
                    f = flags[i][j] if flags else None
                    fc = f' class="{f}"' if f else ""
                    tds.append(f"<td{fc}>{_inline(str(cell))}</td>")
                out.append("<tr>" + "".join(tds) + "</tr>")
            out.append("</tbody></table>")
        elif kind == "img":
            # Only the report's own regular PNG files, whatever name reached the block.
            png = figure_bytes(fig_dir, b[1], f"figure of the section {b[2][:40]!r}")
            data = base64.b64encode(png).decode("ascii")
            out.append(
                f'<figure><img src="data:image/png;base64,{data}" '
                f'alt="{html.escape(b[2])}"><figcaption>{_inline(b[2])}</figcaption>'
                f"</figure>"
            )
        elif kind == "ul":
            out.append("<ul>" + "".join(f"<li>{_inline(it)}</li>" for it in b[1]) + "</ul>")
        elif kind == "details":
            out.append(f"<details><summary>{_inline(b[1])}</summary>")
            html_lines(b[2], fig_dir, out)
            out.append("</details>")
