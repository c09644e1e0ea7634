"""`benchmarks.bench_workprecision`: what a panel records besides its times (issue 38, goal 2).

No timing here: the timer is replaced (speed is measured by the benchmark itself). A
panel must hold ours at every rtol asked, each point's achieved error within its reported
bound and the bound within its rtol; every peer's rungs with a finite error; a family
where rtol trades nothing (a cap) with ours at full accuracy alone; and the figure must
be drawn from the record.
"""

from __future__ import annotations

import math

from benchmarks import bench_workprecision as wp
from reference_impl import PowerLaw
from verification.assertions import assert_true

# The proxy truth (ours at full accuracy) is itself within ~1e-15 relative of the truth
# (its reported bound, `solve.RTOL_STATED` at most 1e-12 but ~1e-15 measured here): the
# achieved error may exceed the fast point's bound by that much.
_PROXY = 1e-14


def _no_timer(contestants, blocks):
    return dict.fromkeys(contestants, 1e-3)


def test_panel_records_ours_within_bounds_and_every_peer(monkeypatch, tmp_path):
    monkeypatch.setattr(wp, "_interleaved", _no_timer)
    pot, m = PowerLaw(1e9, 1.5), 0.0041
    p = wp.panel("Hertz", pot, m, wp.UNIVERSAL, 12, 1, 0)
    ours = p["curves"]["ours"]
    assert_true(
        [q["rtol"] for q in ours] == list(wp.OURS_RTOLS),
        got=str([q["rtol"] for q in ours]),
        should=str(list(wp.OURS_RTOLS)),
        claim="bench",
        call="panel(Hertz, universal)",
    )
    # An rtol below what full accuracy reaches gets the full-accuracy result (`_rtol`).
    full = ours[-1]["max_rel_bound"]
    for q in ours:
        call = f"panel(Hertz, universal) ours at rtol {q['rtol']}"
        ok = q["max_rel_error"] <= q["max_rel_bound"] + _PROXY
        ok &= q["rtol"] is None or q["max_rel_bound"] <= max(q["rtol"], full)
        assert_true(
            ok,
            got=f"error {q['max_rel_error']:.3g}, bound {q['max_rel_bound']:.3g}",
            should=f"error <= bound (+ the proxy's) and bound <= max(rtol, full's {full:.3g})",
            claim="bench",
            call=call,
        )
    for peer in ("dop853", "dop853_sqrt", "sundman"):
        pts = p["curves"].get(peer, [])
        assert_true(
            len(pts) > 10 and all(math.isfinite(q["max_rel_error"]) for q in pts),
            got=f"{len(pts)} points",
            should="most rungs of the ladder, each with a finite error",
            claim="bench",
            call=f"panel(Hertz, universal) {peer}",
        )
    assert_true(
        all(q["us"] == 1e-3 * 1e6 / p["impacts"] for q in ours),
        got=str([q["us"] for q in ours]),
        should="the timer's pass time over the set, per impact",
        claim="bench",
        call="panel(Hertz, universal) us",
    )
    record = {
        "panels": [p],
        "error_floor": wp.ERROR_FLOOR,
        "machine": {"commit": "test"},
        "load_average_1min": 0.0,
        "blocks": 1,
    }
    png = tmp_path / "wp.png"
    wp.figure(record, png)
    assert_true(
        png.is_file() and png.stat().st_size > 10_000,
        got=f"{png.stat().st_size if png.is_file() else 'no'} bytes",
        should="a PNG figure",
        claim="bench",
        call="figure",
    )


def test_rtol_trades_on_power_laws_and_single_caps_under_the_universal_law():
    from reference_impl import Sphere

    cap = Sphere(0.01, 1e8)
    got = (
        wp.trades(PowerLaw(1.0, 2.0), wp.LAW),
        wp.trades(cap, wp.UNIVERSAL),
        wp.trades(cap, wp.LAW),
    )
    assert_true(
        got == (True, True, False),
        got=f"trades(power law + law, cap universal, cap + law) = {got}",
        should="(True, True, False): rtol trades on power laws and on a single cap's Gauss-Jacobi "
        "pair (_one_call), not on the GBS kernel of a cap with a law",
        claim="bench",
        call="trades",
    )
