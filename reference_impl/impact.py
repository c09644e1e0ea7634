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
from functools import lru_cache

import mpmath
import numba
import numpy as np
from scipy import integrate
from scipy.optimize import elementwise
from scipy.special import roots_jacobi

from ._quadrature import DEFAULT_LEVEL, integrate_left_singular, rule, sums_from_values
from .damping import _check_zeta
from .errors import HCVInputError
from .potentials._checks import positive
from .potentials.base import Potential
from .potentials.power import PowerLaw

__all__ = ["ImpactSolution", "solve_impact", "solve_impact_mp", "VirtualOscillator"]

# Gauss-Jacobi fast path for power laws: rule sizes compared, the agreement required
# (relative to the rising-branch time), and the range where scipy's rules and the
# geometric convergence rate are good enough (measured: round-off for p <= 3, zeta <= 0.9).
_GJ_SIZES = (16, 24)
_GJ_RTOL = 1e-14
_GJ_BETA_MIN = -0.5
_GJ_ZETA_MAX = 0.9
# Branches shorter than this fraction of the contact (in virtual time) are empty.
_TINY_BRANCH = 1e-250
# Relative tolerance for locating s(t) in `ImpactSolution.state`: a few ulps.
_STATE_XRTOL = 8.0 * np.finfo(float).eps
# Number of table points used to bracket s(t) before the root finder polishes it.
_STATE_TABLE = 65


class VirtualOscillator:
    """The damped linear oscillator x'' + 2 zeta x' + x = 0, x(0) = 0, x'(0) = v0.

    Parameters
    ----------
    v0 : float
        Initial virtual velocity (equal to the impact speed, m/s, since M = m).
    zeta : float
        Damping ratio (>= 0).
    """

    def __init__(self, v0: float, zeta: float):
        self.v0 = v0
        self.zeta = zeta
        if zeta < 1.0:
            self.wd = math.sqrt(1.0 - zeta * zeta)
            # tan(wd s_peak) = wd / zeta
            self.s_peak = math.atan2(self.wd, zeta) / self.wd
            self.s_end = math.pi / self.wd
        elif zeta == 1.0:
            self.wd = 0.0
            self.s_peak = 1.0
            self.s_end = math.inf
        else:
            r = math.sqrt(zeta * zeta - 1.0)
            self.r1, self.r2 = -zeta + r, -zeta - r
            self.wd = 0.0
            self.s_peak = math.log(self.r2 / self.r1) / (self.r1 - self.r2)
            self.s_end = math.inf
        # x'' = 0 at exactly twice the peak time (see module docstring).
        self.s_zero_force = 2.0 * self.s_peak

    def x(self, s):
        """Virtual displacement x(s)."""
        z, v0 = self.zeta, self.v0
        if z < 1.0:
            return v0 / self.wd * np.exp(-z * s) * np.sin(self.wd * s)
        if z == 1.0:
            return v0 * s * np.exp(-s)
        return v0 / (self.r1 - self.r2) * (np.exp(self.r1 * s) - np.exp(self.r2 * s))

    def x_from_end(self, d):
        """x at s = s_end - d, accurate for small d (underdamped only)."""
        return self.v0 / self.wd * np.exp(-self.zeta * (self.s_end - d)) * np.sin(self.wd * d)

    def dx(self, s):
        """Virtual velocity x'(s)."""
        z, v0 = self.zeta, self.v0
        if z < 1.0:
            e = np.exp(-z * s)
            return v0 / self.wd * e * (self.wd * np.cos(self.wd * s) - z * np.sin(self.wd * s))
        if z == 1.0:
            return v0 * (1.0 - s) * np.exp(-s)
        r1, r2 = self.r1, self.r2
        return v0 / (r1 - r2) * (r1 * np.exp(r1 * s) - r2 * np.exp(r2 * s))


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
        Estimated absolute error of `contact_time` (s).
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
    potential: Potential = field(repr=False, compare=False)
    _osc: VirtualOscillator = field(repr=False, compare=False)
    _t_peak: float = field(repr=False, compare=False)

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
        return _dq_dx(self.potential, self.m, x)

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
        res = elementwise.find_root(
            lambda y, tg: T(y) - tg,
            (lo, hi),
            args=(targets,),
            tolerances=dict(xatol=0.0, xrtol=_STATE_XRTOL, fatol=0.0, frtol=0.0),
        )
        return np.where(exact_lo, grid[0], res.x)


