"""Shared helpers of the report: JSON conversion, number formatting, claim-test lookup."""

from __future__ import annotations

from pathlib import Path

from reference_impl._format import g, jsonable
from reference_impl.claims import _scan
from reference_impl.claims._scan import SUITE_DIR

__all__ = ["SUITE_DIR", "claim_tests", "g", "jsonable", "records"]


def records(df) -> list[dict]:
    """DataFrame rows as JSON-ready dicts."""
    return [jsonable(r) for r in df.to_dict(orient="records")]


def claim_tests(suite_dir: Path = SUITE_DIR) -> dict[str, list[str]]:
    """claim id -> ``file::test`` names carrying its mark (the one scanner, `claims._scan`)."""
    return _scan.claim_tests(suite_dir)
