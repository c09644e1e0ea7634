"""Independent reference integrators (Verlet lanes, scipy solve_ivp, mpmath Taylor)."""

from reference_impl.integrators.ivp import IVPImpact, integrate_impact
from reference_impl.integrators.taylor import TaylorImpact, taylor_impact

__all__ = ["IVPImpact", "TaylorImpact", "integrate_impact", "taylor_impact"]
