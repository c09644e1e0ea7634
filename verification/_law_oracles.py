"""Independent mpmath oracles for the general-law solver's edges (issue 29).

Nothing here calls `reference_impl`: closed forms at 60 digits from the float inputs
taken as exact.

* Linear oscillator m q'' + c q' + k q = 0, q(0) = 0, q'(0) = v0 (the linear dashpot on
  Hooke's spring, and the viscoelastic law there, C = A k): with beta = c / (2m) and
  omega^2 = k / m, underdamped q = v0 e^(-beta t) sin(wd t) / wd (wd^2 = omega^2 - beta^2),
  critical q = v0 t e^(-omega t), overdamped q = v0 (e^(-l2 t) - e^(-l1 t)) / (l1 - l2).
  Each derivative of e^(-beta t) sin(wd t + theta) is omega e^(-beta t) sin(wd t + theta
  + psi), psi = atan2(wd, -beta): q' = 0 at wd t = pi - psi, the total force F = k q + c q'
  = -m q'' vanishes at wd t = 2 (pi - psi) and is stationary where q''' = 0, at
  wd t = j pi - 3 psi. Overdamped, q' = 0 at t_p = ln(l1/l2) / (l1 - l2), q'' = 0 at 2 t_p,
  and F falls from c v0 to its one minimum at 3 t_p: the peak force is c v0.
* Hunt-Crossley, C = alpha U'(q) with U' = k q^p: G(v) = (m / alpha^2) (alpha v -
  ln(1 + alpha v)) + U(q) is conserved, so U(q_max) = G(v0) and the return speed
  v_e = e v0 solves G(-v_e) = G(v0): e = [1 + W0(-(1 + x) e^-(1 + x))] / x, x = alpha v0.
  The force U' (1 + alpha q') never vanishes before q = 0 (1 + alpha q' > 0 throughout),
  so both ends of contact coincide. The contact time is int dq / |v(q)| over both legs,
  1 + alpha v = -W_b(-exp(-(1 + alpha^2 (G0 - U(q)) / m))) with branch b = -1 going in
  and 0 coming out, by q = q_max (1 - u^2) (removes the square root at q_max).
"""

from __future__ import annotations

import mpmath

__all__ = ["linear_oscillator", "hunt_crossley", "hunt_crossley_contact_time"]

_DPS = 60


def linear_oscillator(k, m, c, v0, zeta=None) -> dict:
    """Every field of one impact of m q'' + c q' + k q = 0 (SI units), as mpmath numbers.

    ``zeta`` (the universal law's float) replaces c = 2 zeta sqrt(m k), which no finite
    precision holds exactly: at zeta = 1 it would leave omega^2 - beta^2 a rounding off 0.

    Returns
    -------
    dict
        returns_to_q0 (bool), contact_time (inf without return), restitution,
        contact_time_zero_force, restitution_zero_force, time_of_max_penetration,
        max_penetration, max_force, peak_force.
    """
    with mpmath.workdps(_DPS):
        k, m, v0 = (mpmath.mpf(x) for x in (k, m, v0))
        om2 = k / m
        if zeta is None:
            c = mpmath.mpf(c)
            beta = c / (2 * m)
            d = om2 - beta * beta
        else:
            z = mpmath.mpf(zeta)
            beta = z * mpmath.sqrt(om2)
            c = 2 * m * beta
            d = om2 * (1 - z * z)
        if d > 0:
            wd = mpmath.sqrt(d)

            def q(t):
                return v0 * mpmath.exp(-beta * t) * mpmath.sin(wd * t) / wd

            def w(t):
                return (
                    v0
                    * mpmath.exp(-beta * t)
                    * (mpmath.cos(wd * t) - beta * mpmath.sin(wd * t) / wd)
                )

            psi = mpmath.atan2(wd, -beta)
            t_p = (mpmath.pi - psi) / wd
            t_zf = 2 * t_p
            t_end = mpmath.pi / wd
            stat = [(j * mpmath.pi - 3 * psi) / wd for j in range(1, 4)]
            cands = [t for t in stat if 0 < t < t_end]
        else:
            if d == 0:
                om = mpmath.sqrt(om2)

                def q(t):
                    return v0 * t * mpmath.exp(-om * t)

                def w(t):
                    return v0 * (1 - om * t) * mpmath.exp(-om * t)

                t_p = 1 / om
            else:
                r = mpmath.sqrt(-d)
                l1, l2 = beta + r, om2 / (beta + r)

                def q(t):
                    return v0 * (mpmath.exp(-l2 * t) - mpmath.exp(-l1 * t)) / (l1 - l2)

                def w(t):
                    return v0 * (l1 * mpmath.exp(-l1 * t) - l2 * mpmath.exp(-l2 * t)) / (l1 - l2)

                t_p = mpmath.log(l1 / l2) / (l1 - l2)
            t_zf = 2 * t_p
            t_end = mpmath.inf
            cands = []

        def force(t):
            return k * q(t) + c * w(t)

        peak = max([c * v0] + [force(t) for t in cands])
        returns = t_end != mpmath.inf
        return {
            "returns_to_q0": returns,
            "contact_time": t_end,
            "restitution": -w(t_end) / v0 if returns else mpmath.mpf(0),
            "contact_time_zero_force": t_zf,
            "restitution_zero_force": -w(t_zf) / v0,
            "time_of_max_penetration": t_p,
            "max_penetration": q(t_p),
            "max_force": k * q(t_p),
            "peak_force": peak,
        }


