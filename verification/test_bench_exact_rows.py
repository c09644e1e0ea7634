"""`benchmarks.bench_exact`'s family rows: what a row reports besides its times.

A row whose goal is not met times the prepared call's compiled call alone beside the
whole call (`_compiled_only`), to say where the time goes. That figure is only honest
for a call the prepared call makes and that answers; and a row must report whether the
prepared call equals `solve_impact` whether or not it has such a call. No timing here:
the timer is replaced (speed is measured by the benchmark itself).
"""

from __future__ import annotations

from benchmarks import bench_exact
from reference_impl import PowerLaw, Sphere, prepare, solve_impact
from reference_impl.potentials import SumPotential
from verification.assertions import assert_true

# A sum whose higher term takes over deep inside the contact (docs/performance.md): the
# prepared call hands it to solve_impact's split path, never to its compiled call.
_SPLIT_SUM = (SumPotential(PowerLaw(1e-12, 0.01), PowerLaw(1.0, 20.0)), 1.0, 1.0)


def test_compiled_only_is_none_where_the_prepared_call_does_not_answer_from_it():
    """On main it returned a callable in both cases, whose status said 'not answered':
    its time would have been printed as the row's "compiled call alone"."""
    pot, m, v0 = _SPLIT_SUM
    cases = [("split sum, zeta 0.2", prepare(pot, m), v0, 0.2)]
    cases.append(("sphere, zeta 0.95", prepare(Sphere(0.01, 1e8), 0.05), 1.0, 0.95))
    for name, prep, v, zeta in cases:
        got = bench_exact._compiled_only(prep, v, zeta)
        assert_true(
            got is None,
            got=f"a compiled call answering {None if got is None else got()[-1]!r}",
            should="None (the prepared call does not answer from it)",
            claim="bench",
            call=f"_compiled_only({name})",
        )
    # Where the prepared call does answer from it, it is there, with that call's numbers.
    prep = prepare(Sphere(0.01, 1e8), 0.05)
    call = bench_exact._compiled_only(prep, 1.0, 0.2)
    sol = prep(1.0, 0.2)
    out = None if call is None else call()
    assert_true(
        out is not None and (out[0], out[2]) == (sol.max_penetration, sol.contact_time),
        got=f"{out!r}",
        should=f"q_max {sol.max_penetration!r} and contact time {sol.contact_time!r}",
        claim="bench",
        call="_compiled_only(sphere, 1.0, 0.2)",
    )


def test_family_row_without_a_compiled_call_still_says_if_prepared_is_identical(monkeypatch):
    """On main the identity check sat under `if kernel is not None`: a row with a
    prepared solver but no such call raised UnboundLocalError ('identical')."""
    pot, m, v0 = PowerLaw(1e9, 1.5), 0.0041, 1.0
    sol = solve_impact(pot, m, v0, bench_exact.FAMILY_ZETA)
    keys = bench_exact._UNIVERSAL_KEYS
    # The truth, the peers' columns and the timer replaced: only the row's logic runs.
    monkeypatch.setattr(bench_exact, "_compiled_only", lambda *a: None)
    monkeypatch.setattr(
        bench_exact, "solve_impact_mp", lambda *a, **k: {key: getattr(sol, key) for key in keys}
    )
    column = {"label": "peer", "rtol": 1e-10, "max_rel_error": 0.0, "mean_nfev": 1.0}
    column |= {"at_equal_error": True, "ladder": [], "scene_max_rel_error": 0.0, "scene_nfev": 1}
    eqset = {"standard_met": True, "proxy_check": {"bounds_held": True}}
    monkeypatch.setattr(
        bench_exact,
        "_peer_columns",
        lambda *a, **k: ({"dop853": column}, {"dop853": lambda: None}, eqset),
    )
    monkeypatch.setattr(bench_exact, "_interleaved", lambda c, b: dict.fromkeys(c, 1e-6))
    try:
        row = bench_exact._family_row("hertz", pot, m, v0, 1)
    except NameError as exc:  # UnboundLocalError
        row = {"raised": repr(exc)}
    assert_true(
        row.get("prepared_identical") is True and row.get("kernel_us", 0) is None,
        got=f"{row}",
        should="prepared_identical True and kernel_us None",
        claim="bench",
        call="_family_row(hertz) without a compiled call",
    )
