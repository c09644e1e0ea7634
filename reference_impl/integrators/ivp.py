"""Physical impact by `scipy.integrate.solve_ivp`: an independent reference.

The contact m q'' = -U'(q) - C(q) q' is integrated from q = 0, q' = v0 > 0
until the overlap returns to zero. Nothing of the harmonic theory is used,
except optionally to integrate the reparametrised time tau as an extra state
(d tau / dt = sqrt(M/m) dx/dq, Theorem 2), so that x(q(t)) can be compared with
a function of tau computed *independently* of x.

Three phases, so that no step ever straddles the end of contact:

1. time t from q = 0 to maximum penetration (event v = 0);
2. time t on the way out down to q = q_max / 2 (event);
3. the overlap q as the independent variable, from q_max / 2 down to exactly
   q = 0, with states (t, v[, tau]) and d/dq = (1/v) d/dt.

Why phase 3: the exit force behaves like q^p, so the solution of t is not
smooth at the exit. A Runge-Kutta step across it (the usual terminal-event
approach) has an error the embedded estimator does not see: measured 2.3e-9
relative in v_out at rtol = 1e-12 for a p = 2.79 power law, against 2e-11 (the
global error level) with the exit as an end point. On the way out v < 0 and
stays away from 0 unless the body creeps (overdamped), so 1/v is harmless;
creeping is caught by a horizon.

The independent variables are dimensionless, s = t / t_s (t_s = q_max / v0) and
sigma = q / q_max: solve_ivp locates events with an *absolute* tolerance of
4 eps in the independent variable, a large relative error when t or q is tiny
(measured 1e-7 in the restitution for q_max ~ 1e-11 m without the scaling).
The equations of motion in these variables, kept defined at q <= 0, are
`reference_impl.integrators._contact_rhs`.

Events located on the dense output:

* v = 0: maximum penetration q_max (end of phase 1);
* zero total force U'(q) + C(q) v = 0 on the way out (phases 2, 3): where a DEM
  code that forbids tensile contact forces ends the contact (inside the last
  step, which ends at q = 0 where the force has only a limit, it is searched on
  the dense output, see `_late_zero_force`);
* q = 0: end of contact, the end point of phase 3.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from reference_impl.errors import HCVInputError
from reference_impl.integrators._contact_rhs import Budgeted, ContactRHS
from reference_impl.potentials._checks import positive
from reference_impl.potentials.base import Potential
from reference_impl.theory.harmonic_map import HarmonicMap

__all__ = ["IVPImpact", "ImpactSolution", "integrate_impact"]

# Explicit and implicit methods solve_ivp accepts by name.
_METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")
# solve_ivp clamps rtol below 100 eps (with a warning); refuse it instead, so the
# reported rtol is the one used.
_RTOL_MIN = 100.0 * np.finfo(float).eps
# Default integration horizon in units of q_max / v0. The conservative contact
# time of a power law is 2..4 q_max / v0 and damping with zeta <= 0.9 stretches it
# by at most ~2.3; 1000 leaves room for slow non-universal damping laws.
_T_MAX_FACTOR = 1000.0
# Overlap, as a fraction of the reached q_max, at which the way out switches to q
# as the independent variable: any value well inside (0, 1) keeps away both from
# v = 0 (at q_max, where dq/dt vanishes) and from the exit.
_SWITCH_FRACTION = 0.5
# Phase 3 may fail only when the body creeps towards q = 0 (v -> 0, dt/dq -> inf).
# Below this fraction of v0 such a failure is reported as "did not return".
_CREEP_SPEED = 1e-6
# Inverting t(q) in phase 3 for dense output: brentq tolerance relative to q_max / 2
# (a few ulps of q).
_INVERT_XRTOL = 4.0 * np.finfo(float).eps
# Geometric search for a zero of the total force inside the last phase-3 step:
# q_k 2^-j for j up to 200 reaches 1e-60 q_k, below any physically resolvable overlap.
_LATE_SEARCH_HALVINGS = 200


@dataclass(frozen=True)
class IVPImpact:
    """Result of `integrate_impact`.

    Attributes
    ----------
    contact_time : float
        Time at which q returns to 0 (s); NaN if it did not return before ``t_max``.
    restitution : float
        -v_out / v0 at that return (dimensionless); NaN if it did not return.
    q_max : float
        Maximum penetration, located at v = 0 (m).
    max_force : float
        Elastic force U'(q_max) (N).
    t_zero_force : float
        First time on the way out at which U'(q) + C(q) v = 0 (s). If the total
        force never becomes tensile it vanishes only with the overlap, and this
        equals ``contact_time``.
    restitution_zero_force : float
        -v / v0 at ``t_zero_force`` (dimensionless).
    t, q, v : numpy.ndarray
        Output times (s), overlaps (m) and velocities (m/s): the solver steps of
        the three phases, or ``t_eval`` truncated at the end of the integration.
        Without ``t_eval`` the last point is the end of contact, q = 0 exactly.
    tau : numpy.ndarray or None
        Reparametrised time tau at the same points (virtual s); None without ``hmap``.
    sol : ImpactSolution or None
        Dense output of (q, v[, tau]) over [0, contact_time] when requested; it is
        called like a `scipy.integrate.OdeSolution`.
    nfev : int
        Number of right-hand-side evaluations (all phases).
    method : str
        solve_ivp method used.
    rtol : float
        Relative tolerance used.
    atol : numpy.ndarray
        Absolute tolerances used for (q, v[, tau]) (m, m/s[, s]); phase 3 uses
        atol_q / v0 for t.
    t_q_max : float
        Time of maximum penetration (s).
    tau_q_max, tau_contact, tau_zero_force : float or None
        tau at maximum penetration, at the end of contact and at zero total force
        (virtual s); None without ``hmap``.
    returned : bool
        True when q returned to 0 within the integration horizon.
    """

    contact_time: float
    restitution: float
    q_max: float
    max_force: float
    t_zero_force: float
    restitution_zero_force: float
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray | None
    sol: ImpactSolution | None
    nfev: int
    method: str
    rtol: float
    atol: np.ndarray
    t_q_max: float
    tau_q_max: float | None
    tau_contact: float | None
    tau_zero_force: float | None
    returned: bool


class ImpactSolution:
    """Dense solution (q, v[, tau]) as a function of physical time, over all phases.

    Called like `scipy.integrate.OdeSolution`: ``sol(t)`` returns shape
    ``(n_states,)`` for a scalar ``t`` and ``(n_states, len(t))`` for an array.
    In phase 3 (q independent) q(t) is found by inverting the monotone t(q).
    Outside [0, t_max] it does not extrapolate: t < 0 gives the first state and
    t > t_max the last one (q = 0 and the exit velocity after a return).
    """

    def __init__(self, sols, *, s_bounds, sigma_bounds, t_end, t_s, q_s, n):
        self._sol1, self._sol2, self._sol3 = sols
        self._s1, self._s2 = s_bounds  # ends of phases 1 and 2 (scaled time)
        self._sigma_end, self._sigma_sw = sigma_bounds  # phase 3 runs sigma_sw -> sigma_end
        self._t_s, self._q_s = t_s, q_s
        self.t_min, self.t_max = 0.0, t_end
        self._n = n

    def _phase3(self, s: float) -> np.ndarray:
        if s * self._t_s >= self.t_max:
            sg = self._sigma_end
        else:
            sg = brentq(
                lambda x: float(self._sol3(x)[0]) - s,
                self._sigma_end,
                self._sigma_sw,
                xtol=_INVERT_XRTOL * self._sigma_sw,
                rtol=_INVERT_XRTOL,
            )
        y = self._sol3(sg)
        return np.concatenate([[sg * self._q_s], y[1:]])

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        if np.any(np.isnan(t)):
            raise HCVInputError("ImpactSolution: t must not be NaN")
        ss = np.clip(np.atleast_1d(t), self.t_min, self.t_max) / self._t_s
        out = np.empty((self._n, ss.size))
        m1 = ss <= self._s1
        m2 = ~m1 & (ss <= self._s2)
        m3 = ~m1 & ~m2
        if np.any(m1):
            out[:, m1] = self._sol1(ss[m1])
        if np.any(m2):
            out[:, m2] = self._sol2(ss[m2])
        for i in np.flatnonzero(m3):
            out[:, i] = self._phase3(float(ss[i]))
        return out[:, 0] if t.ndim == 0 else out


def _event(fun, *, terminal: bool, direction: int):
    """Wrap ``fun(s, y)`` in a function carrying solve_ivp's event attributes."""

    def event(s, y):
        return fun(s, y)

    event.terminal, event.direction = terminal, direction
    return event