def _hc_parts(k, p, m, alpha, v0):
    k, p, m, alpha, v0 = (mpmath.mpf(x) for x in (k, p, m, alpha, v0))
    x = alpha * v0
    # x - ln(1 + x) loses 2 log10(1/x) digits for small x: 16 at x = 1e-8, of 60.
    G0 = m / alpha**2 * (x - mpmath.log1p(x))
    return k, p, m, alpha, v0, x, G0


def hunt_crossley(k, p, m, alpha, v0) -> dict:
    """q_max, U'(q_max) and the restitution (both ends) of a Hunt-Crossley impact on U' = k q^p."""
    with mpmath.workdps(_DPS):
        k, p, m, alpha, v0, x, G0 = _hc_parts(k, p, m, alpha, v0)
        q_max = ((p + 1) * G0 / k) ** (1 / (p + 1))
        a = 1 + x
        e = (1 + mpmath.lambertw(-a * mpmath.exp(-a), 0).real) / x
        return {
            "max_penetration": q_max,
            "max_force": k * q_max**p,
            "restitution": e,
            "restitution_zero_force": e,
        }


def hunt_crossley_contact_time(k, p, m, alpha, v0, dps: int = 30):
    """Contact time (both ends) of a Hunt-Crossley impact on U' = k q^p, to ``dps`` digits."""
    with mpmath.workdps(dps + 10):
        k, p, m, alpha, v0, x, G0 = _hc_parts(k, p, m, alpha, v0)
        q_max = ((p + 1) * G0 / k) ** (1 / (p + 1))

        def speed(u, branch):
            # 1 + alpha v = -W_b(-exp(-(1 + g))), g = alpha^2 (U(q_max) - U(q)) / m, with
            # U(q_max) - U(q) = G0 (1 - (1 - u^2)^(p+1)) free of cancellation; near q_max
            # 1 + W ~ sqrt(2 g), so the argument needs log10(1/g) more digits.
            g = -(alpha**2) * G0 / m * mpmath.expm1((p + 1) * mpmath.log1p(-u * u))
            extra = max(0, int(-mpmath.log10(g))) + 10
            with mpmath.extradps(extra):
                y = -mpmath.lambertw(-mpmath.exp(-1 - g), branch).real - 1
            return y / alpha

        def leg(branch):
            # dimensionless integrand (v0 / |v|): mpmath.quad's error test is absolute, and
            # stopped early on the raw one at k = 1e300 (times ~1e-122 s)
            def f(u):
                if u == 0:
                    return mpmath.mpf(0)
                return 2 * u * v0 / abs(speed(u, branch))

            return mpmath.quad(f, [0, mpmath.mpf(1) / 2, 1])

        return +((leg(-1) + leg(0)) * q_max / v0)
