"""The Taylor kernel's lanes: many impacts side by side, each bit for bit the single one.

`_taylor_lanes.solve_lanes` steps `LANES` impacts of one law together (their series in one
pass, `_taylor_lanes_series`), refilling a lane as its impact ends (issue 38, goal 5).
Every row it returns must be the row of `_general_taylor.solve_taylor` for that speed, bit
for bit, whatever its lane and neighbours; every speed it cannot take (not for the Taylor
method, or a series of another structure) must be marked for the single call, and only
those. The generated series must be the text its generator writes.
"""

from __future__ import annotations

import numpy as np
import pytest

from reference_impl.exact import _general_taylor as gt
from reference_impl.exact import _lanes_source, _law_batch, _taylor_lanes
from reference_impl.exact.general_law import prepare_law
from reference_impl.potentials import PowerLaw, SumPotential
from reference_impl.studies.laws import calibrated_laws, hertz
from verification.assertions import assert_true

CLAIM = "solve_impacts (Taylor lanes)"
CALL = "_taylor_lanes.solve_lanes"


def _speeds(n, seed, lo=-2.0, hi=2.0):
    """``n`` speeds (m/s), log-uniform over 10^lo-10^hi: step counts differ from lane to lane."""
    return 10.0 ** np.random.default_rng(seed).uniform(lo, hi, n)


def _single(prepared, v, tops):
    """Each speed's row and code from `solve_taylor` (the single call's Taylor stage)."""
    p = prepared._plan
    rows, codes = [], []
    for v0, qe in zip(v, tops, strict=True):
        out = np.full(len(gt.OUT_FIELDS), np.nan)
        codes.append(gt.solve_taylor(v0, qe, p.pk[0], p.pk[1], p.cs, p.es, p.sc, out))
        rows.append(out)
    return np.array(rows), np.array(codes)


def _lanes(prepared, v, tops):
    p = prepared._plan
    rows = np.empty((v.size, len(gt.OUT_FIELDS)))
    codes = np.empty(v.size, np.int64)
    _taylor_lanes.solve_lanes(v, tops, p.pk[0], p.pk[1], p.cs, p.es, p.sc, rows, codes)
    return rows, codes


def _structure(prepared, v0, qe):
    """The degrees and powers of the speed's series (`series_plan`), as tuples."""
    p = prepared._plan
    N = gt.common_n(p.pk[0], p.pk[1], p.cs, p.es, p.sc)
    L = gt.scale(v0, qe, p.pk[0], p.pk[1], p.sc[0])
    F, C = gt.model(v0, L, N, p.pk[0], p.pk[1], p.cs, p.es, p.sc)
    plan = gt.series_plan(N, F, C, np.zeros(gt.DEG_MAX + 1), False)
    return tuple(tuple(a) for a in plan[5:7] + plan[8:9])


def _check(prepared, v, label):
    tops = _law_batch._tops(prepared._plan, prepared, v)
    want, want_codes = _single(prepared, v, tops)
    got, codes = _lanes(prepared, v, tops)
    done = codes == 0
    assert_true(
        np.all(want_codes[done] == 0),
        got=f"speeds {v[done & (want_codes != 0)][:3]} finished in a lane",
        should="only speeds the single Taylor call finishes",
        claim=CLAIM,
        call=f"{CALL}({label})",
    )
    bad = np.flatnonzero(done & np.any(got.view(np.int64) != want.view(np.int64), axis=1))
    assert_true(
        bad.size == 0,
        got=f"{bad.size} rows differ, first at v0 = {v[bad[:1]]}: {got[bad[:1]]}",
        should=f"{want[bad[:1]]} (solve_taylor's row, bit for bit)",
        claim=CLAIM,
        call=f"{CALL}({label}, {v.size} speeds)",
    )
    handed = codes == _taylor_lanes.HANDED
    assert_true(
        np.all(want_codes[handed] == 1),
        got=f"speeds {v[handed & (want_codes != 1)][:3]} handed to the GBS kernel by a lane",
        should="only speeds the single Taylor call hands over too",
        claim=CLAIM,
        call=f"{CALL}({label})",
    )
    # a speed the single call finishes goes to the single call only for another structure
    first = _structure(prepared, v[np.flatnonzero(done)[0]], tops[np.flatnonzero(done)[0]])
    for i in np.flatnonzero(~done & (want_codes == 0)):
        assert_true(
            _structure(prepared, v[i], tops[i]) != first,
            got=f"v0 = {v[i]} handed to the single call with the lanes' structure",
            should="taken by a lane",
            claim=CLAIM,
            call=f"{CALL}({label})",
        )
    return codes


