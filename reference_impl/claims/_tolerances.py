"""Tolerances shared by several claim modules and their tests, each with the reason for its size."""

from __future__ import annotations

# Tight DOP853 runs (rtol 1e-12, atol scaled to the state): the global error over one
# contact stays near 1e-10 relative, so integrator-level comparisons use 1e-8.
ODE_RTOL = 1e-12
# x(tau) against the sinusoid, relative to its amplitude: DOP853 at ODE_RTOL accumulates
# ~1e-10 over a contact; 1e-8 leaves two orders of headroom and is still 1e7 below the
# physical-time control (which deviates by ~0.1).
SINUSOID_TOL = 1e-8
# Quantities that cancel analytically differ by round-off only: a few ulps per operation
# (~1e-16) through tens of operations stay below 1e-13.
ROUNDOFF_TOL = 1e-13
# A "measurable" difference: far above the error of two ODE runs at ODE_RTOL (~1e-8).
MEASURABLE = 1e-5
# Restitution spread under the universal law: two DOP853 runs at ODE_RTOL agree to ~1e-9
# in e; 1e-8 bounds that error.
E_TOL = 1e-8
# Exact solver (Gauss-Jacobi) against the 30-digit physical quadrature of t_c: the solver
# is accurate to a few ulps times the node count, ~1e-14; 1e-13 bounds it.
EXACT_RTOL = 1e-13
# Log-log slopes of exact power functions fitted by least squares over several decades:
# round-off in log() of ~1e-16 per point gives slope errors ~1e-13; 1e-10 bounds that.
SLOPE_TOL = 1e-10
# Restitution against theory: v_out carries the global ODE error ~1e-10 v0 (absolute in
# units of v0), so |e - e_th| <= E_ATOL + E_RTOL e is ~100x the worst measured 1.0e-11.
E_ATOL = 1e-9
E_RTOL = 1e-8  # relative part of the same bound (see E_ATOL)
# Event times in tau: global error of tau ~1e-10 plus brentq at 4 eps on the dense output.
TAU_EVENT_RTOL = 1e-9
# An identity evaluated two ways at one state: a dozen roundings plus the numeric inverse
# q(x) (4 eps in q, amplified by a log-derivative < 10).
IDENTITY_RTOL = 1e-12
# "Measurably": a difference this many times above the error bound of its method.
MEASURABLE_FACTOR = 1e3
# mpmath precision of central-difference derivatives (step 1e-15 relative): truncation
# ~1e-30 and cancellation ~1e-35 are far below float64 round-off.
MP_DERIV_DPS = 50
