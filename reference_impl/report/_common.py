"""Shared helpers of the report: JSON conversion, number formatting, claim-test lookup."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np

# verification/ next to the package (a source checkout); absent in an installed wheel.
SUITE_DIR = Path(__file__).resolve().parents[2] / "verification"


def jsonable(x):
    """Plain JSON value: NaN -> None, +-inf -> "inf"/"-inf", numpy scalars and arrays unwrapped."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return [jsonable(v) for v in x.tolist()]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        x = float(x)
        if math.isnan(x):
            return None
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return x
    if x is None or isinstance(x, str):
        return x
    return str(x)


def records(df) -> list[dict]:
    """DataFrame rows as JSON-ready dicts."""
    return [jsonable(r) for r in df.to_dict(orient="records")]


def g(x, digits: int = 3) -> str:
    """Short number: ``g(1.2345e-13) == '1.23e-13'``; NaN/None -> '–'."""
    if x is None:
        return "–"
    if isinstance(x, str):
        return x
    x = float(x)
    if math.isnan(x):
        return "–"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e5:
        return f"{x:.0f}" if abs(x) >= 10**digits else f"{x:.{digits}g}"
    mant, exp = f"{x:.{max(digits - 1, 0)}e}".split("e")
    if "." in mant:
        mant = mant.rstrip("0").rstrip(".")
    return f"{mant}e{int(exp)}"


def claim_tests(suite_dir: Path = SUITE_DIR) -> dict[str, list[str]]:
    """claim id -> test modules carrying ``pytest.mark.claim("<id>")``.

    Read with ``ast`` (as verification/test_meta.py does); a marker whose argument
    is a module-level name bound to a string (``claim(CLAIM)``) is resolved too.
    Empty when the suite is not next to the package.
    """
    out: dict[str, set[str]] = {}
    if not suite_dir.is_dir():
        return {}
    for path in sorted(suite_dir.glob("test_*.py")):
        try:
            tree = ast.parse(path.read_text(), filename=str(path))
        except (OSError, SyntaxError):
            continue
        names = {}
        for node in tree.body:
            if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant)
                    and isinstance(node.value.value, str)):
                for tgt in node.targets:
                    if isinstance(tgt, ast.Name):
                        names[tgt.id] = node.value.value
        for node in ast.walk(tree):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr == "claim" and node.args):
                arg = node.args[0]
                cid = None
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    cid = arg.value
                elif isinstance(arg, ast.Name):
                    cid = names.get(arg.id)
                if cid:
                    out.setdefault(cid, set()).add(path.name)
    return {k: sorted(v) for k, v in out.items()}
