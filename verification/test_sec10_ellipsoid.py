"""Section 10: the ellipsoid model, its stiffening domain, Table 1 and Fig. 1."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from hypothesis import given

from reference_impl.damping import UniversalDamping, restitution_from_zeta
from reference_impl.harmonic_map import HarmonicMap
from reference_impl.paper import (
    FIG1,
    PAPER_MASS,
    STIFFENING_LIMIT_PRINTED,
    TABLE1_PRINTED,
    paper_ellipsoid,
    table1_cells,
)
from reference_impl.potentials import Ellipsoid
from reference_impl.stability import dt_safe, geometry_class, stiffening_indicator
from verification import strategies as hs
from verification.assertions import assert_close, assert_less, assert_true

# -- stiffening domain ---------------------------------------------------------

# For alpha = 1/2, 2UU'' - U'^2 has the sign of 4 V S' - S^2, i.e. of
# 12 - 20 u + 5 u^2 with u = delta / a: root u* = (20 - sqrt(160)) / 10.
U_STAR = (20.0 - math.sqrt(160.0)) / 10.0


@pytest.mark.claim("sec10-stiffening-domain")
@given(
    a=hs.log_uniform(1e-3, 1e-1),
    b=hs.log_uniform(1e-3, 1e-1),
    c=hs.log_uniform(1e-3, 1e-1),
    Kn=hs.log_uniform(1e6, 1e12),
)
def test_stiffening_below_printed_limit(a, b, c, Kn):
    """2UU'' >= U'^2 on (0, 0.735 a] for any semi-axes and stiffness (alpha = 0.5)."""
    pot = Ellipsoid(a, b, c, Kn, 0.5)
    u = np.linspace(1e-6, float(STIFFENING_LIMIT_PRINTED), 2001)
    s = stiffening_indicator(pot, u * a)
    # The indicator is O(1) relative; round-off in 2UU'' - U'^2 is ~1e-15 of U'^2,
    # so only values below -1e-12 count as violations.
    assert_true(
        bool(np.all(s > -1e-12)),
        got=f"min indicator {s.min():.3g} at u = {u[np.argmin(s)]:.6f}",
        should=">= 0 on (0, 0.735]",
        claim="sec10-stiffening-domain",
        call=f"stiffening_indicator({pot!r})",
    )


@pytest.mark.claim("sec10-stiffening-domain")
def test_stiffening_limit_is_the_root():
    """The sign change lies at u* = 0.7350889..., which the paper prints as 0.735."""
    pot = paper_ellipsoid()
    a = pot.a
    with mpmath.workdps(30):
        root = mpmath.findroot(
            lambda d: (2 * pot.U(d) * pot.d2U(d) - pot.dU(d) ** 2) / pot.dU(d) ** 2,
            (mpmath.mpf(0.7) * a, mpmath.mpf(0.77) * a),
            solver="anderson",
        )
    u = float(root / a)
    # The root of a smooth function found by a bracketing solver at 30 digits.
    assert_close(u, U_STAR, rtol=1e-14, claim="sec10-stiffening-domain", call="findroot(indicator)")
    assert_true(
        f"{math.floor(u * 1000) / 1000:.3f}" == STIFFENING_LIMIT_PRINTED,
        got=f"u* = {u:.7f}",
        should=f"{STIFFENING_LIMIT_PRINTED} at the printed digits",
        claim="sec10-stiffening-domain",
        call="root / a",
    )
    beyond = stiffening_indicator(pot, np.array([0.74, 1.0, 1.9]) * a)
    assert_less(
        beyond, 0.0, claim="sec10-stiffening-domain", call="indicator beyond u*", what="indicator"
    )


# -- Table 1 -------------------------------------------------------------------

_CELLS = {(c.v0, c.column): c for c in table1_cells()}

# Measured (50 digits, see reference_impl.paper.table1_cells): these printed
# cells do not match the computed value at the printed number of digits.
_MISMATCH = {
    ("0.99", "delta_max"): "computed 6.7069918 mm, printed 6.706989 (2.8 units of the last digit)",
    ("0.99", "max_force"): "computed 10.0000284 N, printed 10.000023 (5.4 units of the last digit)",
    ("0.99", "dt_safe"): "computed 9.8999719 ms, printed 9.899977 (5.1 units of the last digit)",
    ("1.50", "dt_safe"): "computed 9.3151223 ms, printed 9.315123 (0.65 units of the last digit)",
}


def _cell_params():
    for v in TABLE1_PRINTED:
        for col in ("delta_max", "max_force", "dt_safe"):
            marks = []
            if (v, col) in _MISMATCH:
                marks.append(pytest.mark.xfail(strict=True, reason=_MISMATCH[(v, col)]))
            yield pytest.param(v, col, marks=marks, id=f"v0={v}-{col}")


