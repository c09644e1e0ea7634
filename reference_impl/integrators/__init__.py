"""Independent reference integrators (Verlet lanes, scipy solve_ivp, mpmath Taylor)."""
