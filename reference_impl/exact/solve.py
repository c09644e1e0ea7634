"""Exact impact solution through the harmonic map (Theorems 2 and 3).

With the universal damping law of ratio zeta, the contact is, in virtual time
s (we take K = M = m, so Omega0 = 1 and x' = dq/dt), the linear oscillator

    x'' + 2 zeta x' + x = 0,   x(0) = 0,   x'(0) = v0,

whose solution is explicit. Physical time is then a quadrature,
t(s) = int_0^s (dq/dx)(x(s')) ds', and the overlap is q = U^-1(m x^2 / 2).
No ODE is integrated. dq/dx ~ s^beta with beta = 2/n - 1 at both ends of the
contact (U ~ q^n), an integrable singularity that the double-exponential rules
of `_quadrature` handle at full precision.

Two ends of contact are reported:

* the theory's end, q back to 0 (s = pi / omega_d), where the damper may pull
  during the last part of the contact (restitution exp(-pi zeta / omega_d));
* the end at zero total force U' + C q' = 0, used by codes that forbid a tensile
  contact force. Since U' + C q' = -(dx/dq) m x'', it is the inflection x'' = 0,
  which falls at exactly twice the virtual time of maximum compression; after it
  the particle leaves in free flight with restitution exp(-2 zeta s_peak).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.exact._branches import dq_dx
from reference_impl.exact._one_call import conditioning_at as _conditioning_at
from reference_impl.exact._one_call import curvature
from reference_impl.exact._oscillator import S_END_MAX, ZETA_MAX, VirtualOscillator
from reference_impl.exact._quadrature import integrate_left_singular
from reference_impl.exact._route import route, solve_other
from reference_impl.exact._rtol import checked_rtol
from reference_impl.exact._strategies import Job, choose
from reference_impl.exact._validate import (
    N_MAX,
    _check_exponent,
    _validated_below,
    _validated_top,
)
from reference_impl.potentials._checks import positive
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.damping import _check_zeta

__all__ = [
    "ImpactSolution",
    "N_MAX",
    "RTOL_STATED",
    "S_END_MAX",
    "ZETA_MAX",
    "VirtualOscillator",
    "solve_impact",
    "solve_impact_mp",  # noqa: F822 - module __getattr__
]


def __getattr__(name: str):
    # The mpmath truth loads on first use: a float solve never imports mpmath (issue 20).
    if name == "solve_impact_mp":
        from reference_impl.exact._truth import solve_impact_mp

        return solve_impact_mp
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# Stated accuracy of the float solver: every reported time's error bound
# (`ImpactSolution.quadrature_error`) must be at most this fraction of the time.
# A result whose bound exceeds it is refused (UnsupportedError naming the bound),
# never returned as if it met it (issue 22). The rules reach ~1e-14 (README speed
# table), so this refuses only what they cannot resolve, e.g. an ill-conditioned
# turning point (see `_conditioning`).
RTOL_STATED = 1e-12
# The machine epsilon.
_EPS = float(np.finfo(float).eps)
# Smallest normal float64: energies, overlaps, forces and times below it have lost
# relative precision (subnormal) or underflowed to 0 (issue 22).
_TINY = float(np.finfo(float).tiny)
# Relative tolerance for locating s(t) in `ImpactSolution.state`: a few ulps.
_STATE_XRTOL = 8.0 * np.finfo(float).eps
# Number of table points used to bracket s(t) before the root finder polishes it.
_STATE_TABLE = 65


@dataclass(frozen=True)
class ImpactSolution:
    """Exact solution of one normal impact with universal damping (SI units).

    Attributes
    ----------
    v0 : float
        Impact speed (m/s).
    m : float
        Mass (kg).
    zeta : float
        Damping ratio of the universal law.
    max_penetration : float
        Largest overlap q_max (m).
    max_force : float
        Elastic force U'(q_max) at maximum penetration (N), as in Table 1; the peak
        total force max (U' + C q') is the property `peak_force`.
    contact_time : float
        Duration until q returns to 0 (s); inf when it never does (zeta >= 1).
    restitution : float
        -v_out / v0 at q = 0 (theory's end of contact).
    contact_time_zero_force : float
        Duration until the total force U' + C q' first vanishes (s).
    restitution_zero_force : float
        -v / v0 at that instant: the restitution of a code that clips tensile force.
    quadrature_error : float
        Bound on the absolute error of `contact_time` (s): quadrature estimate,
        round-off, and the conditioning of the turning point times the rounding
        of U (`_conditioning`); checked against mpmath truths by the tests. At
        most RTOL_STATED of the time (larger bounds are refused).
    quadrature_error_zero_force : float
        The same for `contact_time_zero_force` (s).
    """

    v0: float
    m: float
    zeta: float
    max_penetration: float
    max_force: float
    contact_time: float
    restitution: float
    contact_time_zero_force: float
    restitution_zero_force: float
    quadrature_error: float
    quadrature_error_zero_force: float
    potential: Potential = field(repr=False, compare=False)
    _osc: VirtualOscillator = field(repr=False, compare=False)
    _t_peak: float = field(repr=False, compare=False)

    @classmethod
    def _fast(cls, fields=(), /, **kw) -> ImpactSolution:
        """Construct from every field, given as a dict (fastest: keywords cost ~1 us of a
        ~7 us prepared impact) or as keywords, without the frozen dataclass __init__ (one
        object.__setattr__ per field cost ~2 us); there is no __post_init__, so the
        instance is the same."""
        obj = object.__new__(cls)
        obj.__dict__.update(fields, **kw)
        return obj

    def __getattr__(self, name: str):
        # Called only for a name missing from the instance: the prepared call
        # (`reference_impl.exact.prepared`) leaves `_osc` out and keeps the oscillator's
        # (wd, s_peak, s_end) as `_osc_of`; the oscillator is built from them on first use
        # (the trajectory, `to_dict`), saving ~0.6 us of an ~7 us impact.
        if name == "_osc":
            d = self.__dict__
            of = d.get("_osc_of")
            if of is not None:
                osc = d["_osc"] = VirtualOscillator._of(d["v0"], d["zeta"], *of)
                return osc
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def to_dict(self) -> dict:
        """The scalar results as a plain dict (for JSON), with ``peak_force``."""
        d = asdict(self)
        for key in ("potential", "_osc", "_t_peak"):
            d.pop(key, None)
        d["peak_force"] = self.peak_force
        d["returns_to_q0"] = self.returns_to_q0
        return d

    @property
    def returns_to_q0(self) -> bool:
        """False when the body never gets back to q = 0 (zeta >= 1 with n >= 2)."""
        return math.isfinite(self.contact_time)

    @property
    def peak_force(self) -> float:
        """Peak total contact force max_t (U'(q) + C(q) q') in N (not U'(q_max)).

        Computed on first use by the general-law integrator (`reference_impl.exact.general_law`,
        ~1e-14 relative), since the harmonic map gives no closed form for it.
        """
        cached = self.__dict__.get("_peak_force")
        if cached is None and self.zeta == 0:
            cached = self.max_force  # undamped: the total force is U', largest at q_max
        if cached is None:
            from reference_impl.exact.general_law import solve_law_impact

            cached = solve_law_impact(
                self.potential, self.m, self.v0, {"law": "universal", "zeta": self.zeta}
            ).peak_force
            self.__dict__["_peak_force"] = cached
        return cached

    # -- trajectory ---------------------------------------------------------
    def _g(self, s_or_d, from_end: bool = False):
        """dt/ds = dq/dx = m x / U'(q(x)) at virtual time s (or distance d from s_end)."""
        osc = self._osc
        x = osc.x_from_end(s_or_d) if from_end else osc.x(s_or_d)
        return dq_dx(self.potential, self.m, x, self.v0)

    def _beta(self) -> float:
        return 2.0 / self.potential.leading_exponent - 1.0

    def _t_rise(self, s):
        """Physical time at virtual time s on the rising branch (vectorised)."""
        val, _ = integrate_left_singular(lambda d: self._g(d), np.asarray(s, float), self._beta())
        return val

    def _t_fall(self, d):
        """Physical time at distance d before s_end on the falling branch."""
        val, _ = integrate_left_singular(
            lambda dd: self._g(dd, from_end=True), np.asarray(d, float), self._beta()
        )
        return self.contact_time - val

    def state(self, t):
        """Overlap q(t) (m) and velocity dq/dt (m/s) at physical times t (s).

        Time 0 is contact onset. Before it and after the end of contact the
        particle is in free flight, reported as a negative overlap (a gap).
        Underdamped contacts (zeta < 1) only.

        Parameters
        ----------
        t : array_like
            Physical times in s.

        Returns
        -------
        q, v : numpy.ndarray
            Overlap and its rate, same shape as ``t``.
        """
        if self.zeta >= 1.0:
            raise HCVInputError(
                f"trajectories are provided for zeta < 1 only (got zeta = {self.zeta}); an "
                "overdamped contact never returns to q = 0 in the theory's definition"
            )
        t = np.asarray(t, dtype=float)
        if np.any(~np.isfinite(t)):
            raise HCVInputError(f"times must be finite, got {t[~np.isfinite(t)].flat[0]!r}")
        flat = t.ravel()
        q = np.empty_like(flat)
        v = np.empty_like(flat)
        before, after = flat < 0, flat > self.contact_time
        q[before], v[before] = self.v0 * flat[before], self.v0
        v_out = self.restitution * self.v0
        q[after], v[after] = -v_out * (flat[after] - self.contact_time), -v_out
        osc = self._osc
        rise = (~before) & (flat <= self._t_peak)
        fall = (~after) & (flat > self._t_peak)
        if np.any(rise):
            s = self._invert(self._t_rise, flat[rise], osc.s_peak)
            x = osc.x(s)
            q[rise], v[rise] = self._q_of_x(x), osc.dx(s)
        if np.any(fall):
            span = osc.s_end - osc.s_peak
            d = self._invert(lambda dd: -self._t_fall(dd), -flat[fall], span)
            x = osc.x_from_end(d)
            q[fall], v[fall] = self._q_of_x(x), osc.dx(osc.s_end - d)
        return q.reshape(t.shape), v.reshape(t.shape)

    def _q_of_x(self, x):
        return self.potential._inverse(0.5 * self.m * np.asarray(x, float) ** 2)

    @staticmethod
    def _invert(T, targets, upper):
        """Solve T(y) = target for y in [0, upper], T increasing, vectorised."""
        # Quadratic spacing puts table points where t(s) is steepest (near contact onset).
        grid = upper * np.linspace(0.0, 1.0, _STATE_TABLE) ** 2
        table = T(grid)
        idx = np.clip(np.searchsorted(table, targets), 1, _STATE_TABLE - 1)
        lo, hi = grid[idx - 1], grid[idx]
        exact_lo = targets <= table[0]
        # A target at or past the branch's end T(upper) is its end: the instants given to
        # a branch end at the reported peak time, which may exceed this table's T(upper)
        # by the two quadratures' difference (~1e-15 relative), and no root is bracketed
        # there (state() returned nan at the peak).
        exact_hi = targets >= table[-1]
        from scipy.optimize import elementwise  # here: scipy.optimize costs 0.2 s to import

        res = elementwise.find_root(
            lambda y, tg: T(y) - tg,
            (lo, hi),
            args=(targets,),
            tolerances=dict(xatol=0.0, xrtol=_STATE_XRTOL, fatol=0.0, frtol=0.0),
        )
        return np.where(exact_lo, grid[0], np.where(exact_hi, grid[-1], res.x))


def _conditioning(
    pot: Potential, m: float, osc: VirtualOscillator, q_max: float, f_max: float
) -> float:
    """Relative error of the times from the rounding of U, amplified by the problem.

    A node value dq/dx = m x / U'(q) at q = U^-1(m x^2 / 2) moves by a relative
    c = |U U''| / U'^2 per relative error of U (d ln g / d ln u = 1 - c), so a U
    accurate to _NODE_ULPS ulps (the potentials' contract) gives the times an error
    of up to c _NODE_ULPS eps beyond the quadrature's. c is largest at the peak
    where U' is smallest relative to U: (n - 1)/n < 1 for a power law, but 1e10 for
    a cap 1e-11 below full overlap, where U' -> 0 (issue 22: an error of 1.9e-6
    against a bound of 1.4e-9). Charged at q_max; negligible (< 1 ulp) unless U'
    is small there.
    """
    if type(pot) is PowerLaw:
        return 0.0  # c = (n - 1)/n < 1: within the node ulps already charged
    d2 = curvature(pot, q_max)
    if d2 is None:
        with np.errstate(all="ignore"):
            d2 = float(pot._d2U(np.array([q_max]))[0])
    return _conditioning_at(m, osc.v0, osc.zeta, osc.s_peak, d2, f_max)


def _charge_conditioning(br, pot: Potential, m: float, osc, q_max: float, f_max: float):
    """``br`` with `_conditioning`'s relative error charged to each of its times."""
    cond = _conditioning(pot, m, osc, q_max, f_max)
    if cond > 0.0:
        br = br._make(_charged(cond, *br))
    return br


def _charged(cond: float, rise, err_rise, mid, err_mid, fall, err_fall) -> tuple:
    """The `Branches` fields with a relative error ``cond`` charged to each time's bound
    (one place for `solve_impact` and the prepared call of `reference_impl.exact.prepared`,
    which works on the floats)."""
    return rise, err_rise + cond * rise, mid, err_mid + cond * mid, fall, err_fall + cond * fall


def _check_normal(values: dict, m: float, v0: float) -> None:
    """Refuse results that left the normal float64 range (never report 0.0 or a
    subnormal number, whose relative precision is lost)."""
    for name, val in values.items():
        if not (val >= _TINY):  # inf is allowed (contact time for zeta >= 1)
            raise UnsupportedError(
                f"{name} = {val!r} is below the normal float64 range ({_TINY:.3g}) for m = {m!r} "
                f"kg, v0 = {v0!r} m/s: rescale the units (e.g. mm, g, ms) so that it is a normal "
                "number"
            )


def _check_bound(
    br, pot: Potential, m: float, v0: float, zeta: float, stated: float = RTOL_STATED
) -> None:
    """Refuse a result whose error bound exceeds ``stated`` (RTOL_STATED, or a larger
    ``rtol`` asked) of a finite reported time."""
    for name, t, e in (
        ("contact_time", br.rise + br.fall, br.err_rise + br.err_fall),
        ("contact_time_zero_force", br.rise + br.mid, br.err_rise + br.err_mid),
    ):
        if math.isfinite(t) and not e <= stated * t:
            raise UnsupportedError(
                f"{name} = {t:.16g} s has an error bound of {e:.2g} s ({e / t:.2g} relative), "
                f"above the solver's stated accuracy {stated:g} (potential {pot!r}, m = {m!r}, "
                f"v0 = {v0!r}, zeta = {zeta!r}); not returned as if it met it: use solve_impact_mp"
            )


def solve_impact(
    potential: Potential,
    m: float,
    v0: float,
    zeta: float = 0.0,
    *,
    law=None,
    level: int | None = None,
    rtol: float | None = None,
):
    """Solve one normal impact exactly: the entry point ``reference_impl.solve``.

    The universal law (``zeta``, or ``law`` of route "harmonic map") is solved through
    the harmonic map here; any other registered law goes where its registry entry says
    (`reference_impl.exact._route`, the one place the strategy is chosen).

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m), leading exponent n <= N_MAX.
    m : float
        Mass (kg), > 0.
    v0 : float
        Impact speed (m/s), > 0.
    zeta : float
        Damping ratio of the universal law, 0 <= zeta <= ZETA_MAX, except for the
        narrow band just below 1 where the theory's end of contact leaves float64
        range (see `reference_impl.exact._oscillator.S_END_MAX`); 0 is conservative.
    law : DampingLaw or dict, optional
        Any registered damping law (`reference_impl.theory.laws`), e.g.
        ``{"law": "linear", "c": 3.0}``. A law the harmonic map solves (``universal``:
        give ``zeta`` there, not both; ``none``) uses this exact quadrature; the others
        go to the strategy their registry entry names (`reference_impl.exact._route`) and
        return a `LawImpactSolution` (same field names, plus ``peak_force``).
    level : int, optional
        Level of the tanh-sinh rules (accuracy); default: Gauss-Jacobi rules
        (power laws, and compiled families whose exponents have small
        denominators) when two rule sizes agree to 1e-14, else tanh-sinh at
        level 5 (round-off) for the numpy path, 4 for the compiled families
        (errors <= ~1e-14, bounded by `ImpactSolution.quadrature_error`). A given
        level always uses tanh-sinh.
    rtol : float, optional
        Relative error bound asked of each reported time, in (0, 0.1]; None (default):
        full accuracy, the same result bit for bit. A larger rtol lets the solver use
        fewer quadrature nodes (a power law's Gauss-Jacobi pairs) or longer Taylor steps
        (general laws), see `reference_impl.exact._rtol`; the reported bound
        (``quadrature_error``, ``error_time``) is then at most rtol of the time, or the
        full-accuracy bound where that is the smaller.

    Returns
    -------
    ImpactSolution or LawImpactSolution

    Raises
    ------
    HCVInputError, NoTurningPointError, NonMonotoneError
        For invalid or unsupported inputs (one line naming the value and the
        supported range) or a potential that violates the paper's assumptions
        on [0, q_max].
    UnsupportedError
        The error bound of a reported time exceeds RTOL_STATED of it (the
        message names the bound): the result is refused, never returned as if
        it met the stated accuracy.
    """
    if rtol is not None:
        rtol = checked_rtol(rtol, "solve_impact")
    if law is not None:
        # The law's registry entry chooses the strategy (`_route`, the one place).
        r = route(law, zeta)
        if r.kind != "harmonic map":
            return solve_other(r, potential, m, v0, rtol)
        zeta = r.zeta
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    m = positive("m", m, "solve_impact")
    v0 = positive("v0", v0, "solve_impact")
    zeta = _check_zeta(zeta)
    _check_exponent(potential)
    osc = VirtualOscillator(v0, zeta)
    E = 0.5 * m * v0 * v0
    if not (math.isfinite(E) and E >= _TINY):
        raise HCVInputError(
            f"kinetic energy m v0^2 / 2 = {E!r} J (m = {m!r}, v0 = {v0!r}) is not a positive "
            f"float64 in the normal range [{_TINY:.3g}, {np.finfo(float).max:.3g}] J: rescale the "
            "units (e.g. mm, g, ms) so that the energy and the overlaps are normal numbers"
        )
    # Validates the turning point and monotonicity on (0, q(E)] (the damped
    # maximum penetration is smaller, so this covers every damped path too).
    # A power law whose energy is at or below one validated already: nothing is left to
    # check, and its Gauss-Jacobi strategy does not read q_top; a strategy that does
    # computes it on first use (`_strategies.Job.q_top`, the same value).
    if type(potential) is PowerLaw and _validated_below(potential, E):
        q_top = None
    else:
        q_top = _validated_top(potential, E)
    # The first strategy that answers integrates the impact (`_strategies`, one contract).
    _, (br, q_max, max_force) = choose(Job(potential, m, v0, osc, q_top, level, rtol))
    restitution = math.exp(-math.pi * zeta / osc.wd) if zeta < 1.0 else 0.0
    br = _charge_conditioning(br, potential, m, osc, q_max, max_force)
    _check_bound(
        br, potential, m, v0, zeta, RTOL_STATED if rtol is None else max(rtol, RTOL_STATED)
    )
    if not (q_max >= _TINY and max_force >= _TINY and br.rise + br.fall >= _TINY):
        _check_normal(
            {"max_penetration": q_max, "max_force": max_force, "contact_time": br.rise + br.fall},
            m,
            v0,
        )
    return ImpactSolution._fast(
        {
            "v0": v0,
            "m": m,
            "zeta": zeta,
            "max_penetration": q_max,
            "max_force": max_force,
            "contact_time": br.rise + br.fall,
            "restitution": restitution,
            "contact_time_zero_force": br.rise + br.mid,
            "restitution_zero_force": osc.restitution_zero_force if zeta > 0 else 1.0,
            "quadrature_error": br.err_rise + br.err_fall,
            "quadrature_error_zero_force": br.err_rise + br.err_mid,
            "potential": potential,
            "_osc": osc,
            "_t_peak": br.rise,
        }
    )
