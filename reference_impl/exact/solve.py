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
import weakref
from dataclasses import asdict, dataclass, field

import numpy as np

from reference_impl.exact._branches import branch_integrals, compiled_nodes, dq_dx
from reference_impl.exact._one_call import fused_impact
from reference_impl.exact._oscillator import S_END_MAX, ZETA_MAX, VirtualOscillator
from reference_impl.exact._quadrature import integrate_left_singular
from reference_impl.exact._truth import solve_impact_mp
from reference_impl.theory.damping import _check_zeta
from reference_impl.errors import HCVInputError
from reference_impl.potentials._checks import positive
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

__all__ = [
    "ImpactSolution",
    "N_MAX",
    "S_END_MAX",
    "ZETA_MAX",
    "VirtualOscillator",
    "solve_impact",
    "solve_impact_mp",
]

# Largest leading exponent n (U ~ q^n) accepted: beta = 2/n - 1 >= -0.905. Above it
# the endpoint singularity s^beta is so close to non-integrable that the float rules
# lost digits (p = 50: 8th digit, p = 1000: 5th, issue 12).
N_MAX = 21.0
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
        Elastic force U'(q_max) at maximum penetration (N), as in Table 1.
    contact_time : float
        Duration until q returns to 0 (s); inf when it never does (zeta >= 1).
    restitution : float
        -v_out / v0 at q = 0 (theory's end of contact).
    contact_time_zero_force : float
        Duration until the total force U' + C q' first vanishes (s).
    restitution_zero_force : float
        -v / v0 at that instant: the restitution of a code that clips tensile force.
    quadrature_error : float
        Bound on the absolute error of `contact_time` (s): quadrature estimate
        plus round-off (checked against the mpmath truth by the tests).
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
    def _fast(cls, **fields) -> ImpactSolution:
        """Construct without the frozen dataclass __init__ (one object.__setattr__ per
        field cost ~2 us, a tenth of a compiled-family impact); every field is given
        and there is no __post_init__, so the instance is the same."""
        obj = object.__new__(cls)
        obj.__dict__.update(fields)
        return obj

    def to_dict(self) -> dict:
        """The scalar results as a plain dict (for JSON)."""
        d = asdict(self)
        for key in ("potential", "_osc", "_t_peak"):
            d.pop(key, None)
        return d

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
        from scipy.optimize import elementwise  # here: scipy.optimize costs 0.2 s to import

        res = elementwise.find_root(
            lambda y, tg: T(y) - tg,
            (lo, hi),
            args=(targets,),
            tolerances=dict(xatol=0.0, xrtol=_STATE_XRTOL, fatol=0.0, frtol=0.0),
        )
        return np.where(exact_lo, grid[0], res.x)


def _check_exponent(pot: Potential) -> float:
    """The leading exponent n, refused above N_MAX (see there)."""
    n = float(pot.leading_exponent)
    if not (math.isfinite(n) and 0.0 < n <= N_MAX):
        raise HCVInputError(
            f"leading exponent n = {n:.6g} of U ~ q^n is outside (0, {N_MAX:g}] (power law "
            f"p = n - 1 <= {N_MAX - 1:g}): dq/dx ~ s^(2/n - 1) is then too close to "
            "non-integrable for the float quadrature to keep 1e-13"
        )
    return n


_VALIDATED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _validated_top(pot: Potential, E: float) -> float:
    """An overlap q_top >= q_max(E) with U' > 0 checked on (0, q_top] (assumption 3).

    The check (a grid of ~2600 points) dominated the cost of one impact; the
    largest validated turning point is kept per potential object, and a lower
    energy reuses it: its bracket (0, q_top] contains every overlap of the impact.
    Potentials are immutable after construction, so the cache cannot go stale.
    """
    try:
        e_c, q_c = _VALIDATED[pot]
    except (KeyError, TypeError):
        e_c = q_c = None
    if e_c is not None and E <= e_c:
        return q_c
    q = pot.turning_point(E)
    try:
        _VALIDATED[pot] = (E, q)
    except TypeError:
        pass
    return q


def _peak(pot: Potential, m: float, osc: VirtualOscillator, q_top: float) -> tuple[float, float]:
    """q_max and U'(q_max): x(s_peak) = v0 exp(-zeta s_peak) (S(s_peak) = 1, see _oscillator)."""
    x_peak = osc.v0 * math.exp(-osc.zeta * osc.s_peak)
    if type(pot) is PowerLaw:
        n = pot.leading_exponent
        q_max = (0.5 * n * m * x_peak * x_peak / pot.k) ** (1.0 / n)
        return q_max, pot.k * q_max**pot.p
    compiled = compiled_nodes(pot)
    if compiled is not None:
        g_pk, q_pk = compiled(np.array([x_peak]), m, q_top)
        return float(q_pk[0]), m * x_peak / float(g_pk[0])
    q_max = float(pot._inverse(np.array([0.5 * m * x_peak**2]))[0])
    return q_max, float(pot._dU(np.array([q_max]))[0])


def solve_impact(
    potential: Potential, m: float, v0: float, zeta: float = 0.0, *, level: int | None = None
) -> ImpactSolution:
    """Solve one normal impact exactly through the harmonic map.

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
    level : int, optional
        Level of the tanh-sinh rules (accuracy); default: Gauss-Jacobi rules
        (power laws, and compiled families whose exponents have small
        denominators) when two rule sizes agree to 1e-14, else tanh-sinh at
        level 5 (round-off) for the numpy path, 4 for the compiled families
        (errors <= ~1e-14, bounded by `ImpactSolution.quadrature_error`). A given
        level always uses tanh-sinh.

    Returns
    -------
    ImpactSolution

    Raises
    ------
    HCVInputError, NoTurningPointError, NonMonotoneError
        For invalid or unsupported inputs (one line naming the value and the
        supported range) or a potential that violates the paper's assumptions
        on [0, q_max].
    """
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    m = positive("m", m, "solve_impact")
    v0 = positive("v0", v0, "solve_impact")
    zeta = _check_zeta(zeta)
    _check_exponent(potential)
    osc = VirtualOscillator(v0, zeta)
    E = 0.5 * m * v0 * v0
    if not (math.isfinite(E) and E > 0):
        raise HCVInputError(
            f"kinetic energy m v0^2 / 2 = {E!r} J (m = {m!r}, v0 = {v0!r}) is not a positive float64"
        )
    # Validates the turning point and monotonicity on (0, q(E)] (the damped
    # maximum penetration is smaller, so this covers every damped path too).
    q_top = _validated_top(potential, E)
    fast = None
    if level is None and type(potential) is not PowerLaw:
        fast = fused_impact(potential, m, osc, q_top)
    if fast is not None:
        br, q_max, max_force = fast
    else:
        br = branch_integrals(potential, m, osc, level, q_top)
        q_max, max_force = _peak(potential, m, osc, q_top)
    restitution = math.exp(-math.pi * zeta / osc.wd) if zeta < 1.0 else 0.0
    return ImpactSolution._fast(
        v0=v0,
        m=m,
        zeta=zeta,
        max_penetration=q_max,
        max_force=max_force,
        contact_time=br.rise + br.fall,
        restitution=restitution,
        contact_time_zero_force=br.rise + br.mid,
        restitution_zero_force=osc.restitution_zero_force if zeta > 0 else 1.0,
        quadrature_error=br.err_rise + br.err_fall,
        quadrature_error_zero_force=br.err_rise + br.err_mid,
        potential=potential,
        _osc=osc,
        _t_peak=br.rise,
    )
