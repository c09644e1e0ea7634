"""Damping law ``hunt-crossley``: C = alpha U'(q)."""

from __future__ import annotations

from reference_impl.theory.laws._registry import Decomposition, LawFamily, Param, register_law

__all__ = ["HuntCrossley"]


@register_law
class HuntCrossley(LawFamily):
    """C = alpha U'(q): the force U' (1 + alpha q'), which never vanishes before q = 0
    (1 + alpha q' = (1 + alpha v0) exp(-(alpha/m) int U' dt) > 0), so the kernels search
    no zero-force instant (``never_pulls``)."""

    name = "hunt-crossley"
    params = (Param("alpha", "s/m"),)
    formula = "α U′(q)"
    strength = "alpha"

    @classmethod
    def decompose(cls, params: dict) -> Decomposition:
        return Decomposition(alpha=params["alpha"], never_pulls=True)
