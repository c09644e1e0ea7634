"""The rich tables that ``hcv solve`` and ``hcv dt-crit`` print: one column per speed."""

from __future__ import annotations

__all__ = ["fmt", "print_transposed"]


def print_transposed(title: str, rows: list[dict], fields, key: str, key_label: str) -> None:
    """One row per field, one column per result (keeps wide result sets readable)."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=title)
    table.add_column(key_label, justify="left")
    for row in rows:
        table.add_column(fmt(row[key]), justify="right")
    for name, label in fields:
        # escape: rich would read units such as "[m]" or "[s]" as markup and drop them
        table.add_row(escape(label), *(fmt(row.get(name)) for row in rows))
    Console().print(table)


def fmt(v) -> str:
    """A cell: floats to 10 significant digits, booleans as yes / NO, None as a dash."""
    if isinstance(v, float):
        return f"{v:.10g}"
    if isinstance(v, bool):
        return "yes" if v else "NO"
    return "—" if v is None else str(v)
