"""Shared helpers of the report: JSON conversion, number formatting, claim-test lookup."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from reference_impl.claims import _scan
from reference_impl.claims._base import g
from reference_impl.claims._scan import SUITE_DIR

__all__ = ["SUITE_DIR", "claim_tests", "g", "jsonable", "records"]


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


def claim_tests(suite_dir: Path = SUITE_DIR) -> dict[str, list[str]]:
    """claim id -> ``file::test`` names carrying its mark (the one scanner, `claims._scan`)."""
    return _scan.claim_tests(suite_dir)
