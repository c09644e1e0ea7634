"""Potential families: power laws, volumetric caps, user expressions, sums, saturating force.

Each family describes itself on its class (scene name, keys, label; contract item 7 of
`Potential`) and registers with `register_family`; importing its module here is the one
line that makes a new family known to scenes, ``hcv``, the report and adapters.
"""

from reference_impl.potentials._families import (
    FAMILIES,
    register_family,
    register_lazy_family,
    unregister_family,
)
from reference_impl.potentials.base import Potential, SumPotential, is_mp
from reference_impl.potentials.power import PowerLaw
from reference_impl.potentials.saturating import SaturatingForce
from reference_impl.potentials.volumetric import Ellipsoid, Sphere

register_family(SumPotential)  # defined in base (the sum of any families)
# `Expression` pulls in sympy (about 0.4 s of CPU): its module is imported on first use, by
# a scene naming the family or by the attribute below, so other families start without it.
register_lazy_family("expression", "reference_impl.potentials.expression")

__all__ = [
    "FAMILIES",
    "Ellipsoid",
    "Expression",
    "Potential",
    "PowerLaw",
    "SaturatingForce",
    "Sphere",
    "SumPotential",
    "is_mp",
    "register_family",
    "register_lazy_family",
    "unregister_family",
]


def __getattr__(name: str):
    if name == "Expression":
        from reference_impl.potentials.expression import Expression

        return Expression
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
