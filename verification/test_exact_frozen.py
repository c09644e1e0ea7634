"""The exact solver's outputs, frozen bit for bit (issue 27, goal 7: one source per loop).

The quadrature loops of `reference_impl.exact` (tanh-sinh and Gauss-Jacobi sums) are
refactored to one source each; a refactoring must not move a single bit of any result.
`_exact_frozen_cases` names one scene per path through those loops and
`_exact_frozen.json` holds what the code gave before (every float field of the solution
as a hex float, the trajectory at a few times, or the refusal's message). Accuracy
against the truth is held elsewhere (test_exact_accuracy, test_exact_families); this
test holds that nothing changed. Regenerate the data only for a change meant to move
results, and say so in its commit.
"""

from __future__ import annotations

import json

import pytest

from verification._exact_frozen_cases import CASES, DATA_FILE, key, outputs
from verification.assertions import assert_true


@pytest.mark.parametrize("case", CASES, ids=[key(c) for c in CASES])
def test_exact_outputs_are_frozen(case):
    got = outputs(case)
    want = json.loads(DATA_FILE.read_text())[key(case)]
    diff = [(g, w) for g, w in zip(got, want, strict=False) if g != w]
    assert_true(
        got == want,
        got=f"{len(diff)} of {len(want)} values differ, first {diff[:3]}",
        should="every value bit for bit as frozen",
        claim="solve_impact",
        call=f"solve_impact({key(case)})",
    )
