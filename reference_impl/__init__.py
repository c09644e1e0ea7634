"""Reference implementation of the hidden-harmonic theory of contact dynamics.

Public names load on first use (PEP 562 ``__getattr__``): ``import reference_impl``
imports no numerical library, so the ``hcv`` command parses its arguments and
refuses bad ones at once; ``from reference_impl import solve_impact`` imports the
exact solver (numba, scipy, sympy) then.
"""

from __future__ import annotations

import importlib
import importlib.util

from reference_impl._cache import configure_numba_cache
from reference_impl._version import __version__ as __version__
from reference_impl._version import version as version

# Before anything imports numba: its disk cache goes to the per-user cache directory
# (reference_impl._cache; a user's NUMBA_CACHE_DIR wins).
configure_numba_cache()

# Public name -> the module that defines it. Read by __getattr__; the modules are imported
# only when one of their names is first asked for.
_EXPORTS = {
    "solve_impacts": "reference_impl.exact.batch",
    "UniversalDamping": "reference_impl.theory.damping",
    "restitution_from_zeta": "reference_impl.theory.damping",
    "tsuji_coefficient": "reference_impl.theory.damping",
    "zeta_from_restitution": "reference_impl.theory.damping",
    # numba-free: the lane engine is imported by the critical-step search only
    "FAILURE_KINDS": "reference_impl.stability.criteria",
    "MAX_CONFIRM_STEPS": "reference_impl.stability.criteria",
    "MAX_FACTOR": "reference_impl.stability.criteria",
    "MAX_LANES_PER_CALL": "reference_impl.stability.criteria",
    "MAX_N_PHASES": "reference_impl.stability.criteria",
    "MAX_N_STEPS": "reference_impl.stability.criteria",
    "MAX_REFINE_POINTS": "reference_impl.stability.criteria",
    "MAX_SCAN_POINTS": "reference_impl.stability.criteria",
    "MAX_SPEEDS": "reference_impl.stability.criteria",
    "MAX_TOL": "reference_impl.stability.criteria",
    "EnergyGrowth": "reference_impl.stability.criteria",
    "ImpactGain": "reference_impl.stability.criteria",
    "SearchGrid": "reference_impl.stability.criteria",
    "parse_criterion": "reference_impl.stability.criteria",
    "DomainError": "reference_impl.errors",
    "ExpressionError": "reference_impl.errors",
    "HCVInputError": "reference_impl.errors",
    "NonMonotoneError": "reference_impl.errors",
    "NoTurningPointError": "reference_impl.errors",
    "SceneError": "reference_impl.errors",
    "UnsupportedError": "reference_impl.errors",
    "HarmonicMap": "reference_impl.theory.harmonic_map",
    "ImpactSolution": "reference_impl.exact.solve",
    "solve_impact": "reference_impl.exact.solve",
    "solve_impact_mp": "reference_impl.exact.solve",
    "PreparedImpact": "reference_impl.exact.prepared",
    # the one exact entry point (issue 37): solve, solve_batch, prepare
    "solve": "reference_impl.exact.api",
    "solve_batch": "reference_impl.exact.api",
    "prepare": "reference_impl.exact.api",
    "Ellipsoid": "reference_impl.potentials",
    "Expression": "reference_impl.potentials",
    "Potential": "reference_impl.potentials",
    "PowerLaw": "reference_impl.potentials",
    "Sphere": "reference_impl.potentials",
    "SumPotential": "reference_impl.potentials",
    "Scene": "reference_impl.scenes",
    "embedded_scenes": "reference_impl.scenes",
    "load_scene": "reference_impl.scenes",
    "parse_scene": "reference_impl.scenes",
    "SafeStep": "reference_impl.stability.bound",
    "dt_safe": "reference_impl.stability.bound",
    "dt_safe_shortcut": "reference_impl.stability.bound",
    "geometry_class": "reference_impl.stability.bound",
    "stiffening_indicator": "reference_impl.stability.bound",
    "restitution_zero_force_from_zeta": "reference_impl.theory.damping",
    "DampingLaw": "reference_impl.theory.laws",
    "LAWS": "reference_impl.theory.laws",
    "LawFamily": "reference_impl.theory.laws",
    "Param": "reference_impl.theory.laws",
    "Decomposition": "reference_impl.theory.laws",
    "register_law": "reference_impl.theory.laws",
    "LawImpactSolution": "reference_impl.exact.general_law",
    "solve_law_impact": "reference_impl.exact.general_law",
    "PreparedLaw": "reference_impl.exact.general_law",
    "prepare_law": "reference_impl.exact.general_law",
}

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
    "prepare",
    "PreparedImpact",
    "restitution_from_zeta",
    "restitution_zero_force_from_zeta",
    "DampingLaw",
    "LAWS",
    "LawFamily",
    "Param",
    "Decomposition",
    "register_law",
    "solve",
    "solve_batch",
    "LawImpactSolution",
    "solve_law_impact",
    "PreparedLaw",
    "prepare_law",
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


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        # A sub-package asked for as an attribute (`reference_impl.scenes` after a bare
        # `import reference_impl`), as the eager imports of earlier versions allowed.
        if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
            return importlib.import_module(f"{__name__}.{name}")
        raise AttributeError(f"module 'reference_impl' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