@pytest.mark.claim("table1")
@pytest.mark.parametrize("v0, column", list(_cell_params()))
def test_table1_cell_matches_printed_digits(v0, column):
    cell = _CELLS[(v0, column)]
    assert_true(
        cell.match,
        got=f"{cell.computed_rounded} {cell.unit} (computed {mpmath.nstr(cell.computed, 12)})",
        should=f"{cell.printed} {cell.unit} as printed",
        claim="table1",
        call=f"table1_cells()[{v0}, {column}]",
    )


@pytest.mark.claim("table1")
def test_table1_row_099_is_consistent_with_a_slightly_different_speed():
    """The printed 0.99 row satisfies dt = 2 m v0 / F with v0 = 0.99 (to its digits),
    but its delta_max corresponds to a smaller speed: the discrepancy is in the root solve
    (or in the speed used for delta_max), not in the dt formula."""
    pot = paper_ellipsoid()
    d_pr, f_pr, dt_pr = (float(s) for s in TABLE1_PRINTED["0.99"])
    v_from_dt = dt_pr * 1e-3 * f_pr / (2 * PAPER_MASS)
    # Printed values carry 7-8 significant digits: relative rounding <= 1e-7.
    assert_close(v_from_dt, 0.99, rtol=2e-7, claim="table1", call="dt*F/(2m) from printed row")
    v_from_delta = math.sqrt(2 * pot.U(d_pr * 1e-3) / PAPER_MASS)
    assert_true(
        abs(v_from_delta - 0.99) > 1e-7,
        got=f"v0(delta_printed) = {v_from_delta:.9f}",
        should="different from 0.99 beyond the printed digits",
        claim="table1",
        call="sqrt(2U(delta_printed)/m)",
    )


@pytest.mark.claim("sec6-dt-safe-bound")
@pytest.mark.parametrize("v0", [0.50, 0.99, 1.50])
def test_table1_supremum_is_at_max_compression(v0):
    """Section 6 item 1 for the ellipsoid: the supremum over the path equals the shortcut."""
    pot = paper_ellipsoid()
    s = dt_safe(pot, PAPER_MASS, v0)
    q_max = pot.turning_point(0.5 * PAPER_MASS * v0**2)
    assert_true(
        geometry_class(pot, q_max) == "stiffening",
        got=geometry_class(pot, q_max),
        should="stiffening",
        claim="sec6-dt-safe-bound",
        call="geometry_class",
    )
    # Both are the same formula at the same point up to round-off of U'/sqrt(2U).
    assert_close(
        s.dt_safe,
        s.dt_shortcut,
        rtol=1e-14,
        claim="sec6-dt-safe-bound",
        call=f"dt_safe(ellipsoid, {v0})",
    )


# -- Fig. 1 --------------------------------------------------------------------

# The paper's run: ode45 (Dormand-Prince 5(4), scipy's RK45) with RelTol = AbsTol = 1e-13.
# The transformed energy M x'^2/2 + K x^2/2 is algebraically the physical energy,
# so its drift measures the integrator, not the theorem; the theorem is tested by
# the sinusoid / spiral checks below and in test_sec5_harmonic.py.
FIG1_RTOL = 1e-13
FIG1_ATOL = 1e-13


def _fig1_run(v0, C0, method="RK45"):
    from reference_impl.integrators.ivp import integrate_impact

    pot = paper_ellipsoid()
    hmap = HarmonicMap(pot, PAPER_MASS, K=FIG1["K"], M=FIG1["M"])
    damp = UniversalDamping(hmap, C0=C0) if C0 > 0 else None
    run = integrate_impact(
        pot,
        PAPER_MASS,
        v0,
        C=None if damp is None else damp.C,
        method=method,
        rtol=FIG1_RTOL,
        atol=FIG1_ATOL,
        hmap=hmap,
    )
    x = hmap.x(np.maximum(run.q, 0.0))
    xp = run.v * math.sqrt(PAPER_MASS / hmap.M)
    H = 0.5 * hmap.M * xp**2 + 0.5 * hmap.K * x**2
    return hmap, damp, run, x, xp, H


@pytest.mark.claim("fig1")
def test_fig1_transformed_energy_is_the_physical_energy():
    """M x'^2/2 + K x^2/2 = m q'^2/2 + U(q) pointwise: the paper's check cannot test Theorem 2."""
    hmap, _, run, x, xp, H = _fig1_run(0.99, 0.0)
    q = np.maximum(run.q, 0.0)
    E_phys = 0.5 * PAPER_MASS * run.v**2 + paper_ellipsoid().U(q)
    # Same quantity computed two ways: differences are round-off (a few ulps).
    assert_close(H, E_phys, rtol=1e-14, claim="fig1", call="H_transformed vs physical energy")


