"""Meta-tests: every registered claim has a test and every tag names a claim.

The tags are read from the test sources with ``ast`` so that the check does not
depend on which tests a run selected.
"""

from __future__ import annotations

import ast
from pathlib import Path

from verification.assertions import assert_true
from verification.claims import CLAIMS, claim_ids

HERE = Path(__file__).parent


def _claim_tags() -> dict[str, list[str]]:
    tags: dict[str, list[str]] = {}
    for path in sorted(HERE.glob("test_*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == "claim"
                and node.args
                and isinstance(node.args[0], ast.Constant)
            ):
                tags.setdefault(node.args[0].value, []).append(path.name)
    return tags


def test_every_claim_has_a_test():
    tags = _claim_tags()
    missing = [c.id for c in CLAIMS if c.id not in tags]
    assert_true(
        not missing,
        got=f"claims without tests {missing}",
        should="none",
        claim="meta",
        call="_claim_tags()",
    )


def test_every_tag_names_a_claim():
    unknown = {t: f for t, f in _claim_tags().items() if t not in set(claim_ids())}
    assert_true(
        not unknown,
        got=f"unknown tags {unknown}",
        should="none",
        claim="meta",
        call="_claim_tags()",
    )


def test_claim_ids_unique():
    ids = claim_ids()
    assert_true(
        len(ids) == len(set(ids)),
        got=f"{len(ids)} ids, {len(set(ids))} distinct",
        should="all distinct",
        claim="meta",
        call="claim_ids()",
    )
