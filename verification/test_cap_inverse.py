"""The volumetric cap's closed-form inverse of U (`reference_impl.potentials._cap_inverse`, issue 38).

A cap's turning point q_max = U^-1(E) was found by the generic bracketed root finder
(`Potential._numeric_inverse`), ~190 us of a ~290 us one-shot sphere impact. The cap now
inverts in closed form (V = t^(1/A), then the cubic's trigonometric root and one Newton
step). These tests hold it to the 30-digit inverse of U written here from the formula
(nothing of the package's U), check that it is what a turning point uses, that an array
gives each energy its own bits, and that what it does not take (an energy above U(2a),
extreme scales, a subclass that may change the law) goes to the numeric inverse as before.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

from reference_impl import Ellipsoid, Sphere
from reference_impl.errors import NoTurningPointError
from reference_impl.potentials.base import Potential
from verification.assertions import assert_less, assert_true

_EPS = float(np.finfo(float).eps)
# The closed form's bound (`_cap_inverse.ULPS`, derived there from its roundings: V <= 3
# ulps, omega 2 more, the Newton residual ~3, q = a y one) in eps of q, times the cubic's
# conditioning kappa(y) = (1 - y/3) / (2 - y) = d ln y / d ln omega where that exceeds 1.
# Measured <= 1.6 eps * max(1, kappa) over the cases below; the numeric inverse it replaced
# reached 13-14 on three ordinary caps and 134 on the cap with Kn = 1e300 (it inverted the
# float U, whose own error it inherited).
_ULPS = 12.0
# Digits of the truth, and the relative bracket it is checked to hold the root in: far
# below an ulp of q (2e-16) even at the far pole, where the root is found only to ~1e-40
# / (2 - y) of q (U' ~ (2 - y) there).
_DPS = 40
_BRACKET = 1e-25


def _mp_cap(Kn: float, alpha: float, a: float, bc: float):
    """U(q) = Kn V^(alpha+1) / (alpha+1), V = pi bc / a^2 (a q^2 - q^3/3), as an mpmath
    callable (the floats given, exactly; alpha + 1 formed in mpmath)."""
    K, A, am = mpmath.mpf(Kn), mpmath.mpf(alpha) + 1, mpmath.mpf(a)
    c0 = mpmath.pi * mpmath.mpf(bc) / am**2

    def U(q):
        return K * (c0 * (am * q**2 - q**3 / 3)) ** A / A

    return U


def _mp_root(U, E: float, a: float):
    """q in (0, 2a] with U(q) = E, by bisection in q (U increases on (0, 2a)) until the
    bracket is within _BRACKET of q (~115 halvings from [0, 2a] at y = 1e-9)."""
    Em = mpmath.mpf(E)
    lo, hi = mpmath.mpf(0), 2 * mpmath.mpf(a)
    if not Em <= U(hi):
        raise ArithmeticError(f"U(2a) = {U(hi)} is below E = {E!r}")
    while hi - lo > _BRACKET * lo:
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if U(mid) < Em else (lo, mid)
    return (lo + hi) / 2


# (potential, its a, its b c): fixed caps of several shapes, scales and alphas, and two
# extreme ones: Kn = 1e300 with alpha = 0.01 (the numeric inverse was off by 134 eps
# there) and a subnormal Kn (whose float U loses digits).
_CAPS = [
    (Sphere(0.01, 1e8, 0.5), 0.01, 1e-4),
    (Ellipsoid(0.015, 0.008, 0.008, 1e8, 0.5), 0.015, 0.008 * 0.008),
    (Ellipsoid(0.02, 0.01, 0.03, 3e9, 0.7), 0.02, 0.01 * 0.03),
    (Sphere(0.005, 2e8, 1.3), 0.005, 0.005 * 0.005),
    (Sphere(3.0, 1e4, 0.0134), 3.0, 9.0),
    (Ellipsoid(1e-4, 3e-4, 5e-5, 1e12, 2.5), 1e-4, 3e-4 * 5e-5),
    (Ellipsoid(1e-5, 1e5, 1e-5, 1e300, 0.01), 1e-5, 1e5 * 1e-5),
    (Sphere(1.0, 1e-308, 0.5), 1.0, 1.0),
]
# Overlaps y = q / a of the energies inverted: from 1e-9 of a to the far pole's
# neighbourhood (kappa up to ~3e7 at 2 - y = 1e-8).
_YS = (1e-9, 1e-5, 0.003, 0.1, 0.5, 1.0, 1.4, 1.9, 1.999, 2.0 - 1e-6, 2.0 - 1e-8)


def _case_id(case) -> str:
    return repr(case[0])


@pytest.mark.parametrize("case", _CAPS, ids=_case_id)
def test_closed_form_is_within_its_bound_of_the_30_digit_inverse(case):
    pot, a, bc = case
    mpmath.mp.dps = _DPS
    U = _mp_cap(pot.Kn, pot.alpha, a, bc)
    u_sup = float(pot.U(2 * a))
    worst = 0.0
    for y in _YS:
        E = float(U(mpmath.mpf(y * a)))  # a float energy near U(y a)
        if not 0.0 < E <= u_sup:
            # No normal float energy (the subnormal Kn at small y), or E rounded above the
            # float U(2a) at the pole, which turning_point refuses (tested below).
            continue
        truth = _mp_root(U, E, a)
        yt = float(truth / a)
        kappa = max(1.0, (1.0 - yt / 3.0) / (2.0 - yt))
        q = pot.turning_point(E, check=False)
        err = float(abs(mpmath.mpf(q) / truth - 1)) / (_EPS * kappa)
        worst = max(worst, err)
    assert_less(
        worst,
        _ULPS,
        claim="tool",
        call=f"{pot!r}.turning_point(E) at y = q/a in {_YS}, eps * max(1, kappa(y))",
        what="largest error in eps * kappa",
    )


def test_a_turning_point_takes_the_closed_form(monkeypatch):
    # The root finder, ~190 us, must not run for an ordinary energy (it did on main).
    pot = Sphere(0.01, 1e8, 0.5)

    def refuse(self, u):
        raise AssertionError("numeric inverse called")

    monkeypatch.setattr(Potential, "_numeric_inverse", refuse)
    qs = [pot.turning_point(0.5 * 0.0327 * v * v, check=False) for v in (0.1, 1.0, 5.0)]
    assert_true(
        all(0.0 < q < 0.02 for q in qs),
        got=f"{qs}",
        should="three overlaps in (0, 2R) without the numeric inverse",
        claim="tool",
        call="Sphere(0.01, 1e8).turning_point(E)",
    )


def test_an_array_gives_each_energy_its_own_bits():
    pot = Ellipsoid(0.02, 0.01, 0.03, 3e9, 0.7)
    u_sup = float(pot.U(0.04))
    u = u_sup * np.geomspace(1e-30, 0.999, 200)
    got = pot.inverse(u)
    alone = np.array([pot.inverse(float(x)) for x in u])
    assert_true(
        np.array_equal(got, alone) and pot.inverse(0.0) == 0.0,
        got=f"{int(np.sum(got != alone))} of {u.size} differ; inverse(0) = {pot.inverse(0.0)}",
        should="each energy's bits as when inverted alone, and 0 at u = 0",
        claim="tool",
        call=f"{pot!r}.inverse(array of 200)",
    )


def test_an_energy_above_the_pole_is_refused_by_name():
    pot = Sphere(0.01, 1e8, 0.5)
    u_sup = float(pot.U(0.02))
    for u in (u_sup * 1.0001, np.array([0.1 * u_sup, 2.0 * u_sup])):
        with pytest.raises(NoTurningPointError, match="no turning point"):
            pot.inverse(u)
    # turning_point compares with U(2a), kept after its first use: twice the same refusal.
    for _ in range(2):
        with pytest.raises(NoTurningPointError, match=f"reaches only {u_sup:.6g} J"):
            pot.turning_point(u_sup * 1.0001)


@pytest.mark.parametrize(
    "pot, u",
    [
        # Energies of which t = A u / Kn leaves the normal range, and the cubic's top,
        # where omega exceeds 4/3 by round-off: the numeric inverse's answer, unchanged.
        (Sphere(0.01, 1e8, 0.5), 1e-300),
        (Sphere(0.01, 1e8, 0.5), 5e-324),
        (Sphere(0.01, 1e8, 0.5), float(Sphere(0.01, 1e8, 0.5).U(0.02))),
    ],
    ids=["u 1e-300", "u subnormal", "u = U(2a)"],
)
def test_what_the_closed_form_does_not_take_goes_to_the_numeric_inverse(pot, u):
    got = pot.inverse(np.array([u, u]))
    want = Potential._numeric_inverse(pot, np.array([u, u]))
    assert_true(
        np.array_equal(got, want) and math.isfinite(got[0]) and got[0] > 0.0,
        got=f"{got}",
        should=f"the numeric inverse's {want}",
        claim="tool",
        call=f"{pot!r}.inverse([{u!r}] * 2)",
    )


class _Softer(Sphere):
    """Changes the cap's U without opting in to its table: no closed form (it would
    invert the wrong law)."""

    def _U(self, q):
        return 0.5 * super()._U(q)


def test_a_subclass_that_may_change_the_law_gets_the_numeric_inverse():
    pot = _Softer(0.01, 1e8, 0.5)
    E = 1e-3
    q = pot.turning_point(E, check=False)
    got = float(pot.U(q))
    assert_true(
        abs(got / E - 1.0) < 64 * _EPS,  # the root finder's few ulps of q, times n = 3 in U
        got=f"U(q) = {got!r}",
        should=f"E = {E!r} (its own law inverted)",
        claim="tool",
        call="_Softer(0.01, 1e8).turning_point(1e-3)",
    )
