"""The compiled peers of `benchmarks/` (issue 38): what each returns, and equal error over a set.

The Sundman-regularised DOP853 (`benchmarks.peer_sundman`) and the q sqrt(q) plain DOP853
(`benchmarks.peer_dop853.solve_dop853_sqrt`) must give every output of the exact solvers
(both ends, q_max, U'(q_max), the peak force) to ~1e-12 at their tightest rung; the plain
peer must give the very numbers it gave before its stepping core was shared; the rung at
"equal error" must be chosen on the worst error over the set; the parallel peers of
`benchmarks.peer_batch` must give the serial peer's bits, impact by impact, whatever the
thread count. No timing here (speed is `benchmarks/bench_exact.py`'s and
`benchmarks/bench_batch_peer.py`'s).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from benchmarks import _equal_error, _peer_columns, _peers, peer_batch, peer_dop853, peer_sundman
from reference_impl import PowerLaw, Sphere, solve_impact
from reference_impl.exact.general_law import solve_law_impact
from reference_impl.potentials import SumPotential
from verification.assertions import assert_close, assert_true

_HERTZ = (PowerLaw(1e9, 1.5), 0.0041)
# Agreement at the tightest rung (rtol 1e-16; atol scaled alike): DOP853's global error
# there is ~1e-14 relative (measured 1e-15 .. 5e-14 on these impacts), the events located
# to a few ulps of a step on its 7th-order dense output add ~1e-15; the exact solvers'
# own error is ~1e-16. 1e-12 leaves a margin of 20x over the worst measured.
_RTOL_PEER = 1e-12
_TIGHTEST = 1e-16
_UNIVERSAL_KEYS = (
    "contact_time",
    "restitution",
    "contact_time_zero_force",
    "restitution_zero_force",
    "max_penetration",
    "max_force",
)
_LAW_KEYS = (*_UNIVERSAL_KEYS, "peak_force")
_IMPACTS = [
    ({"law": "universal", "zeta": 0.2}, 1.0),
    ({"law": "universal", "zeta": 0.7}, 0.3),
    ({"law": "linear", "c": 2.0}, 1.0),
    ({"law": "linear", "c": 2.0}, 0.2),
    ({"law": "hunt-crossley", "alpha": 0.37}, 3.0),
    ({"law": "viscoelastic", "A": 2e-6}, 1.0),
    ({"law": "polynomial", "c": [1.0, 2e5]}, 0.5),
    ({"law": "power", "c": 30.0, "exponent": 0.25}, 1.0),  # Tsuji's q^(1/4): N = 4
]


def _ours(pot, m, v0, law):
    if law["law"] == "universal":
        return solve_impact(pot, m, v0, law["zeta"]), _UNIVERSAL_KEYS
    return solve_law_impact(pot, m, v0, law), _LAW_KEYS


@pytest.mark.parametrize("peer", ["sundman", "dop853_sqrt"])
@pytest.mark.parametrize(("law", "v0"), _IMPACTS, ids=lambda x: str(x))
def test_peer_gives_every_output_of_the_exact_solvers(peer, law, v0):
    pot, m = _HERTZ
    sol, keys = _ours(pot, m, v0, law)
    out = _peers.peer_cases(pot, m)[peer](v0, law)(_TIGHTEST)
    assert_true(
        out[8] == 0.0,
        got=f"status {out[8]}",
        should="0 (the contact ended)",
        claim="bench",
        call=f"{peer}({law}, v0={v0})",
    )
    got = _peers.outputs(out, v0)
    for k in keys:
        assert_close(
            got[k],
            getattr(sol, k),
            rtol=_RTOL_PEER,
            claim="bench",
            call=f"{peer}({law}, v0={v0}).{k} against the exact solver",
        )


# The plain peer's outputs before its stepping core was shared (commit b6353d1, float hex):
# contact time, v_end, both at the zero-force end, q_max, U'(q_max), peak force; nfev.
_FROZEN = [
    (
        PowerLaw(1e9, 1.5), 0.0041, 1.0, {"law": "universal", "zeta": 0.2}, 1e-10,
        ["0x1.97ff734a78dd4p-14", "-0x1.0da1371e59beep-1", "0x1.51115a61f0f7bp-14",
         "-0x1.24bb1be87c73ep-1", "0x1.98c49b3f05dd6p-16", "0x1.e10e4a3086842p+6", "0x0.0p+0"],
        1115,
    ),
    (
        PowerLaw(1e9, 1.5), 0.0041, 1.0, {"law": "linear", "c": 2.0}, 1e-12,
        ["0x1.79149e6d8ac05p-14", "-0x1.f3ad238f0d785p-1", "0x1.725e3dee13694p-14",
         "-0x1.f3e9120e4f3bbp-1", "0x1.fa46a2333cb85p-16", "0x1.4b89491b3895cp+7",
         "0x1.4b8e4f73dcaccp+7"],
        1331,
    ),
    (
        PowerLaw(1e9, 1.5), 0.0041, 0.5, {"law": "hunt-crossley", "alpha": 0.37}, 1e-14,
        ["0x1.b5b1e00e01746p-14", "-0x1.c7b7f270c478ep-2", "0x1.b5b1e00e01746p-14",
         "-0x1.c7b7f270c478ep-2", "0x1.18705d24dc3b1p-16", "0x1.115c94c47368dp+6",
         "0x1.14cb7d689dc2ap+6"],
        1295,
    ),
    (
        Sphere(0.01, 1e8), 0.05, 1.0, {"law": "universal", "zeta": 0.2}, 1e-12,
        ["0x1.c9889bc90c70ep-7", "-0x1.0da137178bd9ap-1", "0x1.6ca5a1a4a2bb5p-7",
         "-0x1.24bb1be0a99e7p-1", "0x1.d7cf5fbe4c3cep-9", "0x1.63363f8f140aep+3", "0x0.0p+0"],
        1391,
    ),
]  # fmt: skip


@pytest.mark.parametrize(("pot", "m", "v0", "law", "rtol", "hexes", "nfev"), _FROZEN)
def test_plain_peer_is_bit_for_bit_what_it_was(pot, m, v0, law, rtol, hexes, nfev):
    """The shared stepping core (`benchmarks._dop853_core`) does the former kernel's
    arithmetic operation for operation: bench_exact's plain column is unchanged."""
    out = _peers.peer_cases(pot, m)["dop853"](v0, law)(rtol)
    got = [float(x).hex() for x in out[:7]] + [int(out[7])]
    assert_true(
        got == [*hexes, nfev],
        got=f"{got}",
        should=f"{[*hexes, nfev]}",
        claim="bench",
        call=f"solve_dop853({pot!r}, {law}, v0={v0}, rtol={rtol})",
    )


