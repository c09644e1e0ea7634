"""The general-law solver's short cuts (issue 38, goal 4) give what the long way gives, bit for
bit, and refuse what it refuses, in the same line.

* `general_law._top`: a `PowerLaw`'s turning point formed inline, against
  `_validate._validated_top` (numpy's power, not Python's: they differ in the last bit for a
  few per cent of arguments on AVX-512 machines, so a Python ``**`` here would fail);
* the solution filled without the frozen dataclass's ``__init__``, against that ``__init__``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from reference_impl import PowerLaw
from reference_impl.errors import HCVInputError
from reference_impl.exact import general_law as gl
from reference_impl.exact._law_table import fast_law
from reference_impl.exact._validate import _validated_top
from reference_impl.theory.laws import law_from_dict
from verification.assertions import assert_true

M = 0.1


@pytest.mark.parametrize("p", [1.5, 1.0, 2.0, 0.5, 3.0])
def test_inline_turning_point_is_validated_top_bit_for_bit(p):
    """p = 1 takes numpy's square root (``** 0.5``), the others its vectorised power."""
    pot = PowerLaw(1e6, p)
    plan = gl._plan(pot, M, {"law": "hunt-crossley", "alpha": 0.3})
    energies = 10.0 ** np.random.default_rng(7).uniform(-12.0, 6.0, 3000)
    bad = [E for E in energies.tolist() if gl._top(plan, E) != _validated_top(pot, E)]
    assert_true(
        not bad,
        got=f"{len(bad)} energies whose turning point differs, first {bad[:1]}",
        should="none (the inline inverse is PowerLaw._inverse's operations)",
        claim="general-law",
        call=f"_top(plan of {pot!r}, E)",
    )


def test_a_subclass_of_power_law_keeps_its_own_inverse():
    class Doubled(PowerLaw):
        def _inverse(self, u):
            return 2.0 * super()._inverse(u)

    plan = gl._plan(Doubled(1e6, 1.5), M, {"law": "linear", "c": 3.0})
    assert_true(
        plan.inv is None,
        got=str(plan.inv),
        should="None (only PowerLaw itself is inverted inline)",
        claim="general-law",
        call="_plan(Doubled(...))",
    )


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # the checked inverse's
def test_a_turning_point_out_of_float_range_is_refused_as_before():
    """k = 1e-300 at 1e6 m/s: n E / k overflows; the inline inverse hands it to the check."""
    pot = PowerLaw(1e-300, 1.5)
    E = 0.5 * M * 1e6 * 1e6
    with pytest.raises(HCVInputError) as want:
        _validated_top(pot, E)
    with pytest.raises(HCVInputError) as got:
        gl.solve_law_impact(pot, M, 1e6, {"law": "linear", "c": 3.0})
    assert_true(
        str(got.value) == str(want.value),
        got=str(got.value),
        should=str(want.value),
        claim="general-law",
        call=f"solve_law_impact({pot!r}, {M}, 1e6, linear)",
    )


@pytest.mark.parametrize(
    "law", [{"law": "linear", "c": 30.0}, {"law": "hunt-crossley", "alpha": 0.3}]
)
def test_the_solution_is_the_dataclass_built_by_its_init(law):
    sol = gl.solve_law_impact(PowerLaw(1e6, 1.5), M, 0.7, law)
    names = [f.name for f in dataclasses.fields(gl.LawImpactSolution)]
    built = gl.LawImpactSolution(**{k: getattr(sol, k) for k in names})
    same = (
        list(vars(sol)) == names
        and not hasattr(gl.LawImpactSolution, "__post_init__")
        and sol == built
        and repr(sol) == repr(built)
        and all(math.isfinite(getattr(sol, k)) for k in ("contact_time", "restitution"))
    )
    assert_true(
        same,
        got=repr(sol),
        should=f"{built!r}, fields in the dataclass's order",
        claim="general-law",
        call=f"solve_law_impact(Hertz, {M}, 0.7, {law})",
    )
    with pytest.raises(dataclasses.FrozenInstanceError):
        sol.contact_time = 1.0