def _dq_dx(pot: Potential, m: float, x):
    """dq/dx = sqrt(2 K U) / U' = m x / U'(q) with K = m, at q = U^-1(m x^2/2)."""
    x = np.asarray(x, dtype=float)
    if type(pot) is PowerLaw:
        # Closed form: q = (n m x^2 / 2k)^(1/n) gives dq/dx = c x^(2/n - 1), one power
        # instead of an inverse and a force evaluation.
        n = pot.leading_exponent
        c = m / pot.k * (0.5 * n * m / pot.k) ** (-pot.p / n)
        return c * x ** (2.0 / n - 1.0)
    q = pot._inverse((0.5 * m * x * x).ravel()).reshape(x.shape)
    return m * x / pot._dU(q)


def solve_impact(
    potential: Potential, m: float, v0: float, zeta: float = 0.0, *, level: int = DEFAULT_LEVEL
) -> ImpactSolution:
    """Solve one normal impact exactly through the harmonic map.

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Mass (kg), > 0.
    v0 : float
        Impact speed (m/s), > 0.
    zeta : float
        Damping ratio of the universal law (>= 0); 0 is conservative.
    level : int
        Level of the tanh-sinh rules (accuracy; the default reaches round-off).

    Returns
    -------
    ImpactSolution

    Raises
    ------
    HCVInputError, NoTurningPointError, NonMonotoneError
        For invalid inputs or a potential that violates the paper's assumptions
        on [0, q_max].
    """
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    m = positive("m", m, "solve_impact")
    v0 = positive("v0", v0, "solve_impact")
    zeta = _check_zeta(zeta)
    E = 0.5 * m * v0 * v0
    # Validates the turning point and monotonicity on (0, q(E)] (the damped
    # maximum penetration is smaller, so this covers every damped path too).
    potential.turning_point(E)
    osc = VirtualOscillator(v0, zeta)
    beta = 2.0 / potential.leading_exponent - 1.0
    fast = _gauss_jacobi_power_law(potential, m, osc, beta) if type(potential) is PowerLaw else None
    if fast is not None:
        vals, errs = fast
    else:
        vals, errs = _tanh_sinh_branches(potential, m, osc, beta, level)
    t_peak, err_rise = float(vals[0]), float(errs[0])
    x_peak = float(osc.x(osc.s_peak))
    q_max = float(potential._inverse(np.array([0.5 * m * x_peak**2]))[0])
    max_force = float(potential._dU(np.array([q_max]))[0])

    falling = 0.0 < zeta < 1.0
    if zeta == 0.0:
        # Symmetric: the falling branch mirrors the rising one.
        t_fall, err_fall = t_peak, err_rise
    elif falling:
        t_fall, err_fall = float(vals[1]), float(errs[1])
    else:
        t_fall, err_fall = _overdamped_tail(potential, m, osc, beta), 0.0
    contact_time = t_peak + t_fall

    if zeta < 1.0:
        restitution = math.exp(-math.pi * zeta / osc.wd)
    else:
        restitution = 0.0
    if zeta == 0.0:
        t_zero_force, e_zero_force = contact_time, 1.0
    else:
        t_zero_force = contact_time - float(vals[2]) if falling else t_peak + float(vals[-1])
        e_zero_force = float(-osc.dx(osc.s_zero_force) / v0)
    return ImpactSolution(
        v0=v0,
        m=m,
        zeta=zeta,
        max_penetration=q_max,
        max_force=max_force,
        contact_time=float(contact_time),
        restitution=restitution,
        contact_time_zero_force=float(t_zero_force),
        restitution_zero_force=e_zero_force,
        quadrature_error=float(err_rise + err_fall),
        potential=potential,
        _osc=osc,
        _t_peak=float(t_peak),
    )


def _branch_rows(osc: VirtualOscillator):
    """Branches (S0, S1, Phi0, Phi1, length) with x = A exp(-zeta S) sin(wd Phi), S and Phi
    affine in the distance d from the branch's singular end: the rising branch (from
    s = 0), the falling branch (back from s_end) and the stretch from the zero-force
    instant to s_end (back from s_end; its length 2 atan2(zeta, wd)/wd is written
    without the cancellation that makes s_end - 2 s_peak zero in floats for tiny zeta).
    Underdamped only; the falling rows are omitted for zeta = 0 (symmetric)."""
    sp = osc.s_peak
    rows = [(0.0, sp, 0.0, sp, sp)]
    if osc.zeta > 0.0:
        lf = osc.s_end - sp
        rows.append((osc.s_end, -lf, 0.0, lf, lf))
        lz = 2.0 * math.atan2(osc.zeta, osc.wd) / osc.wd
        if lz < _TINY_BRANCH * osc.s_end:
            lz = 0.0  # zeta so small (subnormal) that the stretch is empty in floats
        rows.append((osc.s_end, -lz, 0.0, lz, lz))
    return np.array(rows)


