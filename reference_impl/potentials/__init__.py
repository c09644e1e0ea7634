"""Potential families: power laws, volumetric caps, user expressions, sums, saturating force.

Each family describes itself on its class (scene name, keys, label; contract item 7 of
`Potential`) and registers with `register_family`; importing its module here is the one
line that makes a new family known to scenes, ``hcv``, the report and adapters.
"""

from reference_impl.potentials._families import FAMILIES, register_family, unregister_family
from reference_impl.potentials.base import Potential, SumPotential, is_mp
from reference_impl.potentials.expression import Expression
from reference_impl.potentials.power import PowerLaw
from reference_impl.potentials.saturating import SaturatingForce
from reference_impl.potentials.volumetric import Ellipsoid, Sphere

register_family(SumPotential)  # defined in base (the sum of any families)

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
    "unregister_family",
]
