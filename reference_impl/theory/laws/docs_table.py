"""The damping-law table of the docs, generated from the registry (issue 37).

``docs/scenes.md`` and ``docs/adapter-protocol.md`` hold the table between the markers
``<!-- damping-laws:start -->`` and ``<!-- damping-laws:end -->``;
``python -m reference_impl.theory.laws.docs_table`` writes it there from `LAWS` (each
law's `LawFamily.docs_row`), ``--check`` exits 1 when a page differs, and
``verification/test_laws_registry.py`` fails when one does. The table is nowhere
written by hand.
"""

from __future__ import annotations

import sys
from pathlib import Path

from reference_impl.theory.laws._registry import LAWS

__all__ = ["DOC_PAGES", "END", "START", "law_table", "main", "render_page"]

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


def main(argv: list[str] | None = None) -> int:
    """Write the table into `DOC_PAGES` (``--check``: only say which differ; status 1)."""
    args = sys.argv[1:] if argv is None else argv
    check = "--check" in args
    root = Path(__file__).resolve().parents[3]
    stale = []
    for rel in DOC_PAGES:
        path = root / rel
        old = path.read_text(encoding="utf-8")
        new = render_page(old, rel)
        if new != old:
            stale.append(rel)
            if not check:
                path.write_text(new, encoding="utf-8")
    for rel in stale:
        print(f"{rel}: {'differs from the registry' if check else 'written'}")
    return 1 if check and stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
