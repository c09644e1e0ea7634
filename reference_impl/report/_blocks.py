"""Report blocks: the neutral structure the Markdown and HTML writers both format.

Each constructor returns a tuple (kind, ...) that `_render` turns into Markdown or
HTML; section builders return lists of them.
"""

from __future__ import annotations

from reference_impl.report._common import g


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
