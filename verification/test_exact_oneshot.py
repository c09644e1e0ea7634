"""The one-shot calls' caches (issue 38, goals 3-4): never a different result, never stale.

`solve_impact` keeps a power law's kernel constants per exact (k, p, n, m, sizes, agree)
(`_power_kernel.power_constants`), `solve_law_impact` its plan per (potential, m, law,
rtol) and the entry point its law tables (`_oneshot_cache`). A cache only skips work: each
result must be, bit for bit, what the same call computes with every cache empty, for
inputs that differ in their last bit, in a value's type or sign, and from several
threads at once. Speed: benchmarks/bench_exact.py.
"""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

import reference_impl as ri
import reference_impl.exact._power_kernel as power_kernel
import reference_impl.exact.general_law as general_law
from reference_impl import HCVInputError, PowerLaw
from reference_impl.exact import _oneshot_cache
from reference_impl.exact.general_law import solve_law_impact
from reference_impl.theory.laws import Decomposition, LawFamily, Param, register_law
from reference_impl.theory.laws._registry import unregister_law
from verification.assertions import assert_true

LAWS = ({"law": "linear", "c": 30.0}, {"law": "hunt-crossley", "alpha": 0.2})


def _clear() -> None:
    power_kernel._constants.cache_clear()
    general_law._PLANS.clear()
    _oneshot_cache._LAWS.clear()


def _bits(sol) -> dict:
    """Every scalar of a result, floats by their bits (-0.0 and nan told apart)."""
    out = {}
    for k, v in sol.to_dict().items():
        out[k] = float.hex(v) if isinstance(v, float) else v
    return out


def _fresh(call):
    """``call()`` with every cache emptied first (what an uncached solver returns)."""
    _clear()
    return call()


def _random_impacts(n: int, seed: int):
    rng = np.random.default_rng(seed)
    return zip(
        rng.uniform(0.01, 10.0, n).tolist(),
        rng.uniform(0.0, 0.95, n).tolist(),
        rng.uniform(0.01, 2.0, n).tolist(),
        strict=True,
    )


@pytest.mark.parametrize("p", [1.5, 2.0])
@pytest.mark.parametrize("rtol", [None, 1e-8])
def test_cached_power_law_equals_uncached(p, rtol):
    """Universal law, one-shot: the same bits warm (constants kept) as with empty caches."""
    pot = PowerLaw(1e6, p)
    cases = list(_random_impacts(40, seed=int(10 * p)))
    _clear()
    warm = []
    for v0, zeta, m in cases:
        ri.solve(pot, m, v0, zeta, rtol=rtol)  # a first call fills the cache for m
        warm.append(_bits(ri.solve(pot, m, v0, zeta, rtol=rtol)))
    for (v0, zeta, m), got in zip(cases, warm, strict=True):
        want = _bits(_fresh(lambda v0=v0, zeta=zeta, m=m: ri.solve(pot, m, v0, zeta, rtol=rtol)))
        assert_true(
            got == want,
            got=f"{got}",
            should=f"{want} (empty caches)",
            claim="oneshot cache",
            call=f"reference_impl.solve(PowerLaw(1e6, {p}), {m!r}, {v0!r}, {zeta!r}, rtol={rtol})",
        )


@pytest.mark.parametrize("law", LAWS, ids=[la["law"] for la in LAWS])
def test_cached_law_plan_equals_uncached(law):
    """General law, one-shot through both entry points: warm bits equal fresh bits."""
    pot = PowerLaw(1e6, 1.5)
    cases = [(v0, m) for v0, _, m in _random_impacts(15, seed=3)]
    for call in (
        lambda m, v0, rt: ri.solve(pot, m, v0, law=law, rtol=rt),
        lambda m, v0, rt: solve_law_impact(pot, m, v0, law, rtol=rt),
    ):
        for rt in (None, 1e-8):
            _clear()
            warm = [_bits(call(m, v0, rt)) for v0, m in cases + cases][len(cases) :]
            for (v0, m), got in zip(cases, warm, strict=True):
                want = _bits(_fresh(lambda m=m, v0=v0, rt=rt, call=call: call(m, v0, rt)))
                assert_true(
                    got == want,
                    got=f"{got}",
                    should=f"{want} (empty caches)",
                    claim="oneshot cache",
                    call=f"solve(Hertz, {m!r}, {v0!r}, law={law}, rtol={rt})",
                )


