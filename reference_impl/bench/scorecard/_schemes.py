"""The declared scheme run on the declared law: the error a correct code of that scheme
makes (issue 40, §1).

Velocity Verlet runs through the suite's one Verlet recorder (`law_trajectory`, bit for
bit what the bench ran before schemes were declared). The others run here, in a plain
Python loop on the force F(q, v) = U'(q) + C(q) v of the `ImplementedLaw` (0 out of
contact; a tensile total force set to 0 when the law clips tension), with the contract's
conventions: start at q = 0, v = v0, record every step, stop at the first step after the
overlap returned to q <= 0 or after ``n_steps`` steps. Each records at t_n the state
(q_n, v_n) and the force F(q_n, v_n) of the law at that state. A variable-step scheme is
scipy's RK45 at the declared rtol, sampled at t = n dt from its dense output.

Runs are short (a few thousand steps at most): a Python loop keeps one source for every
law of the table, which the compiled Verlet kernel does not.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from reference_impl.adapters.base import ImplementedLaw, Scheme

__all__ = ["force_mismatch", "law_force", "scheme_trajectory"]

# Newton-free root of the implicit step: brentq to this relative tolerance in v (its
# round-off floor, 4 ulps), so the implicit scheme's own error is the step's only.
_XTOL_REL = 8.9e-16
# Expansions of the implicit step's bracket (each doubles it) before giving up.
_MAX_EXPAND = 200
# Absolute error tolerance of the variable-step reference, as a fraction of the
# overlap scale v0 * t_c: the declared rtol decides, this only guards q ~ 0.
_ATOL_FRACTION = 1e-12


def law_force(law: ImplementedLaw):
    """The total normal force F(q, v) (N) of a declared law, as a scalar function.

    Parameters
    ----------
    law : ImplementedLaw
        Potential, mass, damping (universal ratio or C(q)), tension clipping.

    Returns
    -------
    callable
        ``F(q, v)``: U'(q) + C(q) v for an overlap q > 0 (m) and its rate v (m/s,
        positive approaching), 0 for q <= 0; max(F, 0) when the law clips tension.
        NaN outside the potential's domain.
    """
    pot = law.potential

    def force(q: float, v: float) -> float:
        if not q > 0.0:
            return 0.0
        arr = np.array([q])
        with np.errstate(all="ignore"):
            f = float(pot._dU(arr)[0]) + float(law.damping_coefficient(arr)[0]) * v
        return max(f, 0.0) if law.clips_tension else f

    return force


def scheme_trajectory(law: ImplementedLaw, scheme: Scheme, v0: float, dt: float, n_steps: int):
    """The declared scheme's impact trajectory on the declared law.

    Parameters
    ----------
    law : ImplementedLaw
        The law the code declares.
    scheme : Scheme
        Its declared scheme.
    v0, dt : float
        Impact speed (m/s) and step (s; a variable-step scheme's sampling).
    n_steps : int
        Step budget.

    Returns
    -------
    t, q, v, f : ndarray
        Time (s), overlap (m), its rate (m/s) and total force (N) at every step.

    Raises
    ------
    TypeError
        The law's damping is an opaque callable the velocity-Verlet recorder cannot run
        (velocity Verlet only; the other schemes call C(q) as given).
    """
    if scheme.name == "velocity-verlet":
        from reference_impl.adapters.reference import law_trajectory

        return law_trajectory(law, v0, dt, n_steps)
    force = law_force(law)
    if scheme.variable:
        return _variable(force, law.mass, v0, dt, n_steps, scheme.rtol)
    step = {
        "symplectic-euler": _symplectic_euler,
        "explicit-euler": _explicit_euler,
        "implicit-euler": _implicit_euler,
        "rk4": _rk4,
    }[scheme.name]
    m = float(law.mass)
    q, v = [0.0], [float(v0)]
    for _ in range(int(n_steps)):
        qn, vn = step(force, m, q[-1], v[-1], dt)
        q.append(qn)
        v.append(vn)
        if not (math.isfinite(qn) and math.isfinite(vn)) or qn <= 0.0:
            break
    qa, va = np.array(q), np.array(v)
    fa = np.array([force(a, b) for a, b in zip(qa, va, strict=True)])
    return dt * np.arange(qa.size), qa, va, fa


def _explicit_euler(force, m, q, v, dt):
    a = -force(q, v) / m
    return q + dt * v, v + dt * a


def _symplectic_euler(force, m, q, v, dt):
    vn = v - dt * force(q, v) / m
    return q + dt * vn, vn


def _implicit_euler(force, m, q, v, dt):
    """Backward Euler: v' = v - dt F(q + dt v', v') / m, q' = q + dt v' (root in v')."""

    def g(w):
        f = force(q + dt * w, w)
        return w - v + dt * (f if math.isfinite(f) else math.inf) / m

    half = abs(v) + dt * abs(force(q, v)) / m + 1e-300
    lo, hi = v - half, v + half
    for _ in range(_MAX_EXPAND):  # g(w) -> -inf as w -> -inf (out of contact, F = 0)
        if g(lo) < 0.0:
            break
        lo -= half
        half *= 2.0
    for _ in range(_MAX_EXPAND):  # and grows with w once the spring is compressed
        if g(hi) > 0.0:
            break
        hi += half
        half *= 2.0
    w = brentq(g, lo, hi, xtol=1e-300, rtol=_XTOL_REL, maxiter=500)
    return q + dt * w, w


def _rk4(force, m, q, v, dt):
    def rhs(x, y):
        return y, -force(x, y) / m

    k1 = rhs(q, v)
    k2 = rhs(q + 0.5 * dt * k1[0], v + 0.5 * dt * k1[1])
    k3 = rhs(q + 0.5 * dt * k2[0], v + 0.5 * dt * k2[1])
    k4 = rhs(q + dt * k3[0], v + dt * k3[1])
    return (
        q + dt / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
        v + dt / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]),
    )


def _variable(force, m, v0, dt, n_steps, rtol):
    """RK45 at ``rtol``, sampled at t = n dt up to the first sample after q <= 0."""

    def rhs(_t, y):
        return [y[1], -force(y[0], y[1]) / m]

    t_end = dt * n_steps
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, float(v0)], method="RK45", rtol=rtol,
                    atol=_ATOL_FRACTION * abs(v0) * t_end, dense_output=True)  # fmt: skip
    t = dt * np.arange(n_steps + 1)
    t = t[t <= sol.t[-1]]
    q, v = sol.sol(t)
    out = np.nonzero(q[1:] <= 0.0)[0]
    n = int(out[0]) + 2 if out.size else t.size
    t, q, v = t[:n], q[:n], v[:n]
    q[0] = 0.0
    f = np.array([force(a, b) for a, b in zip(q, v, strict=True)])
    return t, q, v, f


def force_mismatch(tr, law: ImplementedLaw) -> dict:
    """The reported force against the declared law at the reported states.

    Parameters
    ----------
    tr : Trajectory
        A run (t, q, v, force at the same instants, after `align_staggered`).
    law : ImplementedLaw
        The law the code declares.

    Returns
    -------
    dict
        ``error``: max over the in-contact samples (q > 0) of |force - F(q, v)|, divided
        by the largest |F(q, v)| (dimensionless; inf when a reported force is not finite
        where the law's is, 0 without contact samples); ``q``, ``v``, ``force`` and
        ``law`` at the worst sample (m, m/s, N, N).
    """
    force = law_force(law)
    worst = {"error": 0.0, "q": math.nan, "v": math.nan, "force": math.nan, "law": math.nan}
    inside = [
        (float(a), float(b), float(c))
        for a, b, c in zip(tr.q, tr.v, tr.force, strict=True)
        if a > 0.0 and math.isfinite(a) and math.isfinite(b)
    ]
    if not inside:
        return worst
    want = [force(a, b) for a, b, _ in inside]
    scale = max((abs(w) for w in want if math.isfinite(w)), default=0.0)
    for (a, b, got), w in zip(inside, want, strict=True):
        if not math.isfinite(w):
            continue  # beyond the law's domain: not the force's error to judge
        diff = abs(got - w) if math.isfinite(got) else math.inf
        err = diff / scale if scale > 0 else (0.0 if diff == 0 else math.inf)
        if err > worst["error"] or math.isnan(worst["q"]):
            worst = {"error": err, "q": a, "v": b, "force": got, "law": w}
    return worst
