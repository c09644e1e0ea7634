"""Independent reference integrators (Verlet lanes, scipy solve_ivp, mpmath Taylor)."""

from .ivp import IVPImpact, integrate_impact
from .taylor import TaylorImpact, taylor_impact

__all__ = ["IVPImpact", "TaylorImpact", "integrate_impact", "taylor_impact"]
