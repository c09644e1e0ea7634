"""Reference implementation of the hidden-harmonic theory of contact dynamics."""

from reference_impl.exact.batch import solve_impacts
from reference_impl.theory.damping import (
    UniversalDamping,
    restitution_from_zeta,
    tsuji_coefficient,
    zeta_from_restitution,
)
from reference_impl.stability.criteria import (  # numba-free: the lane engine is imported by dtcrit only
    FAILURE_KINDS,
    MAX_CONFIRM_STEPS,
    MAX_FACTOR,
    MAX_LANES_PER_CALL,
    MAX_N_PHASES,
    MAX_N_STEPS,
    MAX_REFINE_POINTS,
    MAX_SCAN_POINTS,
    MAX_SPEEDS,
    MAX_TOL,
    EnergyGrowth,
    ImpactGain,
    SearchGrid,
    parse_criterion,
)
from reference_impl.errors import (
    DomainError,
    ExpressionError,
    HCVInputError,
    NonMonotoneError,
    NoTurningPointError,
    SceneError,
    UnsupportedError,
)
from reference_impl.theory.harmonic_map import HarmonicMap
from reference_impl.exact.solve import ImpactSolution, solve_impact, solve_impact_mp
from reference_impl.potentials import Ellipsoid, Expression, Potential, PowerLaw, Sphere, SumPotential
from reference_impl.scenes import Scene, embedded_scenes, load_scene, parse_scene
from reference_impl.stability.bound import SafeStep, dt_safe, dt_safe_shortcut, geometry_class, stiffening_indicator

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
    "UnsupportedError",
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
    # critical-step search: failure kinds, criteria and the bounds of user sizes
    "FAILURE_KINDS",
    "MAX_CONFIRM_STEPS",
    "MAX_FACTOR",
    "MAX_LANES_PER_CALL",
    "MAX_N_PHASES",
    "MAX_N_STEPS",
    "MAX_REFINE_POINTS",
    "MAX_SCAN_POINTS",
    "MAX_SPEEDS",
    "MAX_TOL",
    "EnergyGrowth",
    "ImpactGain",
    "SearchGrid",
    "parse_criterion",
]
