"""Reference implementation of the hidden-harmonic theory of contact dynamics."""

from .batch import solve_impacts
from .damping import (
    UniversalDamping,
    restitution_from_zeta,
    tsuji_coefficient,
    zeta_from_restitution,
)
from .errors import (
    DomainError,
    ExpressionError,
    HCVInputError,
    NonMonotoneError,
    NoTurningPointError,
    SceneError,
)
from .harmonic_map import HarmonicMap
from .impact import ImpactSolution, solve_impact, solve_impact_mp
from .potentials import Ellipsoid, Expression, Potential, PowerLaw, Sphere, SumPotential
from .scenes import Scene, embedded_scenes, load_scene, parse_scene
from .stability import SafeStep, dt_safe, dt_safe_shortcut, geometry_class, stiffening_indicator

__all__ = [
    "DomainError",
    "Ellipsoid",
    "Expression",
    "ExpressionError",
    "HCVInputError",
    "HarmonicMap",
    "ImpactSolution",
    "NoTurningPointError",
    "NonMonotoneError",
    "Potential",
    "PowerLaw",
    "SafeStep",
    "Scene",
    "SceneError",
    "Sphere",
    "SumPotential",
    "UniversalDamping",
    "dt_safe",
    "dt_safe_shortcut",
    "embedded_scenes",
    "geometry_class",
    "load_scene",
    "parse_scene",
    "restitution_from_zeta",
    "solve_impact",
    "solve_impact_mp",
    "solve_impacts",
    "stiffening_indicator",
    "tsuji_coefficient",
    "zeta_from_restitution",
]
