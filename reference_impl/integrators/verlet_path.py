"""Velocity-Verlet trajectories for the speed-against-error study.

The lane engine (`reference_impl.integrators.verlet.run_lanes`) reports only
energies and statuses, not a trajectory, so the work-precision points of
velocity Verlet come from this small compiled loop. It is the engine's
algorithm with the engine's force kernel (`_force_energy`, the same numba
function, so the arithmetic is identical): kick-drift-kick with the force at
the new position, the universal dashpot evaluated with the half-step velocity,
one wall at y = 0, the contact starting exactly at a step boundary (y_0 = 0,
v_0 = impact speed). It records (y_n, v_n) at every step.

From the record: the end of contact by linear interpolation of the last drift
(the drift is linear in time), the restitution from the exit velocity, the
maximum penetration as the largest sampled overlap (what a DEM code sees), and
q(t) at arbitrary instants by cubic Hermite interpolation of (y_n, v_n).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.interpolate import CubicHermiteSpline

from reference_impl.integrators.verlet import _force_energy, kernel_terms
from reference_impl.studies.workprecision import _median_time

__all__ = ["VerletPath", "verlet_impact", "verlet_row"]

# Step budget of one run, in multiples of the requested steps per contact, plus a
# constant: damping lengthens the contact by at most ~2.3 (zeta <= 0.9).
_BUDGET_FACTOR = 4
_BUDGET_EXTRA = 64


@numba.njit(cache=True)
def _path_kernel(fam, par, q_sup, m, c_damp, dt, v0, ys, vs):
    """Integrate one impact, writing y_n, v_n; returns n at separation, -n if blown, 0 if none."""
    y = 0.0
    v = v0
    F = 0.0
    half = 0.5 * dt / m
    ys[0] = 0.0
    vs[0] = v0
    for n in range(1, ys.shape[0]):
        vh = v + half * F
        y = y + dt * vh
        f = 0.0
        if y > 0.0:
            if not y <= q_sup:
                ys[n] = y
                vs[n] = vh
                return -n
            fe, U = _force_energy(y, fam, par)
            f = -fe
            if c_damp > 0.0 and U > 0.0:
                f -= c_damp * fe / math.sqrt(2.0 * U) * vh
        F = f
        v = vh + half * f
        ys[n] = y
        vs[n] = v
        if y <= 0.0:
            return n
    return 0


def _path_python(pot, m, c_damp, dt, v0, ys, vs):
    """Same loop through the Potential API, for potentials without a kernel."""
    y, v, F, half = 0.0, v0, 0.0, 0.5 * dt / m
    ys[0], vs[0] = 0.0, v0
    for n in range(1, ys.shape[0]):
        vh = v + half * F
        y = y + dt * vh
        f = 0.0
        if y > 0.0:
            if not y <= pot.q_sup:
                ys[n], vs[n] = y, vh
                return -n
            fe, U = float(pot.dU(y)), float(pot.U(y))
            f = -fe
            if c_damp > 0 and U > 0:
                f -= c_damp * fe / math.sqrt(2.0 * U) * vh
        F = f
        v = vh + half * f
        ys[n], vs[n] = y, v
        if y <= 0.0:
            return n
    return 0


class VerletPath:
    """One velocity-Verlet impact: the recorded steps and the derived results (SI units)."""

    def __init__(self, dt: float, v0: float, ys: np.ndarray, vs: np.ndarray, status: int):
        self.dt, self.v0 = dt, v0
        self.separated = status > 0
        self.blown = status < 0
        n = abs(status) if status != 0 else ys.shape[0] - 1
        self.steps = n
        self.y, self.v = ys[: n + 1], vs[: n + 1]
        if self.separated:
            y_in, y_out = self.y[-2], self.y[-1]
            self.contact_time = dt * (n - 1 + y_in / (y_in - y_out))
            self.restitution = -self.v[-1] / v0
        else:
            self.contact_time = self.restitution = math.nan
        self.max_penetration = float(np.max(self.y)) if not self.blown else math.nan

    def q(self, t) -> np.ndarray:
        """Overlap at times t (s) by cubic Hermite interpolation of (y_n, v_n)."""
        if not self.separated:
            return np.full(np.shape(t), np.nan)
        tn = self.dt * np.arange(self.y.size)
        return CubicHermiteSpline(tn, self.y, self.v)(np.asarray(t, dtype=float))


def verlet_impact(pot, m: float, v0: float, zeta: float, dt: float, max_steps: int) -> VerletPath:
    """Run velocity Verlet on one impact with step dt (s) for at most max_steps steps."""
    ys = np.empty(max_steps + 1)
    vs = np.empty(max_steps + 1)
    c_damp = 2.0 * zeta * math.sqrt(m)
    terms = kernel_terms(pot)
    if terms is None:
        status = _path_python(pot, m, c_damp, dt, v0, ys, vs)
    else:
        status = _path_kernel(
            terms[0], terms[1], float(pot.q_sup), float(m), c_damp, float(dt), float(v0), ys, vs
        )
    return VerletPath(dt, v0, ys, vs, int(status))


def _rel(a: float, b: float) -> float:
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.nan
    return abs(a - b) / abs(b) if b != 0 else abs(a - b)


def verlet_row(sc, truth, steps_per_contact: int) -> dict:
    """Work-precision row of velocity Verlet with dt = t_contact / steps_per_contact.

    The callback `reference_impl.studies.workprecision.work_precision` expects: errors
    against the mpmath ``truth`` and the median wall time of a whole impact.
    """
    dt = truth.contact_time / steps_per_contact
    budget = _BUDGET_FACTOR * steps_per_contact + _BUDGET_EXTRA
    path = verlet_impact(sc.potential, sc.m, sc.v0, sc.zeta, dt, budget)
    secs = _median_time(lambda: verlet_impact(sc.potential, sc.m, sc.v0, sc.zeta, dt, budget))
    q = path.q(truth.t_samples)
    err_traj = float(np.max(np.abs(q - truth.q_samples))) / truth.max_penetration
    return {
        "scene": sc.name,
        "method": "Verlet",
        "setting": f"{steps_per_contact} steps/contact",
        "seconds": secs,
        "err_contact_time": _rel(path.contact_time, truth.contact_time),
        "err_restitution": _rel(path.restitution, truth.restitution),
        "err_max_penetration": _rel(path.max_penetration, truth.max_penetration),
        "err_trajectory": err_traj if math.isfinite(err_traj) else math.nan,
        "dt": dt,
    }
