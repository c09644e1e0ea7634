"""Independent mpmath truths for the exact solver's reliability tests (issue 22).

Nothing here calls the solver's code (no virtual time, no `reference_impl`
quadrature, inverse or oscillator): the undamped contact time comes from the
classical energy integral

    t_c = 2 int_0^q_max dq / sqrt(v0^2 - 2 U(q) / m),

with q_max the first root of U(q) = m v0^2 / 2 on the interval where U rises
from 0, both in mpmath. U is given as an mpmath callable of q, so the truth
never touches the float formula either.
"""

from __future__ import annotations

import mpmath

__all__ = ["contact_time_undamped", "power_sum", "turning_point"]


def power_sum(terms):
    """U(q) = sum_i k_i q^(p_i + 1) / (p_i + 1) (force sum_i k_i q^p_i) as an mpmath callable,
    and the overlaps where two terms' forces are equal (the hand-over points)."""
    ks = [mpmath.mpf(k) for k, _ in terms]
    ps = [mpmath.mpf(p) for _, p in terms]

    def U(q):
        return mpmath.fsum(k * q ** (p + 1) / (p + 1) for k, p in zip(ks, ps, strict=True))

    cross = []
    for i in range(len(ks)):
        for j in range(i + 1, len(ks)):
            if ps[i] != ps[j]:
                cross.append((ks[i] / ks[j]) ** (1 / (ps[j] - ps[i])))
    return U, cross


def turning_point(U, E, q_hi):
    """The root of U(q) = E in (0, q_hi), where U increases from 0 to at least E
    (mpmath's bracketing Anderson solver, then secant steps to the working precision)."""
    lo, hi = mpmath.mpf(0), mpmath.mpf(q_hi)
    u_hi = U(hi)
    if u_hi == E:
        return hi
    if not u_hi > E:
        raise ValueError("U(q_hi) must reach E")
    q = mpmath.findroot(lambda q: U(q) - E, (lo, hi), solver="anderson")
    # The contact time is proportional to q_max: polish to the working precision
    # (secant from the bracketing solver's answer) and check the residual.
    q = mpmath.findroot(lambda q: U(q) - E, (q, q * (1 + mpmath.mpf(10) ** (5 - mpmath.mp.dps))))
    if not abs(U(q) - E) <= E * mpmath.mpf(10) ** (3 - mpmath.mp.dps):
        raise ArithmeticError(f"turning point not converged: U(q) - E = {U(q) - E}")
    return q


def contact_time_undamped(U, m, q_max, splits=()):
    """t_c = 2 int_0^q_max dq / sqrt(v0^2 - 2U/m) (v0 given by U(q_max) = m v0^2 / 2),
    by q = q_max (1 - w^2) (removes the
    inverse square root at the turning point); ``splits`` are overlaps where the
    integrand changes its behaviour (the hand-over points), used as breakpoints."""
    m = mpmath.mpf(m)
    dps = mpmath.mp.dps
    with mpmath.workdps(2 * dps):
        u_top = U(q_max)

    def f(w):
        # v0^2 - 2U(q)/m is written as 2 (U(q_max) - U(q)) / m, at twice the working
        # precision: with v0^2 itself the root's residual (10^-dps of E) would swamp
        # the difference for w below 10^(-dps/2), a relative error of that size.
        # Using the energy U(q_max) of the computed root changes t_c by 10^-dps.
        with mpmath.workdps(2 * dps):
            q = q_max * (1 - w * w)
            r = 2 * (u_top - U(q)) / m
            return 2 * q_max * w / mpmath.sqrt(r) if r > 0 else mpmath.mpf(0)

    pts = {mpmath.mpf(0), mpmath.mpf(1)}
    for qc in splits:
        for fac in (mpmath.mpf(1) / 8, 1, 8):
            q = qc * fac
            if 0 < q < q_max:
                pts.add(mpmath.sqrt(1 - q / q_max))
    return 2 * mpmath.quad(f, sorted(pts))
