"""High-precision (mpmath) ground truth for the exact impact solver.

The same virtual-time integrals as the float solver (rise, peak to zero force,
zero force to the end of contact), evaluated with mpmath's tanh-sinh quadrature
at ``dps`` digits with guard digits, q(x) = U^-1(m x^2/2) by Newton's method at
that precision. Three things make it agree with itself at 30 and 50 digits:

* near the theory's end of contact x is evaluated from the distance d to s_end
  (x = v0 exp(-zeta (s_end - d)) sin(wd d)/wd), never as x(s_end - d): the old
  form lost every digit for d below the working precision and made the truth
  move by 1e-7 between precisions for n = 11 (issue 8);
* the endpoint behaviour d^beta is removed by d = L sigma^(1/(1+beta)), and each
  stretch is split so that tanh-sinh sees a bounded, smooth integrand;
* every quadrature's own error estimate is checked against the requested
  precision, and the call refuses (HCVInputError) rather than return digits it
  did not reach.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact._oscillator import S_END_MAX, ZETA_MAX
from reference_impl.potentials.base import Potential
from reference_impl.theory.damping import _check_zeta

__all__ = ["MpInverse", "solve_impact_mp"]

# Guard digits carried above the requested precision.
_GUARD = 15
# Newton iterations of the inverse of U at high precision (quadratic: ~8 suffice).
_NEWTON_MAX = 100
# Guard bits of `MpInverse` against cancellation in U: the first try with extra bits uses
# this many, doubled up to _EXTRA_MAX times the working precision (a saturating force at
# x = 1e-30 loses 200 bits); each result is checked with _CHECK_BITS more.
_EXTRA_START = 32
_EXTRA_MAX = 8
_CHECK_BITS = 32
# Seed table of `MpInverse` given the largest energy: this many energies, geometric
# from u_max * _SEED_SPAN to u_max (one vectorised float inverse for all calls).
_SEED_POINTS = 400
_SEED_SPAN = 1e-40
# Float Newton steps on log U refining a table seed (quadratic: the seed to ~1e-15).
_SEED_NEWTON = 3
# Breakpoints (fractions of the substituted unit interval) splitting each stretch.
_SPLIT = (0, 0.125, 0.5, 1)


def _x_funcs(v0, z):
    """x(s), x from the end d -> x(s_end - d), and s_peak, s_end in mpmath."""
    if z < 1:
        wd = mpmath.sqrt((1 - z) * (1 + z))

        def x(s):
            return v0 * mpmath.exp(-z * s) * mpmath.sin(wd * s) / wd

        s_end = mpmath.pi / wd

        def x_end(d):
            return v0 * mpmath.exp(-z * (s_end - d)) * mpmath.sin(wd * d) / wd

        return x, x_end, mpmath.atan2(wd, z) / wd, s_end
    if z == 1:
        return (lambda s: v0 * s * mpmath.exp(-s)), None, mpmath.mpf(1), mpmath.inf
    r = mpmath.sqrt((z - 1) * (z + 1))

    def x(s):
        return v0 * mpmath.exp(-z * s) * mpmath.sinh(r * s) / r

    return x, None, mpmath.log(z + r) / r, mpmath.inf


class MpInverse:
    """q(u) with U(q) = u (J -> m) at the working mpmath precision.

    A float seed, then Newton on log U against log q in mpmath. The seed: without
    ``u_max``, one float ``_inverse`` per call; with ``u_max`` (J),
    log-log interpolation in a table of `_SEED_POINTS` energies from u_max *
    `_SEED_SPAN` to u_max (one vectorised float inverse for all calls; the leading
    power law below it), refined by float Newton steps on log U. The table is what
    makes thousands of calls cheap: the work-precision study's trajectory truth takes
    1.6-7x less time than with a float inverse per call on its scenes whose float
    inverse is numeric, `solve_impact_mp` 1.7-6.5x (measured). Energies without a float seed start from the
    leading power law U ~ U(q_ref) (q/q_ref)^n in mpmath. Call it inside the working
    precision. Where U loses digits to cancellation (the saturating force's
    q_s F0 (x - atan x) as x -> 0), U is evaluated with guard bits, doubled until
    Newton converges and a check with more bits confirms it (`_newton`).

    Raises
    ------
    HCVInputError
        When Newton does not converge.
    """

    def __init__(self, pot: Potential, u_max: float | None = None):
        self.pot = pot
        self._table = None
        # guard bits of the last converged call (a start for the next; see __call__)
        self._extra = 0
        if u_max is not None:
            u_tab = u_max * np.geomspace(_SEED_SPAN, 1.0, _SEED_POINTS)
            with np.errstate(all="ignore"):
                q_tab = np.asarray(pot._inverse(u_tab), dtype=float)
            ok = np.isfinite(q_tab) & (q_tab > 0)
            if np.any(ok):
                self._table = (np.log(u_tab[ok]), np.log(q_tab[ok]), float(pot.leading_exponent))

    def _float_seed(self, uf: float) -> float:
        """q (m) with U(q) ~ uf (J) in floats, or 0.0 when there is none in range."""
        q = 0.0
        if 1e-290 < uf < 1e290:
            if self._table is None:
                with np.errstate(all="ignore"):
                    q = float(self.pot._inverse(np.array([uf]))[0])
            else:
                q = self._table_seed(uf)
        return q if 1e-300 < q < 1e300 else 0.0

    def _table_seed(self, uf: float) -> float:
        lu_tab, lq_tab, n_lead = self._table
        lu = math.log(uf)
        if lu < lu_tab[0]:  # below the table: the leading power law U ~ c q^n
            lq = lq_tab[0] + (lu - lu_tab[0]) / n_lead
        else:
            lq = float(np.interp(lu, lu_tab, lq_tab))
        q = math.exp(lq)
        for _ in range(_SEED_NEWTON):
            qa = np.array([q])  # the hooks take arrays (Potential contract, item 1)
            uq = float(self.pot._U(qa)[0])
            if not (uq > 0 and math.isfinite(uq)):
                break
            q *= math.exp(-(math.log(uq) - lu) * uq / (q * float(self.pot._dU(qa)[0])))
        return q

    def __call__(self, u):
        pot = self.pot
        qf = self._float_seed(float(u))
        if qf > 0:
            q = mpmath.mpf(qf)
        else:
            n_lead = mpmath.mpf(pot.leading_exponent)
            q_ref = mpmath.mpf(pot.q_scale)
            q = q_ref * (u / pot._U(q_ref)) ** (1 / n_lead)
        prec = mpmath.mp.prec
        lu = mpmath.log(u)
        # log U carries an absolute rounding error ~ |log u| ulps: the step cannot get smaller.
        tol = mpmath.mpf(2) ** (-prec + 8) * max(1, abs(lu))
        # U itself may lose digits to cancellation (the saturating force's q_s F0 (x - atan x)
        # loses 2 log10(1/x) digits as x -> 0): Newton then stalls at U's noise, above tol.
        # So U is evaluated with `extra` guard bits, doubled until the result holds.
        extra = self._extra
        while extra <= _EXTRA_MAX * prec:
            with mpmath.workprec(prec + extra):
                qx = self._newton(+q, u, lu, tol)
            if qx is not None:
                self._extra = extra
                return +qx
            extra = max(2 * extra, _EXTRA_START)
        raise HCVInputError(
            f"inverse of U at {mpmath.mp.dps} digits: Newton for U(q) = {mpmath.nstr(u, 8)} J "
            f"did not converge ({pot!r})"
        )

    def _newton(self, q, u, lu, tol):
        """Newton on log U from q at the current precision; None when U's noise stops it.

        A step below tol is accepted only when log U(q) with `_CHECK_BITS` more bits is
        within 4 tol of log u too: where U cancels, its computed value is quantised
        (steps of an ulp of the terms, not of U), so Newton can stop on a step of exactly
        0 with q off by that quantum (measured: 4e-21 relative at 40 digits, u = 5e-61 J
        on the saturating force); more bits refine the quantum and expose it.
        """
        pot = self.pot
        for _ in range(_NEWTON_MAX):
            U = pot._U(q)
            if not U > 0:  # every digit cancelled
                return None
            slope = q * pot._dU(q) / U  # d log U / d log q
            step = (mpmath.log(U) - lu) / slope
            q = q * mpmath.exp(-step)
            if abs(step) < tol:
                with mpmath.workprec(mpmath.mp.prec + _CHECK_BITS):
                    Uc = pot._U(q)
                    if Uc > 0 and abs(mpmath.log(Uc) - lu) <= 4 * tol * abs(slope):
                        return q
                return None
        return None


def solve_impact_mp(potential: Potential, m, v0, zeta=0, *, dps: int = 30) -> dict:
    """High-precision (mpmath) solution of one impact, for ground truth.

    Parameters
    ----------
    potential : Potential
        Contact potential (its hooks must accept mpmath numbers).
    m, v0 : float
        Mass (kg) and impact speed (m/s).
    zeta : float
        Damping ratio, as accepted by `solve_impact`.
    dps : int
        Decimal digits of the result.

    Returns
    -------
    dict
        contact_time (inf when zeta >= 1 and n >= 2), max_penetration,
        restitution, contact_time_zero_force, restitution_zero_force as mpmath numbers.

    Raises
    ------
    HCVInputError
        Unsupported zeta, or a quadrature that did not reach ``dps`` digits.
    """
    zeta_f = _check_zeta(float(zeta))
    if zeta_f > ZETA_MAX:
        raise HCVInputError(f"damping ratio zeta = {zeta!r} is outside [0, {ZETA_MAX:g}]")
    if zeta_f < 1 and math.pi / math.sqrt((1 - zeta_f) * (1 + zeta_f)) > S_END_MAX:
        raise HCVInputError(
            f"damping ratio zeta = {zeta!r} is too close to 1 (s_end > {S_END_MAX:g}), as in "
            "solve_impact"
        )
    with mpmath.workdps(dps + _GUARD):
        m, v0, z = mpmath.mpf(m), mpmath.mpf(v0), mpmath.mpf(zeta)
        x, x_end, s_peak, s_end = _x_funcs(v0, z)
        n_lead = mpmath.mpf(potential.leading_exponent)
        # The seed table spans the energies of the impact (<= m v0^2 / 2): 1.7-6.5x faster
        # than a float inverse per node on the catalogue's damped scenes, the same 35 digits.
        inverse = MpInverse(potential, float(m * v0 * v0 / 2))
        beta = 2 / n_lead - 1
        k = 1 / (1 + beta)
        target = mpmath.mpf(10) ** (-dps - 3)

        def g(xv):
            q = inverse(m * xv * xv / 2)
            return m * xv / potential._dU(q)

        # mpmath.quad stops at an absolute error of 10^-dps: integrate in units of a
        # characteristic time (the rise time of the leading power law, q_peak / v0),
        # so that its tolerance is relative whatever the scale of U (k = 1e+-300).
        q_pk = inverse(m * x(s_peak) ** 2 / 2)
        t_unit = q_pk / v0

        def quad(f, span):
            val, err = mpmath.quad(lambda s: f(s) / t_unit, span, error=True, maxdegree=10)
            val, err = val * t_unit, err * t_unit
            # Relative to the contact's time scale too: a vanishing stretch (zeta ~ 1e-200)
            # needs no digits of its own.
            if err > target * max(abs(val), t_unit):
                raise HCVInputError(
                    f"solve_impact_mp: quadrature error {mpmath.nstr(err, 3)} above 1e-{dps + 3} "
                    f"relative (n = {float(n_lead):.6g}, zeta = {zeta!r}); not used as truth"
                )
            return val

        def singular(xf, length):
            # d = length sigma^k: g dd = g(x(d)) length k sigma^(k-1) dsigma, bounded.
            return quad(lambda sg: g(xf(length * sg**k)) * length * k * sg ** (k - 1), _SPLIT)

        t_rise = singular(x, s_peak)
        if z == 0:
            t_mid, t_end = t_rise, 2 * t_rise
        elif z < 1:
            # Stretch [2 s_peak, s_end], its length written without cancellation.
            wd = mpmath.sqrt((1 - z) * (1 + z))
            lz = 2 * mpmath.atan2(z, wd) / wd
            stretch = singular(x_end, lz)
            if lz < s_peak:
                # Zero force close to s_end: the mid stretch would end near a singularity.
                t_fall = singular(x_end, s_end - s_peak)
                t_mid, t_end = t_fall - stretch, t_rise + t_fall
            else:
                t_mid = quad(lambda s: g(x(s)), [s_peak, (3 * s_peak) / 2, 2 * s_peak])
                t_end = t_rise + t_mid + stretch
        else:
            t_mid = quad(lambda s: g(x(s)), [s_peak, (3 * s_peak) / 2, 2 * s_peak])
            if beta > 0:
                # x ~ exp(-a s), a = 1/(zeta + r): beyond s_cut the rest of the tail,
                # ~ g(x(s_cut)) / (a beta), is below 10^-(dps + 8) of the contact time
                # (an infinite interval put nodes at s ~ 1e18, where x has no float seed).
                a = 1 / (z + mpmath.sqrt((z - 1) * (z + 1)))
                s_cut = 2 * s_peak + ((dps + 8) * mpmath.log(10) + abs(mpmath.log(a * beta))) / (
                    a * beta
                )
                pts = [2 * s_peak]
                while pts[-1] < s_cut:
                    pts.append(min(2 * pts[-1], s_cut))
                tail = quad(lambda s: g(x(s)), pts)
                t_end = t_rise + t_mid + tail
            else:
                t_end = mpmath.inf
        q_max = q_pk
        rest = mpmath.exp(-mpmath.pi * z / mpmath.sqrt((1 - z) * (1 + z))) if z < 1 else 0
        out = {
            "contact_time": t_end,
            "max_penetration": q_max,
            "restitution": mpmath.mpf(rest),
            "contact_time_zero_force": t_rise + t_mid if z > 0 else t_end,
            "restitution_zero_force": mpmath.exp(-2 * z * s_peak),
        }
    # Rounded to dps digits here: outside the working precision `+val` would round to the
    # caller's (mpmath's default 15 digits, i.e. a float: the truth agreed with a closed
    # form only to 5e-17, issue 27).
    with mpmath.workdps(dps):
        return {key: +val for key, val in out.items()}
