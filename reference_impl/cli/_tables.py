"""The tables that ``hcv solve`` and ``hcv dt-crit`` print: one column per speed (rich on a
terminal, full-width plain text otherwise), and their titles (`scene_title`)."""

from __future__ import annotations

import json
import os
import sys

__all__ = ["fmt", "print_transposed", "scene_title"]

# Cells up to this many characters set a plain-text column's width: a float at 10
# significant digits with sign and exponent is at most 17 ("-1.234567891e-300").
_NUMBER_WIDTH = 24


def scene_title(command: str, scene) -> str:
    """``hcv COMMAND: NAME (m = .. kg; potential FAMILY k = .., p = ..; damping LAW ..)``:
    every parameter that decides the answer (the potential's and the damping law's)."""
    from reference_impl.scenes import potential_to_dict

    pot = dict(potential_to_dict(scene.potential))
    family = pot.pop("family", "")
    law = dict(scene.law.to_dict())
    name = law.pop("law", "none")
    damping = f"damping {name}" + (f" {_params(law)}" if law else "")
    return f"hcv {command}: {scene.name} (m = {scene.mass:g} kg; potential {family} {_params(pot)}; {damping})"


def _params(d: dict) -> str:
    return ", ".join(
        f"{k} = {v:.10g}" if isinstance(v, float) else f"{k} = {json.dumps(v, default=str)}"
        for k, v in d.items()
    )


def print_transposed(title: str, rows: list[dict], fields, key: str, key_label: str) -> None:
    """One row per field, one column per result (keeps wide result sets readable).

    On a terminal a rich table; otherwise (a pipe, a file, a CI log) plain text at full
    width, as ``hcv bench`` prints, so that no number is ever cut to the console's width.
    rich is imported only where it may find a terminal (`_may_be_terminal`).
    """
    if not _may_be_terminal():
        _plain(title, rows, fields, key, key_label)
        return
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    console = Console()
    if not console.is_terminal:
        _plain(title, rows, fields, key, key_label)
        return
    table = Table(title=title)
    table.add_column(key_label, justify="left")
    for row in rows:
        table.add_column(fmt(row[key]), justify="right")
    for name, label in fields:
        # escape: rich would read units such as "[m]" or "[s]" as markup and drop them
        table.add_row(escape(label), *(fmt(row.get(name)) for row in rows))
    console.print(table)


def _may_be_terminal() -> bool:
    """False only where rich's ``Console().is_terminal`` is certain to be False: rich reads
    ``TTY_COMPATIBLE`` ("0": no, "1": yes), then a non-empty ``FORCE_COLOR`` (yes), then
    whether stdout is a tty. Its import (~0.05 s of CPU, issue 38 goal 7) is then skipped
    for a pipe, a file or a CI log, which it would print as plain text anyway."""
    env = os.environ
    if env.get("TTY_COMPATIBLE") == "0":
        return False
    if env.get("TTY_COMPATIBLE") == "1" or env.get("FORCE_COLOR"):
        return True
    isatty = getattr(sys.stdout, "isatty", None)
    try:
        return bool(isatty is not None and isatty())
    except ValueError:  # stdout closed: rich's own test says no terminal too
        return False


def _plain(title: str, rows: list[dict], fields, key: str, key_label: str) -> None:
    lines = [[key_label, *(fmt(r[key]) for r in rows)]]
    lines += [[label, *(fmt(r.get(name)) for r in rows)] for name, label in fields]
    # A column is as wide as its numbers; a long text cell (a criterion's description)
    # runs past it, left-aligned, instead of pushing every number of the column far right.
    widths = [max(len(line[0]) for line in lines)] + [
        max([len(line[i]) for line in lines if len(line[i]) <= _NUMBER_WIDTH] or [1])
        for i in range(1, len(lines[0]))
    ]
    out = [title]
    for j, line in enumerate(lines):
        cells = [line[0].ljust(widths[0])] + [
            c.rjust(w) if len(c) <= w else c for c, w in zip(line[1:], widths[1:], strict=True)
        ]
        out.append("  ".join(cells).rstrip())
        if j == 0:
            out.append("  ".join("-" * w for w in widths))
    sys.stdout.write("\n".join(out) + "\n")
    sys.stdout.flush()


def fmt(v) -> str:
    """A cell: floats to 10 significant digits, booleans as yes / NO, None as a dash."""
    if isinstance(v, float):
        return f"{v:.10g}"
    if isinstance(v, bool):
        return "yes" if v else "NO"
    return "—" if v is None else str(v)