def _late_zero_force(r3, rhs: ContactRHS, has_tau: bool):
    """First zero of U' + C v inside the last step of phase 3, or None.

    The step that ends at q = 0 cannot show the event to solve_ivp: the event
    function is undefined there (0/0-type limits) and returns the positive
    sentinel. A tensile zone that starts inside that step (e.g. a linear spring
    with small damping, whose steps are long) is found by sampling the dense
    output at q_k 2^-j towards the exit, then bracketing with brentq.
    """
    sg_k = float(r3.t[-2]) if r3.t.size >= 2 else 0.0
    if not sg_k > 0:
        return None

    def g(sg: float) -> float:
        return rhs.total_force(sg * rhs.q_s, float(r3.sol(sg)[1]))

    sg_hi = sg_k
    if not g(sg_hi) > 0:
        return None
    for j in range(1, _LATE_SEARCH_HALVINGS + 1):
        sg_lo = sg_k * 2.0**-j
        if g(sg_lo) < 0:
            sg = brentq(g, sg_lo, sg_hi, xtol=_INVERT_XRTOL * sg_lo, rtol=_INVERT_XRTOL)
            y = r3.sol(sg)
            return float(y[0]) * rhs.t_s, float(y[1]), float(y[2]) if has_tau else None
        sg_hi = sg_lo
    return None


