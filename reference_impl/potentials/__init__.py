"""Potential families: power laws, volumetric caps, user expressions, sums."""

from reference_impl.potentials.base import Potential, SumPotential, is_mp
from reference_impl.potentials.expression import Expression
from reference_impl.potentials.power import PowerLaw
from reference_impl.potentials.volumetric import Ellipsoid, Sphere

__all__ = ["Potential", "SumPotential", "PowerLaw", "Ellipsoid", "Sphere", "Expression", "is_mp"]
