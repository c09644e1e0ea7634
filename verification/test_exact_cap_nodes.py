"""The cap's node inversion (`reference_impl.exact._nodes`, issue 27 goal 2).

At each quadrature node a cap solves the cubic a q^2 - q^3/3 = w for its overlap. The
kernel takes V = t^(1 / (alpha + 1)) (for alpha = 1/2 by a cube root of its own,
`_cap_powers`), starts from a degree-10 interpolant of the root (`_CAP_H`) and takes one
Halley step (`_cap_root`); a node whose start is not close enough goes to a bracketed
Newton iteration (`_cap_newton`). These tests hold the interpolant to the error its
acceptance rule assumes, each root to an ulp of the exact root of the float w, and V to
two ulps of the exact power (40-digit mpmath).
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

from reference_impl import Sphere
from reference_impl.exact._cap_nodes import (
    _CAP_H,
    _CAP_OMEGA_MAX,
    _CAP_STEP_MAX,
    _cap_powers,
    _cap_root,
    cap_nodes,
)
from reference_impl.exact.solve import solve_impact, solve_impact_mp
from verification.assertions import assert_less, assert_true

_EPS = float(np.finfo(float).eps)
# The interpolant's largest relative error, measured on the generator's 20000-point
# grid (3.55e-8); the acceptance rule assumes it is far below _CAP_STEP_MAX.
_H_RTOL = 4e-8
# A root accepted after one Halley step: the start's error is gone (<= 3e-18 of q, see
# _CAP_STEP_MAX), leaving the rounding of the cubic's residual (~ eps w / (q f'), half an
# ulp of q at small y) and of the step: measured <= 0.84 eps.
_ROOT_RTOL = 1.0 * _EPS
# A root from the bracketed Newton: stopped at a step <= 4 eps q (_CUBIC_XRTOL), plus the
# rounding of the residual, plus V's own error (_CBRT_RTOL, passed to q with a factor
# d ln q / d ln w = (1 - y/3) / (2 - y) <= 1 on y <= 1.5): measured <= 5 eps.
_NEWTON_RTOL = 6.0 * _EPS
# V for alpha = 1/2 (`_cap_powers`): r = cbrt(t) within an ulp after its Newton step, V = r^2
# one more rounding: measured <= 1.8 eps over t = 1e-285 .. 1e285 (pow beyond 1e-290, 1e290).
_CBRT_RTOL = 2.5 * _EPS
# V by pow for other alpha: pow(t, fl(1/A)) (glibc: within an ulp) times 1 + c ln t, c the
# exponent's residual 1/A - fl(1/A) (two more roundings): measured <= 1.13 eps.
_POW_RTOL = 2.0 * _EPS


def _exact_y(s: mpmath.mpf) -> mpmath.mpf:
    """Root y of y^2 (1 - y/3) = s^2 on 0 < y < 2 (closed form, mpmath)."""
    psi = mpmath.asin(mpmath.sqrt(3) * s / 2) / 3
    return 4 * mpmath.sin(psi) * mpmath.sin(psi + mpmath.pi / 3)


def _exact_root(w: float, a: float) -> mpmath.mpf:
    """Root q of a q^2 - q^3/3 = w (w, a the floats given), to 40 digits."""
    wm, am = mpmath.mpf(w), mpmath.mpf(a)
    q0 = am * _exact_y(mpmath.sqrt(wm / am**3))
    return mpmath.findroot(lambda q: q * q * (am - q / 3) - wm, q0)


@pytest.mark.mpmath
def test_cap_interpolant_error_is_what_the_halley_step_assumes():
    """s h(s) from the table is within _H_RTOL of the exact root on its whole range."""
    with mpmath.workdps(40):
        s_max = math.sqrt(_CAP_OMEGA_MAX)
        worst = 0.0
        for s in np.linspace(0.0, s_max, 2001)[1:]:
            h = 0.0
            for c in reversed(_CAP_H):
                h = h * s + c
            worst = max(worst, float(abs(mpmath.mpf(s * h) / _exact_y(mpmath.mpf(s)) - 1)))
    assert_less(worst, _H_RTOL, claim="impl", call="_CAP_H on 0 < s <= sqrt(2/3)", what="rel err")
    # One Halley step from a start off by r leaves ~ r^3 / 3: the accepted steps must be so
    # small that this is far below an ulp.
    assert_less(_CAP_STEP_MAX**3 / 3.0, 0.05 * _EPS, claim="impl", call="_CAP_STEP_MAX")
    assert_less(_H_RTOL, _CAP_STEP_MAX / 10.0, claim="impl", call="_CAP_H vs _CAP_STEP_MAX")


@pytest.mark.mpmath
@pytest.mark.parametrize("a", [0.01, 0.015, 3.7e-7, 2.5e4])
def test_cap_root_within_an_ulp_of_the_exact_root(a):
    """Every root `_cap_root` accepts (y = q/a from 1e-9 to 1) is within _ROOT_RTOL, and
    every y < 0.99 is accepted (the fallback is for y > 1 only)."""
    rng = np.random.default_rng(27)
    ys = np.exp(rng.uniform(math.log(1e-9), math.log(1.0), 150))
    ia3 = 1.0 / (a * a * a)
    worst = 0.0
    with mpmath.workdps(40):
        for y in ys:
            w = float(mpmath.mpf(a) ** 3 * mpmath.mpf(y) ** 2 * (1 - mpmath.mpf(y) / 3))
            q, ok = _cap_root(w, a, ia3, 2.0 * a)
            if y < 0.99:
                assert_true(
                    ok,
                    got=f"refused (w = {w!r})",
                    should="accepted",
                    claim="impl",
                    call=f"_cap_root(y = {y:.6g}, a = {a})",
                )
            if ok:
                worst = max(worst, float(abs(mpmath.mpf(q) / _exact_root(w, a) - 1)))
    assert_less(worst, _ROOT_RTOL, claim="impl", call=f"_cap_root, a = {a}", what="rel err")


@pytest.mark.mpmath
@pytest.mark.parametrize("alpha", [0.5, 0.3, 0.03893196913491494, 1.7])
def test_cap_powers_within_two_eps_of_the_exact_power(alpha):
    """V = t^(1 / (alpha + 1)) at the nodes, t = (alpha + 1) u / Kn, over t = 1e-300 ..
    1e295 and a few subnormal t: for alpha = 1/2 within _CBRT_RTOL of the exact t^(2/3)
    (the cube root inside 1e-290 .. 1e290, pow beyond); for other alpha within _POW_RTOL.
    pow with the float exponent fl(1 / (alpha + 1)) alone was off by t^(1/A - fl(1/A)):
    115 eps for alpha = 1/2 beyond the cube root's range, 131 and 171 eps for alpha = 0.3
    and 0.0389 (measured on main)."""
    kn, m = 1e8, 0.05
    rng = np.random.default_rng(1)
    t = np.concatenate(
        [
            np.exp(rng.uniform(math.log(1e-300), math.log(1e295), 400)),
            [1e-300, 1e-295, 1e295, 2.0**-1000, 8.0**-300, 1e-310, 5e-320],
        ]
    )
    x = np.sqrt(2.0 * kn / (alpha + 1.0) * t / m)
    v, scratch = np.empty_like(x), np.empty_like(x)
    _cap_powers(x, m, alpha, kn, v, scratch)
    t_k = (alpha + 1.0) / kn * (0.5 * m * x * x)  # the kernel's t, in its order
    rtol = _CBRT_RTOL if alpha == 0.5 else _POW_RTOL
    with mpmath.workdps(40):
        e = 1 / mpmath.mpf(alpha + 1.0)
        worst = max(
            float(abs(mpmath.mpf(vj) / mpmath.mpf(tj) ** e - 1))
            for vj, tj in zip(v, t_k, strict=True)
        )
    assert_less(worst, rtol, claim="impl", call=f"_cap_powers(alpha = {alpha})", what="rel err")


@pytest.mark.mpmath
def test_cap_nodes_beyond_the_interpolant_by_newton():
    """Nodes with y from 0.5 to 1.5 (half of them past the interpolant's range) through
    `cap_nodes` (the kernel's own passes): q within _NEWTON_RTOL of the exact root for the
    exact V, and dq/dx = m x / U'(q) with U' = (alpha + 1) u V' / V at the kernel's V."""
    kn, alpha, a, c0, m = 1e8, 0.5, 0.01, math.pi, 0.05
    P = np.array([[1.0, kn, alpha, a, c0]])
    ys = np.linspace(0.5, 1.5, 41)
    # x from U(q(y)) = m x^2 / 2 with U = Kn / (alpha + 1) V^(alpha + 1).
    v_of_y = c0 * a**3 * ys**2 * (1 - ys / 3)
    x = np.sqrt(2.0 * kn / (alpha + 1.0) * v_of_y ** (alpha + 1.0) / m)
    g, qs = np.empty_like(x), np.empty_like(x)
    cap_nodes(x, m, 2.0 * a, P, g, qs)
    v_k, scratch = np.empty_like(x), np.empty_like(x)
    _cap_powers(x, m, alpha, kn, v_k, scratch)  # the kernel's V
    worst = 0.0
    with mpmath.workdps(40):
        for xj, qj, gj, vj in zip(x, qs, g, v_k, strict=True):
            u = 0.5 * m * xj * xj
            t = (alpha + 1.0) / kn * u
            w = mpmath.cbrt(mpmath.mpf(t)) ** 2 / mpmath.mpf(c0)
            wm, am = w, mpmath.mpf(a)
            q0 = am * _exact_y(mpmath.sqrt(wm / am**3))
            root = mpmath.findroot(lambda q, wm=wm, am=am: q * q * (am - q / 3) - wm, q0)
            worst = max(worst, float(abs(mpmath.mpf(qj) / root - 1)))
            du = (alpha + 1.0) * u * (c0 * qj * (2.0 * a - qj)) / vj
            assert_true(
                gj == m * xj / du,
                got=f"dq/dx = {gj!r}",
                should=f"{m * xj / du!r}",
                claim="impl",
                call=f"cap_nodes at q = {qj!r}",
            )
    assert_less(
        worst, _NEWTON_RTOL, claim="impl", call="cap_nodes, y in [0.5, 1.5]", what="rel err"
    )


@pytest.mark.mpmath
@pytest.mark.parametrize("a", [1e-55, 1e-60, 1e-66, 1e-75])
def test_cap_root_at_tiny_scales_within_an_ulp_or_refused(a):
    """At tiny a the Halley step's numerator 2 p f' (~ r a^5 y^3 for a start off by r)
    underflows: the step came out 0 (or a few subnormal bits) and was accepted, leaving
    the interpolant's 3.6e-8 (measured 6.7e7 eps at a = 1e-60). A root is either within
    _ROOT_RTOL of the exact one or refused (then `_cap_newton`, whose step p / f' does
    not underflow, takes it)."""
    rng = np.random.default_rng(60)
    ys = np.exp(rng.uniform(math.log(1e-9), math.log(1.0), 120))
    ia3 = 1.0 / (a * a * a)
    worst = 0.0
    with mpmath.workdps(60):
        am = mpmath.mpf(a)
        for y in ys:
            w = float(am**3 * mpmath.mpf(y) ** 2 * (1 - mpmath.mpf(y) / 3))
            q, ok = _cap_root(w, a, ia3, 2.0 * a)
            if ok:
                # The closed form (not findroot, whose tolerance is absolute) at 60 digits.
                exact = am * _exact_y(mpmath.sqrt(mpmath.mpf(w) / am**3))
                worst = max(worst, float(abs(mpmath.mpf(q) / exact - 1)))
    assert_less(worst, _ROOT_RTOL, claim="impl", call=f"_cap_root, a = {a}", what="rel err")


@pytest.mark.mpmath
@pytest.mark.parametrize("y", [1e-6, 1e-2])
def test_sphere_at_tiny_radius_within_its_bound(y):
    """A whole impact at R = 1e-60 m, q_max = y R, Kn scaled so that every quantity is a
    normal float (the solver answers; t = 1.5 u / Kn stays inside the cube root's range):
    its contact times within their reported bounds of the 30-digit truth. With the
    underflowing Halley step accepted they were 1.5e-8 and 3.5e-12 off, 1.1e6 and 14 times
    the bound."""
    r = 1e-60
    kn = 1.0 / (math.pi * r**3) ** 1.5
    pot = Sphere(r, kn)
    m, zeta = 1.0, 0.2
    v0 = math.sqrt(2.0 * float(pot.U(y * r)) / m)
    sol = solve_impact(pot, m, v0, zeta)
    truth = solve_impact_mp(pot, m, v0, zeta, dps=30)
    call = f"solve_impact({pot!r}, {m!r}, {v0!r}, {zeta!r})"
    for key, bound in (
        ("contact_time", sol.quadrature_error),
        ("contact_time_zero_force", sol.quadrature_error_zero_force),
    ):
        real = float(abs(mpmath.mpf(getattr(sol, key)) - truth[key]))
        assert_less(real, bound, claim="impl", call=call, what=f"|{key} - truth|")


def test_cap_mp_energy_is_the_integral_of_its_mp_force():
    """The 30-digit truth integrates U'(q) = Kn V^alpha S; U must be its integral.

    With alpha + 1 formed in float (alpha = 0.0134... does not add to 1 exactly), the mp
    U was Kn V^fl(alpha+1) / fl(alpha+1): off by ~1e-16 |ln V|, so the truth of a shallow
    impact carried 5e-15. Central difference at 40 digits: its error ~h^2 U''' / 6, h = 1e-12
    q, is ~1e-24 of U', far below the 1e-16 |ln V| the rounded exponent gave.
    """
    for alpha in (0.013462143552233824, 0.3, 1.7):
        pot = Sphere(0.01, 1e8, alpha)
        with mpmath.workdps(40):
            q = mpmath.mpf("1e-12")
            h = q * mpmath.mpf("1e-12")
            num = (pot.U(q + h) - pot.U(q - h)) / (2 * h)
            rel = abs(num / pot.dU(q) - 1)
        assert_true(
            rel < 1e-20,
            got=f"|dU_mp/dq / U'_mp - 1| = {float(rel):.3g} at alpha = {alpha!r}",
            should="< 1e-20 (U the integral of U' in mpmath)",
            claim="tool",
            call="Sphere._U / _dU in mpmath",
        )
