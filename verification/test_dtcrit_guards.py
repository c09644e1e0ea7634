"""Issue 22 item 6: `dt-crit` never reports what it did not measure.

A two-walls gap so large that the overlap is below the float spacing of the
positions is refused (it reported "no failure"), a tolerance below round-off is
refused, and a search whose every step fails down to its floor raises instead of
reporting the floor as a measured critical step.
"""

from __future__ import annotations

import pytest

from reference_impl import HCVInputError, ImpactGain, PowerLaw, SearchGrid
from reference_impl.stability.criteria import MIN_TOL, parse_criterion
from reference_impl.stability.search import search_scene

HERTZ_K, HERTZ_M = 1.0879e10, 4.1103e-3  # the hertz-walls scene


def test_two_walls_gap_beyond_float_resolution_is_refused():
    with pytest.raises(HCVInputError, match=r"gap = 1e\+14 m is too large.*q_max") as info:
        search_scene(PowerLaw(HERTZ_K, 1.5), HERTZ_M, [1.0], "two-walls", gap=1e14)
    assert "\n" not in str(info.value)


def test_two_walls_ordinary_gap_still_runs():
    """The scene's own gap (0.1 mm) resolves the overlap to ~1e-20 of q_max."""
    (res,) = search_scene(PowerLaw(HERTZ_K, 1.5), HERTZ_M, [1.0], "two-walls", gap=1e-4)
    assert res.dt_crit > 0


@pytest.mark.parametrize("text", ["tol=0", "tol=1e-12"])
def test_tolerance_below_round_off_is_refused(text):
    with pytest.raises(HCVInputError, match="round-off"):
        parse_criterion(text, "impact")


def test_search_floor_is_never_reported_as_a_critical_step():
    """At tol = MIN_TOL with the floor raised to 0.5 of dt_safe, every step tried fails
    (Verlet's rebound error there is ~1e-3, far above 1e-9): refused, naming the floor."""
    grid = SearchGrid(lo=0.6, lo_min=0.5)
    with pytest.raises(HCVInputError, match="search floor"):
        search_scene(
            PowerLaw(1e9, 1.5),
            0.0041,
            [1.0],
            "impact",
            criterion=ImpactGain(tol=MIN_TOL, n_phases=2),
            grid=grid,
        )
