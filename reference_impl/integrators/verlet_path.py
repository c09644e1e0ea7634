"""Velocity-Verlet trajectories: the one recorder of (q_n, v_n, force_n) along a run.

The lane engine (`reference_impl.integrators.verlet.run_lanes`) reports only
energies and statuses, not a trajectory. Whatever needs the steps themselves
comes here: the work-precision points of velocity Verlet (`verlet_impact`), and
the reference adapter's trajectories and the critical-step baseline
(`verlet_trajectory`, used by `reference_impl.adapters.reference`). It is the
engine's step (`reference_impl.integrators.verlet_kernel._kdk`, the same function,
so the arithmetic is identical): kick-drift-kick with the force
at the new position, the dashpot evaluated with the half-step velocity. Scenes:
one wall at y = 0 (impact, starting exactly at a step boundary: y_0 = 0,
v_0 = impact speed) or two walls (y = 0 and y = gap). Damping: the universal law
(2 zeta sqrt(m) U'/sqrt(2U)), a power law c q^a, and, in the Python loop only,
any coefficient C(q) given as a callable; optionally a tensile total force is
clipped to 0. Known potential families run in one numba kernel; any other
`Potential` runs the same loop and step in plain Python (rebound to its force).

From an impact's record (`VerletPath`): the end of contact by linear
interpolation of the last drift (the drift is linear in time), the restitution
from the exit velocity, the maximum penetration as the largest sampled overlap
(what a DEM code sees), and q(t) at arbitrary instants by cubic Hermite
interpolation of (y_n, v_n).
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl._jit import rebind
from reference_impl.integrators.verlet import SCENE_IMPACT, SCENE_WALLS, kernel_terms
from reference_impl.integrators.verlet_kernel import _kdk, _overlap, _record_kernel

__all__ = ["VerletPath", "verlet_impact", "verlet_trajectory"]


def _python_force(q, pot, c_fun):
    """U'(q) (N) and U(q) (J) of ``pot`` at one overlap q > 0 (m): `_force_energy` of the
    Python binding, whose ``fam, par`` are the potential and the coefficient C(q)."""
    arr = np.array([q])
    return float(pot._dU(arr)[0]), float(pot._U(arr)[0])


def _python_coefficient(q, pot, c_fun):
    """The damping coefficient C(q) (kg/s) of a vectorised ``c_fun`` at one overlap q (m)."""
    return float(c_fun(np.array([q]))[0])


# `_record_kernel` run as Python around a `Potential` (one scalar call per step), for
# potentials without a kernel or with a per-step coefficient C(q): the same source,
# with the step's force and coefficient rebound (and its overlap run as Python).
_python_step = rebind(
    _kdk.py_func,
    _force_energy=_python_force,
    _coefficient=_python_coefficient,
    _overlap=_overlap.py_func,
)
_record_python = {
    False: rebind(_record_kernel.py_func, _kdk=_python_step),
    True: rebind(_record_kernel.py_func, _kdk=_python_step, _WITH_COEFFICIENT=True),
}


def _record(pot, m, v0, dt, n_steps, *, c_damp, c_pow, a_pow, clip, scene, gap, c_fun):
    """Run the recorder (kernel when the potential has one and no ``c_fun``).

    Returns q, v, f (n_steps + 1 samples each, those after the end unwritten) and the
    status of `_record_kernel`.
    """
    q, v, f = np.empty(n_steps + 1), np.empty(n_steps + 1), np.empty(n_steps + 1)
    terms = None if c_fun is not None else kernel_terms(pot)
    args = (float(pot.q_sup), float(m), c_damp, c_pow, a_pow, bool(clip), float(dt))
    args = (*args, float(v0), scene, float(gap), q, v, f)
    if terms is None:
        status = _record_python[c_fun is not None](pot, c_fun, *args)
    else:
        status = _record_kernel(terms[0], terms[1], *args)
    return q, v, f, int(status)


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
        # scipy.interpolate here, not at import: the adapters import this module
        from scipy.interpolate import CubicHermiteSpline

        if not self.separated:
            return np.full(np.shape(t), np.nan)
        tn = self.dt * np.arange(self.y.size)
        return CubicHermiteSpline(tn, self.y, self.v)(np.asarray(t, dtype=float))


def verlet_impact(pot, m: float, v0: float, zeta: float, dt: float, max_steps: int) -> VerletPath:
    """Run velocity Verlet on one impact (universal damping of ratio ``zeta``) with step
    dt (s) for at most max_steps steps; v0 > 0 (m/s)."""
    c_damp = 2.0 * zeta * math.sqrt(m)
    q, v, _, status = _record(
        pot,
        m,
        v0,
        dt,
        max_steps,
        c_damp=c_damp,
        c_pow=0.0,
        a_pow=0.0,
        clip=False,
        scene=SCENE_IMPACT,
        gap=0.0,
        c_fun=None,
    )
    return VerletPath(dt, v0, q, v, status)


def verlet_trajectory(
    pot,
    m: float,
    v0: float,
    dt: float,
    n_steps: int,
    *,
    zeta: float = 0.0,
    kind: str = "impact",
    gap: float = 0.0,
    damping=None,
    clip: bool = False,
    c_fun=None,
):
    """Velocity-Verlet trajectory (t, q, v, force) of one impact or a two-walls run.

    Parameters
    ----------
    pot : Potential
        Contact potential U(q).
    m, v0, dt : float
        Mass (kg), speed at contact onset (m/s), time step (s).
    n_steps : int
        Largest number of steps.
    zeta : float
        Ratio of the universal damping law.
    kind : str
        ``"impact"``, or anything else for two walls at y = 0 and y = ``gap`` (m).
    damping : PowerDamping, optional
        C = c q^a: any object with ``c`` (kg/s/m^a) and ``exponent`` (a), e.g.
        `reference_impl.adapters.PowerDamping`.
    clip : bool
        Set a tensile total force to 0 (codes that forbid attraction).
    c_fun : callable, optional
        Any other damping coefficient C(q) (kg/s), vectorised over an array of q,
        added to the others and evaluated at each step (the Python loop runs).

    Returns
    -------
    t, q, v, force : numpy.ndarray
        Time (s), overlap (m), velocity (m/s), repulsive force (N) at each step.
        Impact: starts at contact onset (q = 0, dq/dt = v0) and stops at the first
        step with q <= 0 after contact, or after ``n_steps``. Two-walls: starts at
        the onset of the lower wall's contact moving into it; q is the overlap with
        the nearer wall (negative in flight) and v the body's velocity along the
        axis. A run that left the potential's domain (q > q_sup) ends with a
        sample of nan.
    """
    c_pow, a_pow = (0.0, 0.0) if damping is None else (float(damping.c), float(damping.exponent))
    q, v, f, status = _record(
        pot,
        m,
        v0,
        dt,
        int(n_steps),
        c_damp=2.0 * zeta * math.sqrt(m),
        c_pow=c_pow,
        a_pow=a_pow,
        clip=clip,
        scene=SCENE_IMPACT if kind == "impact" else SCENE_WALLS,
        gap=gap,
        c_fun=c_fun,
    )
    k = abs(status) + 1 if status != 0 else q.size
    if status < 0:
        q[k - 1] = v[k - 1] = np.nan
    # n * dt, as the loop would compute it (an int64 step count times dt)
    t = np.arange(k) * float(dt)
    return t, q[:k], v[:k], f[:k]
