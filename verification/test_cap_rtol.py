"""``rtol`` on a volumetric cap (issue 38, goal 2): the Gauss-Jacobi pair taken at rtol.

At full accuracy a cap's impact with zeta above ~0.55 (35 % of the work-precision draw)
left the fused Gauss-Jacobi kernel, whose 20- and 24-node rules disagree there at 1e-14,
for the general path (~0.5 ms). With ``rtol >= 1e-12`` the pair is kept when it meets
rtol (`reference_impl.exact._one_call._relaxed_cap`). These tests hold its reported bound
against the 30-digit truth, check that the general path no longer runs, that the prepared
solver returns the same bits, and that full accuracy and the other families are unchanged.
"""

from __future__ import annotations

import math

import pytest

from reference_impl import PowerLaw, Sphere, prepare, solve_impact
from reference_impl.exact import _strategies
from reference_impl.exact.solve import solve_impact_mp
from verification.assertions import assert_true

_SPHERE = Sphere(0.01, 1e8, 0.5)  # the catalogue's sphere-damped scene
_M = 0.032672563597333845
# Impacts where the full-accuracy pair disagrees (zeta 0.6-0.85), at speeds 0.1-5 m/s.
_IMPACTS = [(0.15, 0.62), (0.8, 0.7), (2.5, 0.78), (4.6, 0.84)]
_TIMES = ("contact_time", "contact_time_zero_force")
# Truth digits: 30, so that the truth's own error (~1e-30) is nothing against the bounds.
_DPS = 30


def _no_general(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the general path ran")

    monkeypatch.setattr(_strategies, "branch_integrals", refuse)


@pytest.mark.parametrize("v0, zeta", _IMPACTS)
def test_rtol_bound_holds_against_30_digits(monkeypatch, v0, zeta):
    rtol = 1e-8
    _no_general(monkeypatch)  # on main rtol was ignored here: the general path ran
    sol = solve_impact(_SPHERE, _M, v0, zeta, rtol=rtol)
    truth = solve_impact_mp(_SPHERE, _M, v0, zeta, dps=_DPS)
    rows = []
    for name, err in zip(_TIMES, ("quadrature_error", "quadrature_error_zero_force"), strict=True):
        got, want, bound = getattr(sol, name), float(truth[name]), getattr(sol, err)
        rows.append((name, abs(got - want), bound, got))
    assert_true(
        all(e <= b and b <= rtol * t for _, e, b, t in rows),
        got="; ".join(
            f"{n}: error {e:.2g} s, bound {b:.2g} s ({b / t:.2g})" for n, e, b, t in rows
        ),
        should=f"each error within its bound, each bound within rtol = {rtol:g}",
        claim="solve_impact",
        call=f"solve_impact(sphere-damped, v0={v0}, zeta={zeta}, rtol={rtol})",
    )


@pytest.mark.parametrize("rtol", [1e-6, 1e-10])
def test_prepared_returns_solve_impacts_bits_at_rtol(rtol):
    prepared = prepare(_SPHERE, _M, rtol=rtol)
    diff = []
    for v0, zeta in [*_IMPACTS, (1.0, 0.0), (0.3, 0.2)]:
        a, b = solve_impact(_SPHERE, _M, v0, zeta, rtol=rtol), prepared(v0, zeta)
        for k in (*_TIMES, "restitution", "quadrature_error", "max_penetration"):
            if getattr(a, k) != getattr(b, k):
                diff.append((v0, zeta, k))
    assert_true(
        not diff,
        got=f"{diff[:3]}",
        should="every field bit for bit",
        claim="solve_impact",
        call=f"prepare(sphere-damped, rtol={rtol})(v0, zeta)",
    )


def test_full_accuracy_and_small_rtol_are_unchanged():
    # Below 1e-12 (and with rtol None) the pair must agree at full accuracy, as before.
    v0, zeta = _IMPACTS[1]
    full = solve_impact(_SPHERE, _M, v0, zeta)
    small = solve_impact(_SPHERE, _M, v0, zeta, rtol=1e-13)
    relaxed = solve_impact(_SPHERE, _M, v0, zeta, rtol=1e-8)
    assert_true(
        full.contact_time == small.contact_time
        and full.quadrature_error == small.quadrature_error
        and full.quadrature_error < relaxed.quadrature_error,
        got=f"bounds {full.quadrature_error:.3g}, {small.quadrature_error:.3g} (1e-13), "
        f"{relaxed.quadrature_error:.3g} (1e-8)",
        should="rtol 1e-13 the full-accuracy result; rtol 1e-8 the pair's larger bound",
        claim="solve_impact",
        call=f"solve_impact(sphere-damped, v0={v0}, zeta={zeta}, rtol=...)",
    )


def test_a_sum_with_a_cap_keeps_full_accuracy():
    # Only a single cap's pair is taken at rtol (its convergence was measured).
    pot = _SPHERE + PowerLaw(1e3, 1.5)
    a = solve_impact(pot, _M, 0.8, 0.7)
    b = solve_impact(pot, _M, 0.8, 0.7, rtol=1e-6)
    assert_true(
        a.contact_time == b.contact_time and math.isfinite(a.contact_time),
        got=f"{a.contact_time!r} and {b.contact_time!r}",
        should="the same bits with and without rtol",
        claim="solve_impact",
        call="solve_impact(sphere + power, v0=0.8, zeta=0.7, rtol=1e-6)",
    )
