"""Damping law ``universal`` (Theorem 3): C = 2 zeta sqrt(m) U'(q) / sqrt(2 U(q)).

The one law whose restitution does not depend on the impact speed; solved exactly by
the harmonic map (`reference_impl.exact.solve`), its strength zeta from a restitution in
closed form (`reference_impl.theory.damping.zeta_from_restitution`).
"""

from __future__ import annotations

from reference_impl.theory.laws._registry import Decomposition, LawFamily, Param, register_law

__all__ = ["Universal"]


@register_law
class Universal(LawFamily):
    """The paper's law at damping ratio ``zeta`` (Tsuji's C ~ q^(1/4) on Hertz)."""

    name = "universal"
    params = (Param("zeta", "-"),)
    formula = "2ζ√m U′(q)/√(2U(q))"
    note = (
        "the paper's law; in a scene also `restitution` [-] with `restitution_end`, or "
        "`C0` [kg/s] with `K` [N/m] and `M` [kg]"
    )
    strength = "zeta"
    route = "harmonic map"

    @classmethod
    def harmonic_zeta(cls, params: dict) -> float:
        return params["zeta"]

    @classmethod
    def decompose(cls, params: dict) -> Decomposition:
        return Decomposition(zeta=params["zeta"])
