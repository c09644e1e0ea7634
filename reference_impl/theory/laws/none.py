"""Damping law ``none``: C = 0, the conservative impact (restitution 1)."""

from __future__ import annotations

from reference_impl.theory.laws._registry import Decomposition, LawFamily, register_law

__all__ = ["NoDamping"]


@register_law
class NoDamping(LawFamily):
    """C = 0: the universal law at zeta = 0, solved by the harmonic map."""

    name = "none"
    formula = "0"
    route = "harmonic map"

    @classmethod
    def harmonic_zeta(cls, params: dict) -> float:
        return 0.0

    @classmethod
    def decompose(cls, params: dict) -> Decomposition:
        return Decomposition()
