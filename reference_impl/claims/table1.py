"""Table 1 (section 10): delta_max, U'(delta_max) and Delta t_safe of the paper ellipsoid."""

from __future__ import annotations

import functools

from reference_impl.claims._base import Measurement
from reference_impl.studies.paper import TABLE1_PRINTED, table1_cells

ID = "table1"
SECTION = "10 (Table 1)"
STATEMENT = (
    "For the ellipsoid (a=0.015, b=c=0.008 m, m=0.05 kg, Kn=1e8, alpha=0.5) and v0 = 0.50, "
    "0.99, 1.50 m/s: delta_max, U'(delta_max) and Delta t_safe are as printed in Table 1."
)

# The statement as printed (where, equation number or None, LaTeX; whitespace-normalised),
# checked verbatim against the paper's .tex by verification/test_tools_erratum.py.
PRINTED = (
    "section 10, Table 1",
    None,
    r"Theoretical lower bounds for the critical timestep ($\Delta t_{\text{safe}}$) evaluated at "
    r"maximum compression for the ellipsoid impact scenarios.",
)

NAMES = {"delta_max": "δmax", "max_force": "U'(δmax)", "dt_safe": "Δt_safe"}
# A cell matches when the 50-digit value rounds to the printed digits (half a unit of the
# last printed digit): the recomputation itself is exact to far more digits.


@functools.cache
def cells() -> dict:
    """(v0 string, column) -> Table1Cell recomputed at 50 digits."""
    return {(c.v0, c.column): c for c in table1_cells()}


def describe(cell) -> str:
    """One line on a cell, from its computed and printed values."""
    return (
        f"v0 = {cell.v0} {NAMES[cell.column]} computed {cell.computed_rounded} vs printed "
        f"{cell.printed} {cell.unit} ({cell.difference_in_last_digit:+.2f} units of the last "
        f"digit)"
    )


@functools.cache
def measure(quick: bool = False) -> Measurement:
    """Refuted if any cell, rounded to the printed digits, differs from the printed value.

    ``figures["rows"]`` holds one row per speed (each column printed / computed /
    match / difference in units of the printed last digit).
    """
    by_v: dict[str, dict] = {v: {"v0": v} for v in TABLE1_PRINTED}
    bad = []
    for c in cells().values():
        d = c.to_dict()
        by_v[c.v0][c.column] = {
            k: d[k]
            for k in (
                "unit",
                "printed",
                "computed",
                "computed_rounded",
                "match",
                "difference_in_last_digit",
            )
        }
        if not c.match:
            bad.append(c)
    n = len(cells())
    if bad:
        evidence = f"{len(bad)} of {n} cells differ at the printed digits: " + "; ".join(
            describe(c) for c in bad
        )
    else:
        evidence = f"all {n} cells match at the printed digits (50-digit recomputation)"
    counter = (
        {
            "cells": [
                {
                    "v0": c.v0,
                    "column": c.column,
                    "printed": c.printed,
                    "computed_rounded": c.computed_rounded,
                }
                for c in bad
            ]
        }
        if bad
        else None
    )
    return Measurement(
        ID,
        "refuted" if bad else "verified",
        evidence,
        "refuted if any computed cell, rounded to the printed digits, differs "
        "from the printed value",
        {"mismatches": len(bad), "cells": n, "rows": list(by_v.values())},
        counter,
        headline=(
            f"{len(bad)} of {n} cells differ at the printed digits"
            + (" (" + ", ".join(f"v0 = {c.v0} {NAMES[c.column]}" for c in bad) + ")" if bad else "")
        ),
    )


def corrected(m: dict, r: dict | None = None) -> tuple[str, str]:
    """This claim's erratum: the contract is `reference_impl.claims.Claim.corrected`."""
    cells = []
    for row in m["rows"]:
        for col, name in (
            ("delta_max", "δmax [mm]"),
            ("max_force", "U'(δmax) [N]"),
            ("dt_safe", "Δt_safe [ms]"),
        ):
            cell = row[col]
            if not cell["match"]:
                cells.append(
                    f"v0 = {row['v0']} m/s, {name}: {cell['printed']} → {cell['computed_rounded']}"
                )
    return (
        "Corrected cells (recomputed at 50 digits from the printed inputs, rounded to the "
        "printed decimals; every digit shown is certain): " + "; ".join(cells) + ".",
        f"{m['mismatches']} of {m['cells']} cells differ; computed to 15 digits: "
        + "; ".join(
            f"v0 = {row['v0']}: "
            + ", ".join(row[c]["computed"] for c in ("delta_max", "max_force", "dt_safe"))
            for row in m["rows"]
        )
        + ".",
    )
