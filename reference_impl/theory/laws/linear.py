"""Damping law ``linear``: a constant dashpot, C = c (kg/s)."""

from __future__ import annotations

from reference_impl.theory.laws._registry import Decomposition, LawFamily, Param, register_law

__all__ = ["Linear"]


@register_law
class Linear(LawFamily):
    """C = c: on Hooke's spring the linear oscillator (closed form)."""

    name = "linear"
    params = (Param("c", "N s/m"),)
    formula = "c"
    strength = "c"

    @classmethod
    def decompose(cls, params: dict) -> Decomposition:
        return Decomposition(terms=((params["c"], 0.0),))
