"""Potential families: power laws, volumetric caps, user expressions, sums."""

from .base import Potential, SumPotential, is_mp
from .expression import Expression
from .power import PowerLaw
from .volumetric import Ellipsoid, Sphere

__all__ = ["Potential", "SumPotential", "PowerLaw", "Ellipsoid", "Sphere", "Expression", "is_mp"]