# Every registered family's table (as scenes give it) and one of each value the checks refuse.
_TABLES = [
    {"law": "none"},
    {"law": "universal", "zeta": 0.3},
    {"law": "linear", "c": 30.0},
    {"law": "linear", "c": 0.0},
    {"law": "power", "c": 2.0, "exponent": 0.25},
    {"law": "power", "exponent": 0.5, "c": 2.0},  # keys in another order
    {"law": "viscoelastic", "A": 1e-4},
    {"law": "hunt-crossley", "alpha": 0.3},
]
_REFUSED = [math.nan, math.inf, -math.inf, -1.0, -1e-300, True, "30", None, [30.0]]


@pytest.mark.parametrize("table", _TABLES, ids=lambda t: "-".join(map(str, t.values())))
def test_fast_law_is_law_from_dict(table):
    got, want = fast_law(table), law_from_dict(table)
    same = (
        got is not None
        and got == want
        and list(got.params) == list(want.params)
        and got.decomposition() == want.decomposition()
        and got.to_dict() == want.to_dict()
        and vars(got) == vars(want)
    )
    assert_true(
        same,
        got=repr(got),
        should=f"{want!r} with its decomposition {want.decomposition()}",
        claim="general-law",
        call=f"fast_law({table})",
    )


@pytest.mark.parametrize(
    "table",
    [
        {"law": "polynomial", "c": [1.0, 2.0]},  # coefficient lists: the long way
        {"law": "linear", "c": 30},  # an int: law_from_dict makes it a float
        {"law": "linear", "c": np.float64(30.0)},
        {"c": 30.0},  # no name: law "none", which refuses c
        {"law": "linear", "c": 30.0, "alpha": 0.1},
        {"law": "linear"},
        {"law": "lineer", "c": 30.0},
        {"law": 3, "c": 30.0},
    ],
    ids=str,
)
def test_fast_law_leaves_the_rest_to_law_from_dict(table):
    assert_true(
        fast_law(table) is None,
        got=repr(fast_law(table)),
        should="None (law_from_dict builds or refuses it)",
        claim="general-law",
        call=f"fast_law({table})",
    )


@pytest.mark.parametrize("value", _REFUSED, ids=repr)
def test_a_refused_value_gets_the_same_one_line(value):
    """The one-shot call refuses as law_from_dict refuses, in one line naming the value."""
    table = {"law": "hunt-crossley", "alpha": value}
    with pytest.raises(HCVInputError) as want:
        law_from_dict(table)
    with pytest.raises(HCVInputError) as got:
        gl.solve_law_impact(PowerLaw(1e6, 1.5), M, 1.0, table, rtol=1e-8)
    msg = str(got.value)
    assert_true(
        fast_law(table) is None and msg == str(want.value),
        got=msg,
        should=str(want.value),
        claim="general-law",
        call=f"solve_law_impact(Hertz, {M}, 1.0, {table})",
    )
    assert_true(
        "\n" not in msg and repr(value) in msg,
        got=msg,
        should=f"one line naming {value!r}",
        claim="general-law",
        call=f"solve_law_impact(Hertz, {M}, 1.0, {table})",
    )


@pytest.mark.parametrize("rtol", [None, 1e-8])
def test_a_body_that_never_returns_keeps_its_fields(rtol):
    """The universal law at zeta = 1.4 on Hertz creeps back and never reaches q = 0 (the
    kernel stops on the overlap; `_refuse_lost_return` lets it pass): the fields of that
    row are reported, not refused or left void (an early version of the compiled fields
    returned NaN there, and no other test saw it)."""
    pot, law = PowerLaw(1e6, 1.5), {"law": "universal", "zeta": 1.396390548343099}
    sol = gl.solve_law_impact(pot, M, 1.728698069272725, law, rtol=rtol)
    ok = (
        sol.returns_to_q0 is False
        and sol.contact_time == math.inf
        and sol.restitution == 0.0
        and 0.0 < sol.time_of_max_penetration < sol.contact_time_zero_force < math.inf
        and 0.0 < sol.restitution_zero_force < 1.0
        and 0.0 < sol.max_penetration < math.inf
        and 0.0 < sol.error_time < math.inf
        and sol.n_steps > 0
    )
    assert_true(
        ok,
        got=str(sol.to_dict()),
        should="no return, contact time inf, finite zero-force end and bounds",
        claim="general-law",
        call=f"solve_law_impact({pot!r}, {M}, 1.7287, {law}, rtol={rtol})",
    )
