"""Potential families: power laws, volumetric caps, user expressions, sums."""

from reference_impl.potentials.base import Potential, SumPotential, is_mp
from reference_impl.potentials.power import PowerLaw
from reference_impl.potentials.volumetric import Ellipsoid, Sphere

__all__ = ["Potential", "SumPotential", "PowerLaw", "Ellipsoid", "Sphere", "Expression", "is_mp"]


# `Expression` pulls in sympy (about 0.4 s of CPU): it loads on first use (PEP 562), so that
# the other families, and every scene that uses them, start without it.
def __getattr__(name: str):
    if name == "Expression":
        from reference_impl.potentials.expression import Expression

        return Expression
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
