"""The Taylor kernel on a volumetric cap (`reference_impl.exact._taylor_cap`, issue 38 goal 4).

The new path is checked against the 30-digit truth (`_general_law_mp`, extended to a cap
row) on a handful of impacts, and against the GBS kernel on the same term table (`_general_kernel`, an independent
integrator: extrapolation in t, not series in the Sundman variable): over 1500 random
impacts (speeds 0.01-10 m/s log-uniform, linear, power, polynomial and Hunt-Crossley
laws, spheres and ellipsoids) every time and restitution agrees within the sum of both
reported bounds; ``rtol`` is honoured (the bound is at most rtol of the time, and the
full-accuracy answer is within it); the cases outside the method go to the GBS kernel
bit for bit.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from reference_impl import Ellipsoid, Sphere
from reference_impl.errors import HCVInputError
from reference_impl.exact import general_law as gl
from reference_impl.exact._general_contact import law_arrays
from reference_impl.exact._general_fields import form
from reference_impl.exact._general_kernel import OUT_FIELDS
from reference_impl.exact._general_kernel import solve as gbs_kernel
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact._general_rows import table_arrays
from reference_impl.exact._taylor_cap import solve as cap_kernel
from reference_impl.exact._taylor_cap import solve_cap_taylor
from reference_impl.potentials import SumPotential
from reference_impl.theory.laws import law_from_dict
from verification.assertions import assert_true

CALL = "_taylor_cap.solve_cap_taylor"
CLAIM = "solve_law_impact (Taylor kernel on a cap)"
# `form`'s fields after its flag, by name.
_NAMES = (
    "q_max",
    "max_force",
    "peak_force",
    "t_peak",
    "t_end",
    "e",
    "t_zf",
    "e_zf",
    "returns",
    "err_t",
    "err_e",
    "n_steps",
)
_TIMES = ("t_peak", "t_end", "t_zf")
_RESTITUTIONS = ("e", "e_zf")
# q_max and U'(q_max) have no bound of their own: the goal of issue 18 (1e-12 relative),
# which both kernels meet (measured here: <= 2e-14 at full accuracy).
GOAL_RTOL = 1e-12
N_IMPACTS = 1200
# And on the workprecision panel's sphere (sphere-damped: R = 1 cm, Kn = 1e8, m = 0.0327
# kg) with its linear dashpot 26.75 N s/m scaled 0.1-1x, 0.01-5.5 m/s (q_E up to 1.6 a,
# U(2a) is reached at 5.9 m/s): heavily damped, many of them creep back and never return
# (the no-return verdict compared too).
N_PANEL = 300
# Share of the drawn impacts the Taylor path must take itself (measured 2026-11-29: 1489
# of 1500; the rest creep back slower than `_general_taylor._CREEP_STEPS` allows and are
# handed over): the comparison must not be vacuous.
MIN_TAKEN = 0.9
# Share of the panel's impacts that must be creeping no-returns (measured: 250 of 300).
MIN_NO_RETURN = 0.2


def _laws(rng):
    """A random law of the four the cap path covers (strengths of order 1 at 1 m/s)."""
    k = rng.integers(4)
    s = 10.0 ** rng.uniform(-1.0, 1.0)
    if k == 0:
        return {"law": "linear", "c": 2.0 * s}
    if k == 1:
        return {"law": "power", "c": 400.0 * s, "exponent": float(rng.choice([0.5, 1.0, 1.5]))}
    if k == 2:
        return {"law": "polynomial", "c": [1.0 * s, 300.0 * s]}
    return {"law": "hunt-crossley", "alpha": 0.3 * s}


def _pots(rng):
    """A random sphere or ellipsoid, stiff enough that 10 m/s stays within q <= a."""
    if rng.integers(2) == 0:
        return Sphere(R=0.01 * rng.uniform(0.5, 2.0), Kn=1e11 * rng.uniform(0.5, 2.0))
    return Ellipsoid(a=0.01, b=0.01 * rng.uniform(0.5, 2.0), c=0.012, Kn=1e11, alpha=0.5)


def _fields(row, v0, qe):
    f = form(row, v0, qe)
    return f[0], dict(zip(_NAMES, f[1:], strict=True))


def _plan(pot, m, law, rtol=None):
    return gl.prepare_law(pot, m, law, rtol=rtol)._plan


@functools.cache
def _impacts():
    """(label, Taylor fields, GBS fields) of the drawn impacts the Taylor path takes, and
    the number drawn."""
    rng = np.random.default_rng(20261129)
    got = []
    for i in range(N_IMPACTS + N_PANEL):
        if i < N_IMPACTS:
            pot, law, m = _pots(rng), _laws(rng), 0.03
            v0 = 10.0 ** rng.uniform(-2.0, 1.0)
        else:
            pot, m = Sphere(R=0.01, Kn=1e8), 0.0327
            law = {"law": "linear", "c": 26.75 * rng.uniform(0.1, 1.0)}
            v0 = 10.0 ** rng.uniform(-2.0, math.log10(5.5))
        p = _plan(pot, m, law)
        qe = gl._top(p, 0.5 * m * v0 * v0)
        out = np.full(len(OUT_FIELDS), np.nan)
        if solve_cap_taylor(v0, qe, p.tab[0], p.cs, p.es, p.sc, out) != 0:
            continue
        g = gbs_kernel(v0, qe, p.tab[0], p.tab[1], p.cs, p.es, p.sc)
        got.append((f"{pot!r} {law} v0={v0!r}", _fields(out, v0, qe), _fields(g, v0, qe)))
    return got


def test_taylor_takes_most_impacts():
    taken = len(_impacts())
    creep = sum(1 for label, (_, t), _g in _impacts() if not t["returns"])
    assert_true(
        creep >= MIN_NO_RETURN * N_PANEL,
        got=f"{creep} no-returns compared",
        should=f">= {MIN_NO_RETURN:.0%} of the panel's {N_PANEL} impacts",
        claim=CLAIM,
        call=CALL,
    )
    assert_true(
        taken >= MIN_TAKEN * (N_IMPACTS + N_PANEL),
        got=f"{taken} of {N_IMPACTS + N_PANEL} impacts by the Taylor path",
        should=f"at least {MIN_TAKEN:.0%} (else the agreement below proves little)",
        claim=CLAIM,
        call=CALL,
    )


def test_cap_taylor_agrees_with_gbs_within_both_bounds():
    worst = (0.0, "")
    for label, (ft, t), (fg, g) in _impacts():
        assert_true(
            ft == fg == 0 and t["returns"] == g["returns"],
            got=f"flags {ft}, {fg}, returns {t['returns']}, {g['returns']}",
            should="both formed (OK) and the same verdict on the return",
            claim=CLAIM,
            call=f"{CALL} {label}",
        )
        for keys, err in ((_TIMES, "err_t"), (_RESTITUTIONS, "err_e")):
            for k in keys:
                if k in ("t_end", "e") and not t["returns"]:
                    continue  # inf and 0 on both sides (checked above)
                d = abs(t[k] - g[k])
                b = t[err] + g[err]
                worst = max(worst, (d / b, f"{k} {label}"))
                assert_true(
                    d <= b,
                    got=f"|Taylor - GBS| = {d:.3g} for {k} ({t[k]!r} vs {g[k]!r})",
                    should=f"<= the sum of both bounds {b:.3g}",
                    claim=CLAIM,
                    call=f"{CALL} {label}",
                )
        for k in ("q_max", "max_force", "peak_force"):
            r = abs(t[k] / g[k] - 1.0)
            assert_true(
                r <= GOAL_RTOL,
                got=f"relative difference {r:.3g} of {k}",
                should=f"<= {GOAL_RTOL:g}",
                claim=CLAIM,
                call=f"{CALL} {label}",
            )
    assert_true(
        worst[0] > 0.0,
        got="no difference at all",
        should="a real comparison",
        claim=CLAIM,
        call=CALL,
    )


@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10])
def test_rtol_is_honoured(rtol):
    rng = np.random.default_rng(7)
    steps = []
    for i in range(60):
        if i % 2 == 0:
            pot, law, m = _pots(rng), _laws(rng), 0.03
            v0 = 10.0 ** rng.uniform(-2.0, 1.0)
        else:  # the panel's sphere: heavily damped, slow exits (N = 1 redone with N = 2)
            pot, m = Sphere(R=0.01, Kn=1e8), 0.0327
            law = {"law": "linear", "c": 26.75 * rng.uniform(0.1, 1.0)}
            v0 = 10.0 ** rng.uniform(-1.0, math.log10(5.5))
        full = gl.solve_law_impact(pot, m, v0, law)
        loose = gl.solve_law_impact(pot, m, v0, law, rtol=rtol)
        steps.append((loose.n_steps, full.n_steps))
        label = f"{pot!r} {law} v0={v0!r} rtol={rtol} (case {i})"
        # rtol is asked of the contact times (as `benchmarks.bench_workprecision` reads
        # it: the one error_time over the shorter end; t_peak shares that bound)
        end = min(full.contact_time, full.contact_time_zero_force)
        assert_true(
            loose.error_time <= rtol * end,
            got=f"bound {loose.error_time:.3g} s",
            should=f"<= rtol x the shorter contact time ({rtol * end:.3g} s)",
            claim=CLAIM,
            call=f"solve_law_impact {label}",
        )
        for k in ("time_of_max_penetration", "contact_time_zero_force", "contact_time"):
            a, b = getattr(loose, k), getattr(full, k)
            if not math.isfinite(a):
                continue
            assert_true(
                abs(a - b) <= loose.error_time + full.error_time,
                got=f"{k} {a!r} (full {b!r})",
                should=f"within both bounds {loose.error_time + full.error_time:.3g} s",
                claim=CLAIM,
                call=f"solve_law_impact {label}",
            )
    assert_true(
        sum(s for s, _ in steps) < sum(f for _, f in steps),
        got=f"steps {steps}",
        should="fewer steps in all at the looser rtol (it trades something)",
        claim=CLAIM,
        call=f"solve_law_impact rtol={rtol}",
    )


def _bits(row):
    return np.asarray(row).view(np.int64)


@pytest.mark.parametrize("case", ["viscoelastic", "zeta", "two-rows"], ids=lambda c: c)
def test_cases_outside_go_to_gbs_bit_for_bit(case):
    pot, m, v0 = Sphere(R=0.01, Kn=1e8), 0.0327, 1.0
    law = {"law": "linear", "c": 2.0}
    if case == "viscoelastic":
        law = {"law": "viscoelastic", "A": 1e-4}
    elif case == "zeta":
        law = {"law": "universal", "zeta": 0.3}
    else:
        pot = SumPotential(pot, Sphere(R=0.02, Kn=1e8))
    rows, lim = table_arrays(pot)
    p = _plan(pot, m, {"law": "linear", "c": 2.0})
    cs, es, sc = law_arrays(law_from_dict(law), m, pot)
    qe = gl._top(p, 0.5 * m * v0 * v0)
    out = np.full(len(OUT_FIELDS), np.nan)
    rc = solve_cap_taylor(v0, qe, rows, cs, es, sc, out)
    got = cap_kernel(v0, qe, rows, lim, cs, es, sc)
    want = gbs_kernel(v0, qe, rows, lim, cs, es, sc)
    assert_true(
        rc == 1 and np.array_equal(_bits(got), _bits(want)),
        got=f"code {rc}, rows equal bit for bit: {np.array_equal(_bits(got), _bits(want))}",
        should="1 (handed over) and the GBS kernel's row, bit for bit",
        claim=CLAIM,
        call=f"{CALL} {case}",
    )


# Against the 30-digit truth (`_general_law_mp` on a cap row: the same factor's power
# recurrence in mpmath, an independent series in t in the middle stretch), ~1 s each:
# the returning impacts on every output with a bound, and a no-return's zero-force end.
_TRUTH_CASES = [
    (Sphere(R=0.01, Kn=1e8), 0.0327, 1.0, {"law": "hunt-crossley", "alpha": 0.2}, False),
    (Sphere(R=0.01, Kn=1e8), 0.0327, 5.0, {"law": "linear", "c": 3.0}, False),
    (
        Ellipsoid(a=0.01, b=0.012, c=0.008, Kn=1e9),
        0.03,
        0.5,
        {"law": "power", "c": 300.0, "exponent": 1.0},
        False,
    ),
    (Sphere(R=0.01, Kn=1e8), 0.0327, 0.3, {"law": "linear", "c": 26.75}, True),
]


@pytest.mark.parametrize("case", range(len(_TRUTH_CASES)))
def test_cap_taylor_against_30_digit_truth(case):
    pot, m, v0, law, creeps = _TRUTH_CASES[case]
    s = gl.solve_law_impact(pot, m, v0, law)
    assert_true(
        s.returns_to_q0 != creeps and s.n_steps < 200,
        got=f"returns_to_q0 = {s.returns_to_q0}, {s.n_steps} steps",
        should=f"{not creeps}, by the Taylor path (< 200 steps; the GBS kernel takes more)",
        claim=CLAIM,
        call=f"solve_law_impact({pot!r}, {law}, v0={v0})",
    )
    truth = solve_law_impact_mp(pot, m, v0, law, dps=30, zero_force_only=creeps)
    keys = [("time_of_max_penetration", "error_time"), ("contact_time_zero_force", "error_time")]
    keys += [("restitution_zero_force", "error_restitution")]
    if not creeps:
        keys += [("contact_time", "error_time"), ("restitution", "error_restitution")]
    for k, b in keys:
        d = abs(getattr(s, k) - float(truth[k]))
        assert_true(
            d <= getattr(s, b),
            got=f"|{k} - truth| = {d:.3g}",
            should=f"<= its bound {b} = {getattr(s, b):.3g}",
            claim=CLAIM,
            call=f"solve_law_impact({pot!r}, {law}, v0={v0})",
        )
    r = abs(s.max_penetration / float(truth["max_penetration"]) - 1.0)
    assert_true(
        r <= GOAL_RTOL,
        got=f"relative error {r:.3g} of max_penetration",
        should=f"<= {GOAL_RTOL:g}",
        claim=CLAIM,
        call=f"solve_law_impact({pot!r}, {law}, v0={v0})",
    )


def test_truth_refuses_a_cap_law_outside_its_reach():
    with pytest.raises(HCVInputError, match="viscoelastic"):
        solve_law_impact_mp(Sphere(R=0.01, Kn=1e8), 0.0327, 1.0, {"law": "viscoelastic", "A": 1e-4})