def test_generated_series_is_its_generators_text():
    text = _lanes_source.TARGET.read_text(encoding="utf-8")
    assert_true(
        text == _lanes_source.source(),
        got=f"{_lanes_source.TARGET.name} differs from its generator's text",
        should="the text of _lanes_source.source() (run python -m reference_impl.exact._lanes_source)",
        claim=CLAIM,
        call="_lanes_source.source()",
    )


@pytest.mark.parametrize("rtol", (None, 1e-8), ids=("full", "rtol 1e-8"))
@pytest.mark.parametrize("name", tuple(calibrated_laws()))
def test_lanes_are_the_single_call_bit_for_bit(name, rtol):
    """Every law of the study on Hertz, 203 speeds over four decades (not a multiple of the
    lanes: the last round runs part-empty)."""
    pot, m = hertz()
    prepared = prepare_law(pot, m, calibrated_laws()[name], rtol=rtol)
    codes = _check(prepared, _speeds(203, 38), f"hertz, {name}, rtol {rtol}")
    assert_true(
        np.count_nonzero(codes == 0) > 150,
        got=f"{np.count_nonzero(codes == 0)} of 203 speeds finished in the lanes",
        should="most (else the comparison proves little)",
        claim=CLAIM,
        call=f"{CALL}(hertz, {name})",
    )


def test_a_speed_of_another_structure_goes_to_the_single_call():
    """C = c0 + c1 q with c0 = 3.6e-291 kg/s on k q^3: its scaled term c0 L / (m v0), with
    L ~ v0^(1/2), underflows to 0 at the fastest speeds, where the series lose that term:
    those speeds are not the lanes' structure, and must go to the single call; the others
    stay bit for bit."""
    law = {"law": "polynomial", "c": [3.6e-291, 1.5e-13]}
    prepared = prepare_law(PowerLaw(56796532.8, 3.0), 0.0016, law)
    v = np.concatenate([_speeds(20, 1, 0.0, 1.0), _speeds(20, 2, 66.0, 72.0), _speeds(20, 3)])
    v = v[np.random.default_rng(4).permutation(v.size)]
    tops = _law_batch._tops(prepared._plan, prepared, v)
    shapes = {_structure(prepared, v0, qe) for v0, qe in zip(v, tops, strict=True)}
    assert len(shapes) == 2, f"workload lost its two structures: {shapes}"
    codes = _check(prepared, v, "k q^3, c0 ~ 3.6e-291")
    assert_true(
        np.count_nonzero(codes == 1) >= 1,
        got="no speed handed to the single call",
        should="the speeds of the other structure",
        claim=CLAIM,
        call=f"{CALL}(k q^3, c0 ~ 3.6e-291)",
    )


def test_a_sum_of_powers_in_lanes():
    prepared = prepare_law(
        SumPotential(PowerLaw(3e5, 1.0), PowerLaw(1e9, 1.5)), 0.01, calibrated_laws()["linear"]
    )
    _check(prepared, _speeds(37, 5), "hooke + hertz, linear")


def test_a_creeping_return_is_handed_over_as_the_single_call_hands_it():
    """Hertz + a strong constant dashpot: the slow speeds creep back and never reach q = 0,
    which the Taylor method hands to the GBS kernel (`HANDED`), as `solve_taylor` does."""
    prepared = prepare_law(PowerLaw(1e9, 1.5), 1e-3, {"law": "linear", "c": 50.0})
    v = np.array([1e-4, 1.0, 3e-4, 0.1, 2e-4, 0.5, 0.05, 0.02, 5e-4])
    codes = _check(prepared, v, "hertz, linear c = 50")
    assert_true(
        np.count_nonzero(codes == _taylor_lanes.HANDED) >= 3,
        got=f"codes {codes}",
        should="at least the creeping speeds 1e-4, 2e-4, 3e-4 m/s handed over",
        claim=CLAIM,
        call=f"{CALL}(hertz, linear c = 50)",
    )