def test_sundman_n_is_the_smallest_making_the_law_polynomial():
    el = peer_dop853.elastic_table(_HERTZ[0])
    cases = {
        "universal (q^(1/4))": ({"law": "universal", "zeta": 0.2}, 4),
        "linear": ({"law": "linear", "c": 1.0}, 2),
        "power e = 1": ({"law": "power", "c": 1.0, "exponent": 1.0}, 2),
        "Tsuji e = 1/4": ({"law": "power", "c": 1.0, "exponent": 0.25}, 4),
        "viscoelastic (q^(1/2))": ({"law": "viscoelastic", "A": 1e-6}, 2),
        "hunt-crossley (q^(3/2))": ({"law": "hunt-crossley", "alpha": 0.3}, 2),
        # no N <= 8 makes 0.3 N and 1.5 N integers: N from the elastic term, pow for C
        "power e = 0.3": ({"law": "power", "c": 1.0, "exponent": 0.3}, 2),
    }
    for name, (law, want) in cases.items():
        da, zeta = peer_dop853.damping_table(_HERTZ[0], law)
        got = peer_sundman.sundman_n(el, da, zeta)
        assert_true(got == want, got=f"N = {got}", should=f"{want}", claim="bench", call=name)
    cap = peer_dop853.elastic_table(Sphere(0.01, 1e8))
    got = peer_sundman.sundman_n(cap, np.zeros((0, 2)), 0.2)
    assert_true(got == 0, got=f"N = {got}", should="0 (a cap)", claim="bench", call="sphere")