def _x_on_rows(osc: VirtualOscillator, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """x at relative nodes d in [0, 1] of each branch row of `_branch_rows`."""
    # x = A exp(-zeta S0) exp(-zeta S1 d) sin(wd Phi0 + wd Phi1 d), few temporaries.
    z, wd = osc.zeta, osc.wd
    out = np.exp(np.multiply.outer(-z * c[:, 1], d))
    out *= np.sin(np.multiply.outer(wd * c[:, 3], d) + (wd * c[:, 2])[:, None])
    out *= ((osc.v0 / wd) * np.exp(-z * c[:, 0]))[:, None]
    return out


@lru_cache(maxsize=32)
def _jacobi_pair(beta: float):
    """Nodes u in (0, 1) of the Gauss-Jacobi rules of sizes _GJ_SIZES for
    int_0^1 f(u) u^beta du, concatenated, and a (nodes, 2) weight matrix whose
    columns give the two rules (zeros on the other rule's nodes)."""
    us, cols = [], []
    for size in _GJ_SIZES:
        y, w = roots_jacobi(size, 0.0, beta)
        us.append((1.0 + y) / 2.0)
        cols.append(w / 2.0 ** (beta + 1.0))
    u = np.concatenate(us)
    W = np.zeros((u.size, len(_GJ_SIZES)))
    W[: _GJ_SIZES[0], 0] = cols[0]
    W[_GJ_SIZES[0] :, 1] = cols[1]
    return u, W


def _gauss_jacobi_power_law(pot: PowerLaw, m: float, osc: VirtualOscillator, beta: float):
    """Branch integrals for a power law by Gauss-Jacobi, or None when not applicable.

    For U = k q^n / n, dq/dx = c x^beta exactly and x(s) = s h(s) with h analytic, so
    dq/dx = c h^beta s^beta: Gauss-Jacobi with weight s^beta converges geometrically
    (rate set by the zero of h at s_end). Two rule sizes are compared and the result
    is used only when they agree to _GJ_RTOL; scipy's Jacobi rules lose accuracy for
    beta near -1, hence the range limit.
    """
    if osc.zeta >= _GJ_ZETA_MAX or beta < _GJ_BETA_MIN:
        return None
    n = pot.leading_exponent
    c_pl = m / pot.k * (0.5 * n * m / pot.k) ** (-pot.p / n)
    rows = _branch_rows(osc)
    u, W = _jacobi_pair(beta)
    L = rows[:, 4]
    if L.min() <= 0:
        return None  # an empty stretch: the tanh-sinh path handles it
    sums = _gj_sums(rows, u, W, osc.zeta, osc.wd, osc.v0, beta, c_pl)
    coarse, fine = sums[:, 0], sums[:, 1]
    err = np.abs(fine - coarse)
    if err.max() > _GJ_RTOL * abs(fine[0]):
        return None
    return fine, err


@numba.njit(cache=True)
def _gj_sums(rows, u, W, zeta, wd, v0, beta, c_pl):  # pragma: no cover - compiled
    """sum_j W[j, k] c (x(s_j)/s_j)^beta L^(beta+1) per branch row (see _x_on_rows).

    Compiled: ~120 nodes make numpy's per-call overhead dominate (39 us vs ~5 us).
    """
    nr, nn = rows.shape[0], u.shape[0]
    out = np.zeros((nr, W.shape[1]))
    amp = v0 / wd
    for i in range(nr):
        s0, s1, p0, p1, L = rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4]
        scale = c_pl * L ** (beta + 1.0)
        for j in range(nn):
            d = u[j]
            x = amp * np.exp(-zeta * (s0 + s1 * d)) * np.sin(wd * (p0 + p1 * d))
            f = scale * (x / (L * d)) ** beta
            for k in range(W.shape[1]):
                out[i, k] += W[j, k] * f
    return out


def _tanh_sinh_branches(pot: Potential, m: float, osc: VirtualOscillator, beta: float, level: int):
    """Branch integrals by the tanh-sinh rules of `_quadrature` (any monotone potential)."""
    r = rule(level, beta)
    d = r.d
    if osc.zeta < 1.0:
        c = _branch_rows(osc)
        xs = _x_on_rows(osc, c, d)
        lengths = c[:, 4]
    else:
        sp = osc.s_peak
        lengths = np.array([sp, osc.s_zero_force - sp])
        xs = np.stack([osc.x(sp * d), osc.x(sp + lengths[1] * d)])
    betas = np.full(len(lengths), beta)
    if osc.zeta >= 1.0:
        betas[-1] = 0.0  # the peak-to-zero-force stretch is smooth (x > 0)
    g = _dq_dx(pot, m, xs)
    return sums_from_values(g, lengths, betas, r)


