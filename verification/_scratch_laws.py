"""The scratch law of the change exercise (issue 37): C = c q^(1/4), Tsuji's exponent.

Two test modules register it at run time -- `verification/test_laws_registry.py` (the
registry's paths) and `verification/test_change_exercise.py` (the exercise end to end,
as a subclass with its own name, so the two never share a registry entry) -- and both
draw single examples of a strategy inside a test with `one_draw`.
"""

from __future__ import annotations

from hypothesis import Phase, given, settings
from hypothesis import strategies as st

from reference_impl.theory.laws import Decomposition, LawFamily, Param

__all__ = ["QuarterPower", "one_draw"]


class QuarterPower(LawFamily):
    """The change exercise: C = c q^(1/4) (Tsuji's exponent, any potential; route "general")."""

    name = "test-quarter"
    params = (Param("c", "N s m^-1.25"),)
    formula = "c q^(1/4)"
    strength = "c"

    @classmethod
    def decompose(cls, params):
        return Decomposition(terms=((params["c"], 0.25),))


def one_draw(strategy):
    """One example of ``strategy``, drawn inside a test (errors propagate as raised)."""
    out = []

    @settings(max_examples=1, database=None, phases=(Phase.generate,))
    @given(st.data())
    def run(data):
        out.append(data.draw(strategy))

    run()
    return out[0]