_NON_POLYNOMIAL = [
    # C = c q^0.3 on Hertz: |rho|^0.6 by pow (no N <= 8 makes it a polynomial)
    (_HERTZ[0], _HERTZ[1], 1.0, {"law": "power", "c": 40.0, "exponent": 0.3}),
    # the universal law on a sum: U' / sqrt(2 U) evaluated at q = L rho^N (the catalogue's
    # power-sum-damped scene, and a stronger damping)
    (SumPotential(PowerLaw(1e5, 1.5), PowerLaw(2e3, 1.0)), 0.1, 0.3, {"law": "universal", "zeta": 0.2}),
    (SumPotential(PowerLaw(1e5, 1.5), PowerLaw(2e3, 1.0)), 0.1, 1.0, {"law": "universal", "zeta": 0.6}),
]  # fmt: skip


@pytest.mark.parametrize(("pot", "m", "v0", "law"), _NON_POLYNOMIAL)
def test_non_polynomial_regularised_law_still_agrees(pot, m, v0, law):
    """Where the regularised right-hand side is no polynomial (the docstring's fallbacks)."""
    sol, keys = _ours(pot, m, v0, law)
    got = _peers.outputs(_peers.peer_cases(pot, m)["sundman"](v0, law)(_TIGHTEST), v0)
    for k in keys:
        assert_close(
            got[k], getattr(sol, k), rtol=_RTOL_PEER, claim="bench", call=f"sundman {law} {k}"
        )


def test_equal_error_rung_is_chosen_on_the_worst_impact_of_the_set():
    """A peer whose error is rtol on every impact but one, 1000 rtol there: the rung must
    be the one where that impact too is within the target, not the typical impact's."""
    keys = ("contact_time",)
    impacts = [(1.0 + i, {"law": "linear", "c": 1.0}) for i in range(20)]
    truths = np.array([[2.0 * v] for v, _ in impacts])

    def case(v0, law):
        bad = 1000.0 if v0 == 7.0 else 1.0

        def call(rtol):
            out = np.zeros(9)
            out[0] = 2.0 * v0 * (1.0 + bad * rtol)
            out[7] = 1.0 / rtol  # cheaper at looser rungs
            return out

        return call

    rtols = tuple(10.0**-k for k in range(6, 17))
    # target 2e-10: 1000 x 1e-13 is within it whatever the rounding; 1000 x 1e-12 is not
    got = _equal_error.set_ladder(case, impacts, truths, keys, 2e-10, rtols)
    assert_true(
        got["at_equal_error"] and got["rtol"] == 1e-13 and got["max_rel_error"] <= 2e-10,
        got=f"rtol {got['rtol']}, worst {got['max_rel_error']:.2e}",
        should="rtol 1e-13 (1000 x 1e-13 <= 2e-10), at equal error",
        claim="bench",
        call="set_ladder(one bad impact in 20)",
    )
    one = _equal_error.set_ladder(case, impacts[:1], truths[:1], keys, 2e-10, rtols)
    assert_true(
        one["rtol"] == 1e-10,
        got=f"rtol {one['rtol']}",
        should="1e-10 on the one typical scene (what the set must not fall back to)",
        claim="bench",
        call="set_ladder(one scene)",
    )


