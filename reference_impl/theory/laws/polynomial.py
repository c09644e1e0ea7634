"""Damping law ``polynomial``: C = sum_i c_i q^i."""

from __future__ import annotations

from reference_impl.theory.laws._registry import Decomposition, LawFamily, Param, register_law

__all__ = ["MAX_POLY_TERMS", "Polynomial"]

# Every user-controlled size is bounded: a polynomial of degree 15 is already far beyond any
# published impedance law; more terms would only cost time.
MAX_POLY_TERMS = 16


@register_law
class Polynomial(LawFamily):
    """C = c0 + c1 q + c2 q^2 + ...; a restitution scales every coefficient (the given
    ones are the shape)."""

    name = "polynomial"
    params = (Param("c", "N s m^-(1+i)", coefficients=True, max_len=MAX_POLY_TERMS),)
    formula = "Σ cᵢ qⁱ (`c = [c0, c1, ...]`)"
    strength = "c"
    shape_scaled = True

    @classmethod
    def decompose(cls, params: dict) -> Decomposition:
        return Decomposition(
            terms=tuple((c, float(i)) for i, c in enumerate(params["c"]) if c != 0.0)
        )

    @classmethod
    def example(cls, c_ref, q_ref, K, m, u) -> dict:
        # two or three terms, each of weight in [0, 1) at q_ref
        a = u[1:3] if u[0] < 0.5 else u[1:4]
        return {"c": [ai * c_ref / q_ref**i for i, ai in enumerate(a)]}