def _overdamped_tail(pot: Potential, m: float, osc: VirtualOscillator, beta: float) -> float:
    """Physical time from the peak to q = 0 when zeta >= 1 (x -> 0 only as s -> inf).

    dq/dx ~ x^beta with x decaying exponentially: the time is finite only for
    beta > 0 (softening contacts, n < 2), infinite otherwise.
    """
    if beta <= 0:
        return math.inf
    val, _ = integrate.quad(
        lambda s: float(_dq_dx(pot, m, np.array([osc.x(s)]))[0]),
        osc.s_peak,
        np.inf,
        epsabs=0.0,
        epsrel=1e-12,
        limit=200,
    )
    return val


def solve_impact_mp(potential: Potential, m, v0, zeta=0, *, dps: int = 30) -> dict:
    """High-precision (mpmath) version of `solve_impact`, for ground truth.

    The same virtual-time integral t_c = int_0^{s_end} (dq/dx)(x(s)) ds is
    evaluated with mpmath's tanh-sinh quadrature at ``dps`` digits, split at the
    peak, after a substitution that removes the d^beta endpoint behaviour; q(x) is
    found by a bracketing root finder at that precision.
    Underdamped contacts only.

    Validity: checked against the Beta-function closed forms and for consistency
    between 25 and 35 digits for leading exponents n <= 5 (p <= 4); for steeper
    laws (p = 10) mpmath's quadrature did not converge to its working precision
    (results moved by 1e-7 between precisions), so it is not used as truth there.

    Returns
    -------
    dict
        contact_time, max_penetration, restitution, contact_time_zero_force,
        restitution_zero_force as mpmath numbers.
    """
    zeta_f = _check_zeta(float(zeta))
    if zeta_f >= 1:
        raise HCVInputError(f"solve_impact_mp needs zeta < 1, got {zeta!r}")
    with mpmath.workdps(dps + 10):
        m, v0, z = mpmath.mpf(m), mpmath.mpf(v0), mpmath.mpf(zeta)
        wd = mpmath.sqrt(1 - z * z)
        s_peak = mpmath.atan2(wd, z) / wd
        s_end = mpmath.pi / wd

        def x(s):
            return v0 / wd * mpmath.exp(-z * s) * mpmath.sin(wd * s)

        n_lead = mpmath.mpf(potential.leading_exponent)
        q_ref = mpmath.mpf(potential.q_scale)
        u_ref = potential._U(q_ref)

        def q_of_x(xv):
            u = m * xv * xv / 2
            uf = float(u)
            if uf > 1e-290:
                q0 = mpmath.mpf(float(potential._inverse(np.array([uf]))[0]))
                lo, hi = q0 * (1 - 1e-9), q0 * (1 + 1e-9)
            else:
                # Below float range: seed from the leading power law U ~ u_ref (q/q_ref)^n.
                q0 = q_ref * (u / u_ref) ** (1 / n_lead)
                lo, hi = q0 / 2, q0 * 2
            return mpmath.findroot(lambda q: potential._U(q) - u, (lo, hi), solver="anderson")

        def g(s):
            xv = x(s)
            return m * xv / potential._dU(q_of_x(xv)) if xv > 0 else mpmath.mpf(0)

        # dq/dx ~ d^beta at both ends of contact; the substitution d = L sigma^(1/(1+beta))
        # turns g dd into a bounded integrand, which tanh-sinh then resolves to full
        # precision (without it mpmath.quad loses digits for beta near -1).
        beta = mpmath.mpf(2) / mpmath.mpf(potential.leading_exponent) - 1
        k = 1 / (1 + beta)

        def from_start(length):
            return mpmath.quad(lambda sg: g(length * sg**k) * length * k * sg ** (k - 1), [0, 1])

        def from_end(length):
            return mpmath.quad(
                lambda sg: g(s_end - length * sg**k) * length * k * sg ** (k - 1), [0, 1]
            )

        t_peak = from_start(s_peak)
        t_end = t_peak + from_end(s_end - s_peak)
        t_zf = t_end - from_end(s_end - 2 * s_peak) if z > 0 else t_end

        def dx(s):
            return v0 / wd * mpmath.exp(-z * s) * (wd * mpmath.cos(wd * s) - z * mpmath.sin(wd * s))

        return {
            "contact_time": t_end,
            "max_penetration": q_of_x(x(s_peak)),
            "restitution": -dx(s_end) / v0,
            "contact_time_zero_force": t_zf,
            "restitution_zero_force": -dx(2 * s_peak) / v0 if z > 0 else mpmath.mpf(1),
        }
