"""Report blocks: the neutral structure the Markdown and HTML writers both format.

Each constructor returns a tuple (kind, ...) that `_render` turns into Markdown or
HTML; section builders return lists of them.
"""

from __future__ import annotations

import html

from reference_impl.report._common import g
from reference_impl.report._text import markdown_text as _t


# ----------------------------------------------------------------------------------
# blocks
# ----------------------------------------------------------------------------------
def H(level, text, anchor=None):
    return ("h", level, text, anchor)


def P(text, cls=None):
    return ("p", text, cls)


def T(headers, rows, flags=None, cls=None):
    """Table; flags[i][j] in {None, "bad", "good"} colours a cell."""
    return ("table", headers, rows, flags, cls)


def IMG(name, caption):
    return ("img", name, caption)


def UL(items):
    return ("ul", items)


def DETAILS(summary, blocks):
    return ("details", summary, blocks)


def _num(x, d=4):
    return (
        g(x, d)
        if not isinstance(x, (bool, str))
        else ("yes" if x is True else "no" if x is False else x)
    )


def _md_cell(s) -> str:
    return _t(str(s).replace("|", "\\|").replace("\n", " "))


def markdown_lines(blocks, out: list[str]) -> None:
    """Append the Markdown of ``blocks`` (the report's block tuples) to ``out``."""
    for b in blocks:
        kind = b[0]
        if kind == "h":
            out.append(f"{'#' * b[1]} {_t(b[2])}\n")
        elif kind == "p":
            out.append(("> " if b[2] == "warn" else "") + _t(b[1]) + "\n")
        elif kind == "table":
            _, headers, rows, flags, _cls = b
            out.append("| " + " | ".join(_md_cell(h) for h in headers) + " |")
            out.append("|" + "---|" * len(headers))
            for i, row in enumerate(rows):
                cells = []
                for j, c in enumerate(row):
                    f = flags[i][j] if flags else None
                    c = _md_cell(c)
                    cells.append(f"**{c}**" if f == "bad" and c else c)
                out.append("| " + " | ".join(cells) + " |")
            out.append("")
        elif kind == "img":
            out.append(f"![{_t(b[2])}](figures/{b[1]})\n\n*{_t(b[2])}*\n")
        elif kind == "ul":
            out += [f"- {_t(it)}" for it in b[1]] + [""]
        elif kind == "details":
            out.append(f"<details><summary>{html.escape(b[1])}</summary>\n")
            markdown_lines(b[2], out)
            out.append("</details>\n")