def test_last_bit_apart_never_share():
    """Two potentials (and two masses) one ulp apart, alternated: each gets its own result,
    the one it gets with empty caches; the results differ (the check can fail)."""
    k0 = 1e6
    pots = (PowerLaw(k0, 1.5), PowerLaw(math.nextafter(k0, 2e6), 1.5))
    masses = (0.1, math.nextafter(0.1, 1.0))
    law = LAWS[0]
    _clear()
    for _ in range(2):
        for pot in pots:
            for m in masses:
                for call in (
                    lambda pot=pot, m=m: ri.solve(pot, m, 1.3, 0.4),
                    lambda pot=pot, m=m: ri.solve(pot, m, 1.3, law=law),
                ):
                    got = _bits(call())
                    warm_state = (len(general_law._PLANS), power_kernel._constants.cache_info())
                    want = _bits(_fresh(call))
                    assert_true(
                        got == want,
                        got=f"{got}",
                        should=f"{want} (empty caches; cache before: {warm_state})",
                        claim="oneshot cache",
                        call=f"solve({pot!r}, {m!r}, 1.3, ...)",
                    )
    a, b = (ri.solve(p, 0.1, 1.3, 0.4).contact_time for p in pots)
    assert_true(
        a != b,
        got=f"{a!r} == {b!r}",
        should="different contact times",
        claim="oneshot cache",
        call="solve on potentials one ulp apart",
    )


def test_law_values_told_apart_by_type_and_sign():
    """1, 1.0, True, 0.0 and -0.0 are different keys: True stays refused after 1 and 1.0
    were planned, and -0.0 keeps its sign in the result's law table."""
    pot = PowerLaw(1e6, 1.5)
    _clear()
    for c in (1, 1.0):
        ri.solve(pot, 0.1, 1.0, law={"law": "linear", "c": c})
        solve_law_impact(pot, 0.1, 1.0, {"law": "linear", "c": c})
    for call in (ri.solve, lambda p, m, v, law: solve_law_impact(p, m, v, law)):
        with pytest.raises(HCVInputError, match="got True"):
            call(pot, 0.1, 1.0, law={"law": "linear", "c": True})
    signs = {}
    for c in (0.0, -0.0, 0.0):
        got = ri.solve(pot, 0.1, 1.0, law={"law": "linear", "c": c}).law["c"]
        signs.setdefault(math.copysign(1.0, c), set()).add(math.copysign(1.0, got))
    assert_true(
        signs == {1.0: {1.0}, -1.0: {-1.0}},
        got=f"signs {signs}",
        should="each c's own sign",
        claim="oneshot cache",
        call="solve(law linear c=+-0.0)",
    )


def test_refused_input_is_refused_every_time():
    """A refused table is not kept: the second call raises the same one line."""
    pot = PowerLaw(1e6, 1.5)
    for _ in range(2):
        with pytest.raises(HCVInputError, match="damping.cc"):
            ri.solve(pot, 0.1, 1.0, law={"law": "linear", "cc": 1.0})
        with pytest.raises(HCVInputError, match="m must be > 0"):
            solve_law_impact(pot, -0.1, 1.0, LAWS[0])


def test_caches_stay_bounded():
    """A sweep of distinct potentials and masses keeps at most KEPT plans and constants."""
    _clear()
    for i in range(_oneshot_cache.KEPT + 20):
        pot = PowerLaw(1e6 + i, 1.5)
        ri.solve(pot, 0.1 + i * 1e-3, 1.0, 0.2)
        ri.solve(pot, 0.1, 1.0, law=LAWS[0])
    sizes = (len(general_law._PLANS), power_kernel._constants.cache_info().currsize)
    assert_true(
        max(sizes) <= _oneshot_cache.KEPT,
        got=f"sizes {sizes}",
        should=f"<= {_oneshot_cache.KEPT}",
        claim="oneshot cache",
        call="84 potentials",
    )