def test_random_impacts_span_the_ranges_and_repeat():
    law = {"law": "polynomial", "c": [1.0, 2.0]}
    a = _equal_error.random_impacts("row x", law, 1000)
    b = _equal_error.random_impacts("row x", law, 1000)
    v = np.array([x[0] for x in a])
    c0 = np.array([x[1]["c"][0] for x in a])
    c1 = np.array([x[1]["c"][1] for x in a])
    lo, hi = 10.0 ** np.array(_equal_error.LOG_V0)
    assert_true(
        a == b
        and len(a) == 1000
        and v.min() >= lo
        and v.max() <= hi
        and v.max() / v.min() > 50.0
        and np.allclose(c1, 2.0 * c0)
        and c0.min() >= 0.1
        and c0.max() <= 1.0,
        got=f"v0 in [{v.min():.3g}, {v.max():.3g}], c0 in [{c0.min():.3g}, {c0.max():.3g}]",
        should=f"the same set twice, v0 spanning [{lo}, {hi}], c scaled together in [0.1, 1]",
        claim="bench",
        call="random_impacts",
    )


def test_denominator_is_the_fastest_at_equal_error_else_the_most_accurate():
    """Before, with no peer at equal error the fastest was taken: on the universal rows a
    peer that ended no impact on any rung (worst error inf), at its loosest rung."""

    def col(err, ok):
        return {"label": "x", "rtol": 1e-10, "max_rel_error": err, "mean_nfev": 1.0}| {
            "at_equal_error": ok, "ladder": [], "scene_max_rel_error": err, "scene_nfev": 1
        }  # fmt: skip

    t = {"peer:a": 2e-6, "peer:b": 1e-6, "peer:c": 1e-7}
    cases = [
        ({"a": col(1e-15, True), "b": col(2e-15, True), "c": col(np.inf, False)}, "b"),
        ({"a": col(5e-14, False), "b": col(1e-13, False), "c": col(np.inf, False)}, "a"),
    ]
    for cols, want in cases:
        got = _peer_columns.fastest(cols, t)["peer_name"]
        assert_true(
            got == want,
            got=got,
            should=f"{want}",
            claim="bench",
            call=f"fastest({ {k: c['max_rel_error'] for k, c in cols.items()} })",
        )


# A batch of each law: speeds over the benchmark's range, distinct zetas (zeta = 0 among
# them: the Sundman peer's N is 2 there, 4 elsewhere); two rungs of the ladder.
_BATCH_V0 = 10.0 ** np.linspace(-1.0, 1.0, 9)
_BATCH_LAWS = [
    ("universal", np.linspace(0.0, 0.85, 9), None),
    ("linear", None, {"law": "linear", "c": 2.0}),
    ("hunt-crossley", None, {"law": "hunt-crossley", "alpha": 0.37}),
]


@pytest.mark.parametrize("peer", peer_batch.BATCH_PEERS)
@pytest.mark.parametrize(("name", "zetas", "law"), _BATCH_LAWS, ids=lambda x: str(x)[:20])
def test_parallel_peer_is_the_serial_peer_bit_for_bit(peer, name, zetas, law):
    """bench_batch_peer's denominator must be the peer bench_exact times, run in a prange
    loop: each row the serial call's bits (tolerances, N, turning point alike), on 1 and 2
    threads."""
    pot, m = _HERTZ
    call = peer_batch.batch_call(peer, pot, m, _BATCH_V0, zetas, law)
    case = _peers.peer_cases(pot, m)[peer]
    threads = numba.get_num_threads()
    try:
        for rtol in (1e-10, 1e-14):
            for th in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
                numba.set_num_threads(th)
                got = call(rtol).copy()
                for i, v0 in enumerate(_BATCH_V0):
                    lw = law or {"law": "universal", "zeta": float(zetas[i])}
                    want = case(float(v0), lw)(rtol)
                    assert_true(
                        np.array_equal(got[i], want, equal_nan=True),
                        got=f"{got[i].tolist()}",
                        should=f"{want.tolist()} (the serial peer's)",
                        claim="bench",
                        call=f"batch_call({peer!r}, {name}, {th} threads)({rtol:g})[{i}]",
                    )
    finally:
        numba.set_num_threads(threads)


def test_parallel_sundman_peer_declines_a_cap():
    got = peer_batch.batch_call("sundman", Sphere(0.01, 1e8), 0.05, [1.0], [0.2])
    assert_true(got is None, got=f"{got!r}", should="None", claim="bench", call="sphere")
