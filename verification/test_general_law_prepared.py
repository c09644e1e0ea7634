"""`prepare_law`: the general-law solver planned once per (potential, m, law) returns, at every
speed, the solution of `solve_law_impact` bit for bit, and refuses what it refuses."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings

from reference_impl import PowerLaw, prepare_law, solve_law_impact
from reference_impl.errors import HCVInputError
from verification.assertions import assert_true
from verification.strategies import law_cases

CALL = "prepare_law"
LAWS = ("linear", "power", "polynomial", "viscoelastic", "hunt-crossley", "universal")


def _same(a, b) -> bool:
    """Equal field by field, nan equal to nan (bit-identical floats compare equal)."""
    da, db = a.to_dict(), b.to_dict()
    return da.keys() == db.keys() and all(
        da[k] == db[k] or (isinstance(da[k], float) and math.isnan(da[k]) and math.isnan(db[k]))
        for k in da
    )


def _check(pot, m, v0, law):
    prepared = prepare_law(pot, m, law)
    for v in (v0, 0.5 * v0, 2.0 * v0):
        got, want = prepared(v), solve_law_impact(pot, m, v, law)
        assert_true(
            _same(got, want),
            got=str(got.to_dict()),
            should=f"solve_law_impact's {want.to_dict()} bit for bit",
            claim="general-law",
            call=f"{CALL}({pot!r}, {m!r}, {law})({v!r})",
        )


for _name in LAWS:

    @settings(max_examples=5)
    @given(case=law_cases(_name))
    def _test(case):
        _check(*case)

    _test.__name__ = f"test_prepared_equals_one_shot_{_name.replace('-', '_')}"
    globals()[_test.__name__] = _test


def test_the_closed_form_linear_oscillator_is_prepared_too():
    """Hooke with a constant dashpot near critical damping (issue 29's case): closed form."""
    pot = PowerLaw(1.0, 1.0)
    _check(pot, 1.0, 1.0, {"law": "linear", "c": 2.0 * 0.999})


def test_bad_input_is_refused_when_preparing():
    pot = PowerLaw(1e9, 1.5)
    for m, law, needle in (
        (-1.0, {"law": "linear", "c": 1.0}, "m"),
        (1.0, {"law": "linear", "c": -1.0}, "c"),
        (1.0, {"law": "hunt_crossley", "alpha": 1.0}, "hunt_crossley"),
        (1.0, {"law": "viscoelastic", "A": 1.0}, "viscoelastic"),
    ):
        with pytest.raises(HCVInputError, match=needle):
            prepare_law(PowerLaw(1e9, 0.5) if law["law"] == "viscoelastic" else pot, m, law)
    prepared = prepare_law(pot, 1.0, {"law": "linear", "c": 1.0})
    for v0 in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(HCVInputError, match="v0"):
            prepared(v0)