# Measured with scipy RK45 at the paper's tolerances (this environment): drift
# 5.2e-13 (v0 = 0.50), 3.8e-13 (0.99), 2.4e-13 (1.50). The values depend on the
# step sequence (they moved by ~50 % when the integrator's scaling changed), which
# is the point: the printed bound is a property of one integrator run.
_FIG1_DRIFT_ABOVE_CLAIM = {
    0.50: "measured relative drift 5.2e-13 > 3e-13 with RK45 (ode45) at RelTol = AbsTol = 1e-13",
    0.99: "measured relative drift 3.8e-13 > 3e-13 with RK45 (ode45) at RelTol = AbsTol = 1e-13",
}


@pytest.mark.claim("fig1")
@pytest.mark.parametrize(
    "v0",
    [
        pytest.param(
            v,
            marks=[pytest.mark.xfail(strict=True, reason=_FIG1_DRIFT_ABOVE_CLAIM[v])]
            if v in _FIG1_DRIFT_ABOVE_CLAIM
            else [],
        )
        for v in FIG1["velocities"]
    ],
)
def test_fig1_conservative_drift_below_printed_bound(v0):
    """The printed figure, literally: drift < 3e-13 with the paper's integrator settings."""
    *_, H = _fig1_run(v0, 0.0)
    drift = float(np.max(np.abs(H / H[0] - 1)))
    assert_less(
        drift,
        FIG1["claimed_energy_error"],
        claim="fig1",
        call=f"RK45 rtol=atol=1e-13 ellipsoid v0={v0} C0=0",
        what="relative energy drift",
    )


@pytest.mark.claim("fig1")
@pytest.mark.parametrize("v0", FIG1["velocities"])
@pytest.mark.parametrize("method", ["RK45", "DOP853"])
def test_fig1_conservative_drift_at_integrator_level(v0, method):
    """What does hold: the drift is at the integrator's tolerance level. Over ~300
    steps of local error <= 1e-13 the accumulated energy error stays below 1e-11;
    measured 6e-14 to 3e-12 across methods and atol scalings."""
    *_, H = _fig1_run(v0, 0.0, method)
    drift = float(np.max(np.abs(H / H[0] - 1)))
    assert_less(
        drift,
        1e-11,
        claim="fig1",
        call=f"{method} rtol=atol=1e-13 v0={v0}",
        what="relative energy drift",
    )


@pytest.mark.claim("fig1")
@pytest.mark.parametrize("v0", FIG1["velocities"])
@pytest.mark.xfail(
    strict=True,
    reason="measured: with C0 = 0.5 the transformed energy is not "
    "conserved, it decays to 0.1504 = e^2 of its initial value over the contact "
    "(relative change 0.85 at every speed); 'conserved to < 3e-13' can only refer to "
    "the C0 = 0 runs",
)
def test_fig1_dissipative_transformed_energy_conserved_as_printed(v0):
    *_, H = _fig1_run(v0, FIG1["C0"][1])
    drift = float(np.max(np.abs(H / H[0] - 1)))
    assert_less(
        drift,
        FIG1["claimed_energy_error"],
        claim="fig1",
        call=f"v0={v0} C0=0.5",
        what="relative energy drift",
    )


@pytest.mark.claim("fig1")
@pytest.mark.parametrize("v0", FIG1["velocities"])
@pytest.mark.parametrize("C0", FIG1["C0"])
def test_fig1_exact_semi_ellipse_and_spiral(v0, C0):
    """x(tau) of the integrated physical trajectory equals the exact damped linear solution."""
    hmap, damp, run, x, xp, H = _fig1_run(v0, C0)
    w0 = hmap.omega0
    zeta = 0.0 if damp is None else damp.zeta
    wd = w0 * math.sqrt(1 - zeta**2)
    a0 = v0 * math.sqrt(PAPER_MASS / hmap.M)
    x_exact = a0 / wd * np.exp(-zeta * w0 * run.tau) * np.sin(wd * run.tau)
    # Global error of DOP853 at rtol 1e-13 over one contact, propagated through
    # x = sqrt(2U/K) (condition ~ n/2 = 1.5) and tau: allow 1e-9 of the amplitude.
    assert_close(
        x,
        x_exact,
        rtol=0,
        atol=1e-9 * a0 / wd,
        claim="fig1",
        call=f"integrate_impact(ellipsoid, v0={v0}, C0={C0}) mapped to (x, tau)",
    )
    e = run.restitution
    assert_close(
        e, restitution_from_zeta(zeta), rtol=1e-9, claim="fig1", call=f"restitution v0={v0} C0={C0}"
    )