def test_reregistered_law_is_planned_again():
    """A law unregistered and registered again under its name (a different class) is read
    and planned anew, not served from the first class's plan."""

    def family(c_scale):
        class Tmp(LawFamily):
            name = "oneshot-tmp"
            params = (Param("c", "N s/m"),)
            formula = "c"
            strength = "c"

            @classmethod
            def decompose(cls, params):
                return Decomposition(terms=((c_scale * params["c"], 0.0),))

        return Tmp

    pot, law = PowerLaw(1e6, 1.5), {"law": "oneshot-tmp", "c": 20.0}
    got = []
    try:
        for scale in (1.0, 2.0):
            register_law(family(scale))
            got.append(ri.solve(pot, 0.1, 1.0, law=law).restitution)
            unregister_law("oneshot-tmp")
    finally:
        unregister_law("oneshot-tmp")
    want = ri.solve(pot, 0.1, 1.0, law={"law": "linear", "c": 40.0}).restitution
    assert_true(
        got[1] == want and got[0] != want,
        got=f"restitutions {got}",
        should=f"[e(c=20), {want!r}] (the second class doubles c)",
        claim="oneshot cache",
        call="solve after re-registering a law",
    )


def test_threads_share_the_caches_safely():
    """Four threads solving interleaved potentials and laws get the serial results."""
    pots = [PowerLaw(1e6 * (1 + i), 1.5 + 0.5 * (i % 2)) for i in range(6)]
    jobs = [(pots[i % 6], 0.1, 0.3 + 0.1 * i, LAWS[i % 2]) for i in range(60)]
    want = [
        (_bits(ri.solve(p, m, v, 0.2)), _bits(ri.solve(p, m, v, law=la))) for p, m, v, la in jobs
    ]
    _clear()
    got = [None] * len(jobs)

    def work(start):
        for i in range(start, len(jobs), 4):
            p, m, v, la = jobs[i]
            got[i] = (_bits(ri.solve(p, m, v, 0.2)), _bits(ri.solve(p, m, v, law=la)))

    threads = [threading.Thread(target=work, args=(s,)) for s in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    bad = [i for i in range(len(jobs)) if got[i] != want[i]]
    assert_true(
        not bad,
        got=f"{len(bad)} results differ (first {bad[:3]})",
        should="the serial results",
        claim="oneshot cache",
        call="4 threads",
    )


# -- integer p: the Gauss-Jacobi pair holds (issue 38: p = 2 fell back to tanh-sinh) ------


@pytest.mark.parametrize("p", [1.5, 2.0, 3.0])
def test_stored_rules_integrate_moments_to_round_off(p):
    """Each rule of the pair integrates u^k u^beta on (0, 1), k <= 20 (exact for a Gauss
    rule of >= 11 nodes), to 1/(beta + 1 + k) within round-off: scipy's rules missed by up to
    4e-14 (p = 2, 3), which alone broke the pair's 1e-14 agreement."""
    from reference_impl.exact._branches import _GJ_SIZES, _jacobi_pair

    beta = 2.0 / (p + 1.0) - 1.0
    u, W = _jacobi_pair(beta, _GJ_SIZES)
    eps = np.finfo(float).eps
    for col, size in enumerate(_GJ_SIZES):
        for k in range(21):
            got = float(np.sum(W[:, col] * u**k))
            want = 1.0 / (beta + 1.0 + k)  # exact to 1 ulp (two roundings)
            # Round-off: each node correctly rounded (u^k: k/2 ulps, its weight 1/2 ulp,
            # the power and the product ~2 ulps) and a sum of 40 positive terms (40 ulps,
            # zeros included): (k/2 + 45) ulps of the sum.
            tol = (0.5 * k + 45.0) * eps
            assert_true(
                abs(got / want - 1.0) <= tol,
                got=f"{got!r} (rel err {abs(got / want - 1.0):.2g})",
                should=f"{want!r} within {tol:.2g}",
                claim="tool",
                call=f"_jacobi_pair({beta!r}) rule {size}, moment u^{k}",
            )


@pytest.mark.parametrize("p", [2.0, 3.0])
def test_integer_p_stays_on_the_gauss_jacobi_pair(p):
    """200 random impacts, zeta in [0, 0.85): every one on the power law's Gauss-Jacobi
    strategy (main sent 6 % of p = 2 and 28 % of p = 3 to tanh-sinh)."""
    from reference_impl.exact._oscillator import VirtualOscillator
    from reference_impl.exact._strategies import Job, choose
    from reference_impl.exact._validate import _validated_top

    pot = PowerLaw(1e6, p)
    off = []
    for v0, zeta, m in _random_impacts(200, seed=int(p)):
        zeta *= 0.85 / 0.95
        q_top = _validated_top(pot, 0.5 * m * v0 * v0)
        name, _ = choose(Job(pot, m, v0, VirtualOscillator(v0, zeta), q_top, None))
        if name != "power_law":
            off.append((v0, zeta, m, name))
    assert_true(
        not off,
        got=f"{len(off)} of 200 impacts off the pair (first {off[:2]})",
        should="all on power_law",
        claim="tool",
        call=f"_strategies.choose(PowerLaw(1e6, {p}))",
    )


@pytest.mark.parametrize("p", [2.0, 3.0])
def test_integer_p_bound_holds_against_mpmath(p):
    """The fast path's reported bound bounds the true error of both times against the
    30-digit truth (`solve_impact_mp`), over random impacts up to zeta = 0.85."""
    from reference_impl.exact.solve import solve_impact_mp

    pot = PowerLaw(1e6, p)
    for v0, zeta, m in _random_impacts(5, seed=100 + int(p)):
        zeta *= 0.85 / 0.95
        sol = ri.solve(pot, m, v0, zeta)
        truth = solve_impact_mp(pot, m, v0, zeta)
        for t, e, name in (
            (sol.contact_time, sol.quadrature_error, "contact_time"),
            (
                sol.contact_time_zero_force,
                sol.quadrature_error_zero_force,
                "contact_time_zero_force",
            ),
        ):
            err = abs(t - float(truth[name]))
            assert_true(
                err <= e,
                got=f"error {err:.3g} s of {name} = {t!r}",
                should=f"<= its bound {e:.3g} s",
                claim="tool",
                call=f"solve(PowerLaw(1e6, {p}), {m!r}, {v0!r}, {zeta!r}) vs solve_impact_mp",
            )


def test_lazy_turning_point_gives_the_eager_result():
    """A power law's impact below an energy validated already leaves its turning point to
    the strategy that reads it (`_strategies.Job.q_top`): bit for bit the result of a fresh
    potential object (nothing validated: computed eagerly), on the Gauss-Jacobi path and on
    the tanh-sinh and overdamped paths (zeta >= 0.9) that read it."""
    k, p, m = 1e6, 2.0, 0.3
    warm = PowerLaw(k, p)
    ri.solve(warm, m, 20.0, 0.1)  # validates every lower energy
    for v0, zeta, _ in _random_impacts(12, seed=9):
        for z in (zeta, 0.9 + 0.1 * zeta, 1.0 + zeta):
            got = _bits(ri.solve(warm, m, v0, z))
            want = _bits(ri.solve(PowerLaw(k, p), m, v0, z))
            assert_true(
                got == want,
                got=f"{got}",
                should=f"{want} (a fresh potential)",
                claim="oneshot cache",
                call=f"solve(PowerLaw({k}, {p}), {m}, {v0!r}, {z!r}) after a faster impact",
            )
