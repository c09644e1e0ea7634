"""Damping law ``power``: C = c q^e."""

from __future__ import annotations

from reference_impl.theory.laws._registry import Decomposition, LawFamily, Param, register_law

__all__ = ["MAX_EXPONENT", "Power"]

# Largest damping exponent accepted: C ~ q^e with e > 20 is negligible over any contact that
# float64 resolves, and larger values only risk overflow.
MAX_EXPONENT = 20.0
# Exponents the tests' examples choose from (`Power.example`): constant, Tsuji's 1/4, ...
_EXAMPLE_EXPONENTS = (0.0, 0.25, 0.5, 1.0, 1.5)


@register_law
class Power(LawFamily):
    """C = c q^exponent (exponent 0: the linear law)."""

    name = "power"
    params = (Param("c", "N s m^-(1+e)"), Param("exponent", "-", high=MAX_EXPONENT))
    formula = "c q^e (e: `exponent`)"
    strength = "c"

    @classmethod
    def decompose(cls, params: dict) -> Decomposition:
        return Decomposition(terms=((params["c"], params["exponent"]),))

    @classmethod
    def strength_unit(cls, params: dict) -> str:
        return f"N s m^-{1.0 + params['exponent']:g}"

    @classmethod
    def example(cls, c_ref, q_ref, K, m, u) -> dict:
        e = _EXAMPLE_EXPONENTS[int(u[0] * len(_EXAMPLE_EXPONENTS))]
        return {"c": c_ref / q_ref**e, "exponent": e}
