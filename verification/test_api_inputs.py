"""Issue 22 (and 17): the Python API refuses bad types and out-of-range sizes with
HCVInputError naming the value, under one rule for numbers (real numbers only:
int, float, numpy integer or floating scalars; bool, str, complex, containers
refused), and never returns 0.0 for a result below the normal float64 range."""

from __future__ import annotations

import math

import numpy as np
import pytest

from reference_impl import (
    HCVInputError,
    PowerLaw,
    dt_safe,
    solve_impact,
    solve_impacts,
)

HERTZ = PowerLaw(1e9, 1.5)


def _refused(call, *words):
    with pytest.raises(HCVInputError) as info:
        call()
    msg = str(info.value)
    assert "\n" not in msg, f"got {msg!r}, should be one line"
    for w in words:
        assert w in msg, f"got {msg!r}, should name {w!r}"
    return msg


@pytest.mark.parametrize(
    "call,words",
    [
        (lambda: solve_impacts(HERTZ, 1.0, [1e155, 1.0], 0.0), ("1e+155",)),
        (lambda: solve_impact(HERTZ, 10**400, 1.0), ("parameter m", "1000")),
        (lambda: solve_impacts(HERTZ, 1.0, [1 + 2j], 0.0), ("v0s", "(1+2j)")),
        (lambda: solve_impacts(HERTZ, 1.0, {"a": 1.0}, 0.0), ("v0s", "{'a': 1.0}")),
        (
            lambda: solve_impacts(HERTZ, 1.0, [[1.0, 2.0], [1.0]], 0.0),
            ("v0s", "[[1.0, 2.0], [1.0]]"),
        ),
        (lambda: solve_impacts(HERTZ, 1.0, [10**400], 0.0), ("v0s", "1000")),
        (lambda: solve_impacts(HERTZ, 1.0, ["1.0"], 0.0), ("v0s", "'1.0'")),
        (lambda: solve_impacts(HERTZ, 1.0, 1.0, [True]), ("zetas", "True")),
        (lambda: dt_safe(HERTZ, 1, "x"), ("parameter v0", "'x'")),
        (lambda: dt_safe(HERTZ, True, 1.0), ("parameter m", "True")),
        (lambda: solve_impact(HERTZ, 1.0, 1.0, zeta="0.1"), ("zeta", "'0.1'")),
        (lambda: solve_impact(HERTZ, 1.0, 1.0, zeta=True), ("zeta", "True")),
        (lambda: solve_impact(HERTZ, 1.0, 1.0 + 0j), ("v0", "(1+0j)")),
        (lambda: PowerLaw("1e9", 1.5), ("parameter k", "'1e9'")),
    ],
)
def test_bad_types_are_one_line_input_errors(call, words):
    """Issue 22 "Tracebacks": no raw OverflowError / TypeError / ValueError."""
    _refused(call, *words)


def test_mismatched_batch_shapes_are_refused():
    """Issue 17: arrays that do not broadcast are an input error naming both shapes."""
    _refused(lambda: solve_impacts(HERTZ, 1.0, [1.0, 2.0], [0.1, 0.2, 0.3]), "(2,)", "(3,)")


def test_one_rule_accepts_every_real_number_type():
    """int, float and numpy integer/floating scalars and arrays are the same number."""
    ref = solve_impact(HERTZ, 0.5, 1.0, 0.1).contact_time
    for m, v0, z in [(np.float64(0.5), np.int64(1), np.float32(0.1)), (0.5, 1, 0.1)]:
        got = solve_impact(HERTZ, m, v0, float(z) if isinstance(z, float) else z).contact_time
        assert math.isclose(got, ref, rel_tol=1e-7), f"got {got!r}, should be {ref!r}"
    batch = solve_impacts(HERTZ, 0.5, np.array([1, 2]), np.float64(0.1))["contact_time"]
    assert batch[0] == pytest.approx(ref, rel=1e-13), f"got {batch[0]!r}, should be {ref!r}"


@pytest.mark.parametrize("v0", [1e-156, 1e-160])
def test_energy_below_normal_range_is_refused_never_zero(v0):
    """Issue 22 item 5: Hertz at v0 <= 1e-156 gave q_max = 0.0; single and batch now agree
    (both refuse in one line, naming the energy)."""
    _refused(lambda: solve_impact(HERTZ, 0.0041, v0), "kinetic energy", "rescale")
    _refused(lambda: solve_impacts(HERTZ, 0.0041, [v0, 1.0], 0.0), "kinetic energy", "rescale")


def test_tiny_energy_in_normal_range_scales():
    """Hertz at v0 = 1e-150 (E ~ 4e-303 J): q_max follows the closed form
    (2.5 E / k)^(1/2.5) to round-off (factored, no intermediate underflow), in the
    single and the batch solver."""
    m, v0 = 0.0041, 1e-150
    q_true = (2.5 / 1e9) ** 0.4 * (0.5 * m) ** 0.4 * v0**0.8
    single = solve_impact(HERTZ, m, v0).max_penetration
    batch = solve_impacts(HERTZ, m, [v0], 0.0)["max_penetration"][0]
    for got in (single, batch):
        # A few roundings of the powers: 1e-14 relative.
        assert got == pytest.approx(q_true, rel=1e-14), f"got {got!r}, should be {q_true!r}"


@pytest.mark.parametrize("m", [1.0, 1e-300])
def test_dt_safe_of_a_tiny_mass(m):
    """Issue 22 item 5: m = 1e-300 on a linear spring gave dt_safe 15 % low (subnormal U
    on the supremum's grid); dt_safe = 2 sqrt(m / k) exactly for U = k q^2 / 2."""
    got = dt_safe(PowerLaw(1.0, 1.0), m, 1.0).dt_safe
    # sqrt and the ratio's arithmetic: a few ulps.
    assert got == pytest.approx(2.0 * math.sqrt(m), rel=1e-14), (
        f"got {got!r}, should be {2 * math.sqrt(m)!r}"
    )