def _check_atol(atol, default: np.ndarray) -> np.ndarray:
    if atol is None:
        return default
    a = np.asarray(atol, dtype=float)
    if a.ndim == 0:
        a = np.full_like(default, float(a))
    if a.shape != default.shape or not np.all(np.isfinite(a) & (a > 0)):
        raise HCVInputError(
            f"integrate_impact: atol must be a positive finite number or {default.size} of "
            f"them (q, v[, tau]), got {atol!r}"
        )
    return a


def _check_t_eval(t_eval) -> np.ndarray | None:
    if t_eval is None:
        return None
    te = np.asarray(t_eval, dtype=float)
    if (
        te.ndim != 1
        or np.any(~np.isfinite(te))
        or np.any(np.diff(te) <= 0)
        or (te.size and te[0] < 0)
    ):
        raise HCVInputError("integrate_impact: t_eval must be finite, increasing and start at >= 0")
    return te


def _is_ode_solver(method) -> bool:
    from scipy.integrate import OdeSolver

    return isinstance(method, type) and issubclass(method, OdeSolver)


def integrate_impact(
    potential: Potential,
    m: float,
    v0: float,
    *,
    C: Callable | None = None,
    method: str = "DOP853",
    rtol: float = 1e-12,
    atol=None,
    hmap: HarmonicMap | None = None,
    t_eval=None,
    dense_output: bool = False,
    t_max: float | None = None,
    max_nfev: int | None = None,
) -> IVPImpact:
    """Integrate one normal impact m q'' = -U'(q) - C(q) q' with solve_ivp.

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J of m).
    m : float
        Mass (kg, > 0).
    v0 : float
        Impact speed (m/s, > 0); the contact starts at q = 0 with q' = v0.
    C : callable, optional
        Damping coefficient q -> C(q) (kg/s), called with a float overlap
        q >= 0; None (default) for the conservative contact.
    method : str or type
        solve_ivp method: a name (default DOP853, 8th order, tight tolerances are cheap)
        or, as ``solve_ivp`` accepts, a ``scipy.integrate.OdeSolver`` subclass.
    rtol : float
        Relative tolerance, >= 100 eps (default 1e-12).
    atol : float or array_like, optional
        Absolute tolerance(s) for (q, v[, tau]). Default: rtol times the scale of
        each state, i.e. rtol * q_max(E) (conservative turning point), rtol * v0
        and rtol * pi / Omega0.
    hmap : HarmonicMap, optional
        If given (for the same potential and mass), tau is integrated as a third
        state with d tau / dt = hmap.dtau_dt(q).
    t_eval : array_like, optional
        Increasing output times (s) starting at >= 0; points after the end of
        the integration are dropped.
    dense_output : bool
        Return the dense solution ``sol`` (default False).
    t_max : float, optional
        Integration horizon (s); default 1000 q_max / v0. If q has not returned
        to 0 by then, ``returned`` is False and the end-of-contact fields are NaN.
    max_nfev : int, optional
        Budget of right-hand-side evaluations over all phases (default None: none
        but ``t_max``). A body creeping towards q = 0 (an overdamped law) can spend
        minutes before ``t_max``; past the budget a one-line RuntimeError is raised.

    Returns
    -------
    IVPImpact

    Raises
    ------
    HCVInputError
        Invalid argument (subclasses: NoTurningPointError if the potential cannot
        stop the impact, NonMonotoneError if U' <= 0 before the turning point).
    RuntimeError
        solve_ivp failed other than by a body creeping towards q = 0, or the
        ``max_nfev`` budget was spent.
    """
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    m = positive("m", m, "integrate_impact")
    v0 = positive("v0", v0, "integrate_impact")
    if C is not None and not callable(C):
        raise HCVInputError(f"integrate_impact: C must be callable q -> C(q) or None, got {C!r}")
    if not (isinstance(method, str) and method in _METHODS) and not _is_ode_solver(method):
        raise HCVInputError(
            f"integrate_impact: method must be one of {_METHODS} or a "
            f"scipy.integrate.OdeSolver subclass, got {method!r}"
        )
    rtol = positive("rtol", rtol, "integrate_impact")
    if not _RTOL_MIN <= rtol < 1:
        raise HCVInputError(
            f"integrate_impact: rtol must lie in [{_RTOL_MIN:.3g}, 1), got {rtol!r}"
        )
    if hmap is not None:
        if not isinstance(hmap, HarmonicMap):
            raise HCVInputError(f"integrate_impact: hmap must be a HarmonicMap, got {hmap!r}")
        if hmap.potential is not potential or hmap.m != m:
            raise HCVInputError(
                "integrate_impact: hmap must map the same potential and mass as the impact "
                f"(got {hmap.potential!r}, m = {hmap.m!r} for {potential!r}, m = {m!r})"
            )

    # Conservative turning point: scale of q and the existence check (assumption 4).
    q_scale = potential.turning_point(0.5 * m * v0 * v0)
    if C is not None:
        c_probe = np.asarray(C(0.5 * q_scale), dtype=float)
        c_val = float(c_probe.reshape(-1)[0]) if c_probe.size == 1 else math.nan
        if not (math.isfinite(c_val) and c_val >= 0):
            raise HCVInputError(
                f"integrate_impact: C(q) must return one finite value >= 0 (kg/s), got "
                f"{c_probe!r} at q = {0.5 * q_scale!r} m"
            )
    has_tau = hmap is not None
    scales = [q_scale, v0] + ([math.pi / hmap.omega0] if has_tau else [])
    atol_arr = _check_atol(atol, rtol * np.asarray(scales))
    t_max = (
        _T_MAX_FACTOR * q_scale / v0
        if t_max is None
        else positive("t_max", t_max, "integrate_impact")
    )
    t_eval = _check_t_eval(t_eval)

    # Internally the independent variables are dimensionless, s = t / t_s in phases
    # 1-2 and sigma = q / q_s in phase 3: scipy locates events with brentq at an
    # *absolute* xtol of 4 eps, which is a large relative error when t or q is tiny
    # (measured 1e-7 in e for q_max ~ 1e-11 m before scaling).
    q_s = q_scale
    t_s = q_scale / v0
    rhs = ContactRHS(potential, m, C, hmap, q_s=q_s, t_s=t_s)
    if max_nfev is not None:
        if not (isinstance(max_nfev, int) and max_nfev > 0):
            raise HCVInputError(
                f"integrate_impact: max_nfev must be a positive int or None, got {max_nfev!r}"
            )
        rhs = Budgeted(rhs, max_nfev, f"{potential!r}, m = {m!r}, v0 = {v0!r}")
    dense = dense_output or t_eval is not None
    opts = dict(method=method, rtol=rtol, dense_output=dense)
    n = len(scales)
    s_max = t_max / t_s
    nfev = 0

    def _failed(res, phase):
        return RuntimeError(
            f"integrate_impact: solve_ivp failed in phase {phase} for {potential!r}, "
            f"v0 = {v0!r}: {res.message}"
        )

    # Phase 1: s from the first touch to maximum penetration.
    turn = _event(lambda s, y: float(y[1]), terminal=True, direction=-1)
    y0 = [0.0, v0] + ([0.0] if has_tau else [])
    r1 = solve_ivp(rhs.in_s, (0.0, s_max), y0, atol=atol_arr, events=[turn], **opts)
    nfev += r1.nfev
    if r1.status < 0:
        raise _failed(r1, 1)
    if r1.status != 1:  # pragma: no cover - U' > 0 with a turning point always stops the body
        raise RuntimeError(f"integrate_impact: no maximum penetration before t_max = {t_max!r} s")
    s1, y1 = float(r1.t_events[0][0]), r1.y_events[0][0]
    q_max = float(y1[0])

    # Phase 2: s on the way out, to q = q_max / 2.
    q_sw = _SWITCH_FRACTION * q_max
    switch = _event(lambda s, y: float(y[0]) - q_sw, terminal=True, direction=-1)
    zf_s = _event(
        lambda s, y: rhs.total_force(float(y[0]), float(y[1])), terminal=False, direction=-1
    )
    r2 = solve_ivp(rhs.in_s, (s1, s_max), y1, atol=atol_arr, events=[switch, zf_s], **opts)
    nfev += r2.nfev
    if r2.status < 0:
        raise _failed(r2, 2)
    zero_force = None  # (t, v, tau) at the first zero of the total force
    if r2.t_events[1].size:
        yz = r2.y_events[1][0]
        zero_force = (
            float(r2.t_events[1][0]) * t_s,
            float(yz[1]),
            float(yz[2]) if has_tau else None,
        )

    # Phase 3: sigma = q / q_s from the switch down to 0, states (s, v[, tau]).
    r3 = None
    sigma_sw = q_sw / q_s
    if r2.status == 1:
        s2, y2 = float(r2.t_events[0][0]), r2.y_events[0][0]
        # Start from the q of the located state (q_sw up to the root tolerance), so
        # that (q, s, v, tau) is one consistent point of the trajectory.
        sigma_sw = float(y2[0]) / q_s
        y3 = [s2, float(y2[1])] + ([float(y2[2])] if has_tau else [])
        atol3 = np.concatenate([[atol_arr[0] / q_s], atol_arr[1:]])
        zf_q = _event(
            lambda sg, y: rhs.total_force(sg * q_s, float(y[1])), terminal=False, direction=-1
        )
        horizon = _event(lambda sg, y: float(y[0]) - s_max, terminal=True, direction=1)
        # Dense output always: the last step is searched for a late zero of the force.
        r3 = solve_ivp(
            rhs.in_sigma,
            (sigma_sw, 0.0),
            y3,
            atol=atol3,
            events=[zf_q, horizon],
            **{**opts, "dense_output": True},
        )
        nfev += r3.nfev
        if r3.status < 0 and not abs(float(r3.y[1][-1])) < _CREEP_SPEED * v0:
            raise _failed(r3, 3)
        if zero_force is None and r3.t_events[0].size:
            yz = r3.y_events[0][0]
            zero_force = (float(yz[0]) * t_s, float(yz[1]), float(yz[2]) if has_tau else None)
        if zero_force is None and r3.status == 0:
            zero_force = _late_zero_force(r3, rhs, has_tau)

    returned = r3 is not None and r3.status == 0
    if returned:
        contact_time = float(r3.y[0][-1]) * t_s
        restitution = -float(r3.y[1][-1]) / v0
        tau_contact = float(r3.y[2][-1]) if has_tau else None
    else:
        contact_time = restitution = math.nan
        tau_contact = math.nan if has_tau else None
    if zero_force is None:
        # The total force never became tensile: it vanishes with the overlap.
        t_zf, e_zf, tau_zf = contact_time, restitution, tau_contact
    else:
        t_zf, e_zf, tau_zf = zero_force[0], -zero_force[1] / v0, zero_force[2]

    # Step points of all phases (phase 3 rows reordered to (q, v[, tau]) of t).
    ts = [r1.t * t_s, r2.t[1:] * t_s]
    ys = [r1.y, r2.y[:, 1:]]
    if r3 is not None:
        ts.append(r3.y[0][1:] * t_s)
        ys.append(np.vstack([r3.t[1:] * q_s, r3.y[1:, 1:]]))
    t_all, y_all = np.concatenate(ts), np.hstack(ys)
    t_end = float(t_all[-1])

    sol = None
    if dense:
        sol = ImpactSolution(
            (r1.sol, r2.sol, r3.sol if r3 is not None else None),
            s_bounds=(s1, float(r2.t[-1])),
            sigma_bounds=(float(r3.t[-1]) if r3 is not None else sigma_sw, sigma_sw),
            t_end=t_end,
            t_s=t_s,
            q_s=q_s,
            n=n,
        )
    if t_eval is not None:
        t_all = t_eval[t_eval <= t_end]
        y_all = sol(t_all) if t_all.size else np.empty((n, 0))

    return IVPImpact(
        contact_time=contact_time,
        restitution=restitution,
        q_max=q_max,
        max_force=float(potential.dU(q_max)),
        t_zero_force=t_zf,
        restitution_zero_force=e_zf,
        t=t_all,
        q=y_all[0],
        v=y_all[1],
        tau=y_all[2] if has_tau else None,
        sol=sol if dense_output else None,
        nfev=int(nfev),
        method=method,
        rtol=rtol,
        atol=atol_arr,
        t_q_max=s1 * t_s,
        tau_q_max=float(y1[2]) if has_tau else None,
        tau_contact=tau_contact,
        tau_zero_force=tau_zf,
        returned=returned,
    )
