"""The damping-law table of the docs, generated from the registry when the site is built
(issue 37).

``docs/scenes.md`` and ``docs/adapter-protocol.md`` hold only the markers
``<!-- damping-laws:start -->`` and ``<!-- damping-laws:end -->``; Sphinx's
``source-read`` event (`fill_source`, connected in ``docs/conf.py``) puts the table of
every registered law between them as the page is read, so a new law's row appears with
no line written in any page and no copy can go stale.
``python -m reference_impl.theory.laws.docs_table`` prints the table;
``verification/test_laws_registry.py`` fails when a page holds a hand-written copy.
"""

from __future__ import annotations

import sys

from reference_impl.theory.laws._registry import LAWS

__all__ = ["DOC_PAGES", "END", "START", "fill_source", "law_table", "main", "render_page"]

START = "<!-- damping-laws:start -->"
END = "<!-- damping-laws:end -->"
# The pages that show the table, relative to the checkout's root.
DOC_PAGES = ("docs/scenes.md", "docs/adapter-protocol.md")


def law_table() -> str:
    """The Markdown table of every registered law, in registration order."""
    lines = [
        "| `law` | parameters [SI units] | C [kg/s] | solved exactly by; strength |",
        "|---|---|---|---|",
    ]
    for fam in LAWS.values():
        lines.append("| " + " | ".join(fam.docs_row()) + " |")
    return "\n".join(lines) + "\n"


def render_page(text: str, where: str = "page") -> str:
    """``text`` with the block between `START` and `END` replaced by `law_table`.

    Raises
    ------
    ValueError
        The page lacks the markers (or has them out of order).
    """
    i, j = text.find(START), text.find(END)
    if i < 0 or j < i:
        raise ValueError(f"{where}: no {START} ... {END} block")
    return text[: i + len(START)] + "\n" + law_table() + text[j:]


def fill_source(app, docname: str, source: list[str]) -> None:
    """Sphinx ``source-read`` handler: the law table into a page that has the markers.

    Parameters
    ----------
    app : sphinx.application.Sphinx
        Unused (the signature Sphinx calls).
    docname : str
        The page being read, e.g. ``"scenes"``.
    source : list of str
        One string, the page's text, replaced in place.
    """
    if START in source[0]:
        source[0] = render_page(source[0], docname)


def main(argv: list[str] | None = None) -> int:
    """Print the table (what the built pages show)."""
    sys.stdout.write(law_table())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
