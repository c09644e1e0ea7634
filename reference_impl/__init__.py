"""Reference implementation of the hidden-harmonic theory of contact dynamics."""

from .damping import UniversalDamping, restitution_from_zeta, tsuji_coefficient, zeta_from_restitution
from .errors import (
    DomainError,
    ExpressionError,
    HCVInputError,
    NonMonotoneError,
    NoTurningPointError,
    SceneError,
)
from .harmonic_map import HarmonicMap
from .potentials import Ellipsoid, Potential, PowerLaw, Sphere, SumPotential
from .stability import SafeStep, dt_safe, dt_safe_shortcut, geometry_class, stiffening_indicator

__all__ = [
    "DomainError",
    "Ellipsoid",
    "ExpressionError",
    "HCVInputError",
    "HarmonicMap",
    "NoTurningPointError",
    "NonMonotoneError",
    "Potential",
    "PowerLaw",
    "SafeStep",
    "SceneError",
    "Sphere",
    "SumPotential",
    "UniversalDamping",
    "dt_safe",
    "dt_safe_shortcut",
    "geometry_class",
    "restitution_from_zeta",
    "stiffening_indicator",
    "tsuji_coefficient",
    "zeta_from_restitution",
]
