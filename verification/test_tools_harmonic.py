"""Tool tests of section 5's instruments (no claim marks): integrator checks that cannot
fail for a wrong Theorem 2.
"""

from __future__ import annotations

import math

from hypothesis import given

from reference_impl import HarmonicMap
from reference_impl.integrators.ivp import integrate_impact
from verification._harmonic_checks import _ODE_RTOL, _x_on_path
from verification.assertions import (
    assert_close,
)
from verification.strategies import impacts, reference_constants

# Relative drift of the (identically physical) energy along the ODE solution:
# global error ~1e-10 of q and v, squared terms double it.
_ENERGY_RTOL = 1e-9


@given(case=impacts(), km=reference_constants())
def test_virtual_energy_is_physical_energy_integrator_check(case, km):
    """INTEGRATOR CHECK, not a test of Theorem 2.

    E_v = M x'^2/2 + K x^2/2 with x' = q' sqrt(m/M) equals m q'^2/2 + U(q)
    identically, so its constancy only checks that solve_ivp conserves the
    physical energy. A wrong Theorem 2 would pass this test.
    """
    pot, m, v0 = case
    K, M = km
    hmap = HarmonicMap(pot, m, K, M)
    res = integrate_impact(pot, m, v0, rtol=_ODE_RTOL)
    xp = res.v * math.sqrt(m / M)
    E_v = 0.5 * M * xp**2 + 0.5 * K * _x_on_path(hmap, res.q) ** 2
    assert_close(
        E_v,
        0.5 * m * v0 * v0,
        rtol=_ENERGY_RTOL,
        claim="thm2-harmonic",
        call=f"M x'^2/2 + K x^2/2 along integrate_impact({pot!r}, v0={v0!r})",
    )
