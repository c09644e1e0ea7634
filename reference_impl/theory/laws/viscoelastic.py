"""Damping law ``viscoelastic``: C = A U''(q) (Kuwabara-Kono / Brilliantov)."""

from __future__ import annotations

from reference_impl.theory.laws._registry import Decomposition, LawFamily, Param, register_law

__all__ = ["Viscoelastic"]


@register_law
class Viscoelastic(LawFamily):
    """C = A U''(q): the force A d/dt U'(q); needs U'' finite at contact (p >= 1)."""

    name = "viscoelastic"
    params = (Param("A", "s"),)
    formula = "A U″(q)"
    note = "Kuwabara–Kono / Brilliantov: force A d/dt U′(q); needs U″ finite at 0 (p ≥ 1)"
    strength = "A"

    @classmethod
    def decompose(cls, params: dict) -> Decomposition:
        return Decomposition(A=params["A"])
