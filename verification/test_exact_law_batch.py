"""`solve_impacts(..., law=...)` on every core: `solve_law_impact` bit for bit (issue 27, goal 4).

The general-law batch (`reference_impl.exact._law_batch`) integrates the speeds in a
numba prange loop and forms the fields from the kernel's rows as `solve_law_impact`
does; every field must be the single call's, on one thread and on all. Speed:
benchmarks/bench_exact.py and benchmarks/device_scaling.py.
"""

from __future__ import annotations

import dataclasses
import itertools

import numba
import numpy as np
import pytest

from reference_impl import PowerLaw, solve_impacts
from reference_impl.errors import HCVInputError
from reference_impl.exact import _general_fields, _law_batch
from reference_impl.exact._validate import _validated_top
from reference_impl.exact.general_law import LawImpactSolution, prepare_law, solve_law_impact
from reference_impl.potentials import SumPotential
from verification.assertions import assert_true

# Hertz (k = 1e9 Pa m^0.5, m = 4.1 g) with each kind of law, strengths of the calibrated
# study laws (e ~ 0.8 at 1 m/s) and a strong Hunt-Crossley damper.
LAWS = (
    {"law": "linear", "c": 26.7},
    {"law": "power", "c": 6.6e6, "exponent": 1.0},
    {"law": "polynomial", "c": [19.1, 1.87e6]},
    {"law": "viscoelastic", "A": 1.23e-6},
    {"law": "hunt-crossley", "alpha": 0.37},
    {"law": "hunt-crossley", "alpha": 5.0},
)
# What a batch returns, read off the solution itself (not the module's own list, so that a
# field the batch dropped would be missed here): every field of `LawImpactSolution` but its
# inputs and the two that `solve_impacts` documents it does not return.
_INPUTS = ("v0", "m", "law")
_SOLUTION = tuple(f.name for f in dataclasses.fields(LawImpactSolution))
BATCH_FIELDS = tuple(
    k for k in _SOLUTION if k not in (*_INPUTS, "time_of_max_penetration", "n_steps")
)
# Rising and falling speeds: the validation of `_validate._validated_top` is cached per
# potential, and no result may depend on it (each speed is compared with a fresh object).
SPEEDS = (1.0, 0.3, 3.0, 0.1, 7.0, 2.0)


def _hertz():
    return PowerLaw(1e9, 1.5), 0.0041


def _serial(make, m, law):
    """The reference: one `solve_law_impact` per speed, each on a fresh potential ``make()``
    (a result depends on its own inputs only, not on the speeds solved before)."""
    sols = [solve_law_impact(make(), m, v, law) for v in SPEEDS]
    return {key: np.array([float(getattr(s, key)) for s in sols]) for key in BATCH_FIELDS}


def test_batch_fields_are_the_solutions_and_form_names_them_in_its_order():
    """`form`'s tuple after its flag is the solution's fields less its inputs, in order
    (`general_law` fills the solution by position, `_law_batch` picks its columns by these
    names), and the batch returns exactly `BATCH_FIELDS`."""
    got = (_general_fields.FORMED, _law_batch.LAW_FIELDS)
    want = (tuple(k for k in _SOLUTION if k not in _INPUTS), BATCH_FIELDS)
    returned = tuple(solve_impacts(PowerLaw(1e9, 1.5), 0.0041, [1.0], law=LAWS[0]))
    assert_true(
        got == want and returned == BATCH_FIELDS,
        got=f"FORMED {got[0]}, LAW_FIELDS {got[1]}, solve_impacts returns {returned}",
        should=f"FORMED {want[0]}, LAW_FIELDS and the keys {want[1]}",
        claim="solve_impacts",
        call="_general_fields.FORMED, _law_batch.LAW_FIELDS",
    )


def test_law_batch_kernel_is_parallel():
    kernel = _law_batch._solve_rows
    assert_true(
        kernel.targetoptions.get("parallel") is True,
        got=f"_solve_rows compiled with {kernel.targetoptions}",
        should="parallel=True (numba prange over the speeds)",
        claim="solve_impacts",
        call="_law_batch._solve_rows",
    )


@pytest.mark.parametrize("law", LAWS, ids=lambda t: f"{t['law']}")
def test_law_batch_is_solve_law_impact_bit_for_bit(law):
    cores = numba.config.NUMBA_NUM_THREADS
    _, m = _hertz()
    want = _serial(lambda: _hertz()[0], m, law)
    before = numba.get_num_threads()
    try:
        for threads in sorted({1, cores}):
            numba.set_num_threads(threads)
            got = solve_impacts(PowerLaw(1e9, 1.5), m, np.array(SPEEDS), law=law)
            for key, ref in want.items():
                assert_true(
                    got[key].tobytes() == ref.tobytes(),
                    got=f"{key} = {got[key]}",
                    should=f"{ref} (solve_law_impact per speed, bit for bit)",
                    claim="solve_impacts",
                    call=f"solve_impacts(hertz, {m}, {SPEEDS}, law={law}) on {threads} threads",
                )
    finally:
        numba.set_num_threads(before)


def test_law_batch_sum_and_shape():
    law = LAWS[4]
    want = _serial(lambda: SumPotential(PowerLaw(1e9, 1.5), PowerLaw(1e12, 2.5)), 0.01, law)
    v = np.array(SPEEDS).reshape(2, 3)
    got = solve_impacts(SumPotential(PowerLaw(1e9, 1.5), PowerLaw(1e12, 2.5)), 0.01, v, law=law)
    for key, ref in want.items():
        assert_true(
            got[key].shape == (2, 3) and got[key].ravel().tobytes() == ref.tobytes(),
            got=f"{key} = {got[key]}",
            should=f"{ref.reshape(2, 3)} (solve_law_impact per speed)",
            claim="solve_impacts",
            call=f"solve_impacts(hertz + power 2.5, 0.01, 2x3 speeds, law={law})",
        )


@pytest.mark.parametrize(
    "pot, m, speeds, bad",
    (
        (PowerLaw(1e9, 1.5), 0.0041, [1.0, -1.0], -1.0),
        # k = 1e-300: 1.5 E / k overflows from E ~ 1e8 J on (q_max inf). The serial loop
        # refuses the first such speed in the order given, not the largest: the batch's
        # one vectorised inverse falls back to the per-speed loop to name it.
        (PowerLaw(1e-300, 1.5), 1.0, [1.0, 1e5, 2e5], 1e5),
    ),
    ids=("negative speed", "no finite turning point"),
)
def test_law_batch_refuses_a_bad_speed_as_the_single_call(pot, m, speeds, bad):
    with pytest.raises(HCVInputError) as single, np.errstate(all="ignore"):
        solve_law_impact(pot, m, bad, LAWS[4])
    with pytest.raises(HCVInputError) as batch, np.errstate(all="ignore"):
        solve_impacts(pot, m, speeds, law=LAWS[4])
    assert str(batch.value) == str(single.value), (
        f"got {batch.value}, should be {single.value} [solve_impacts, law batch refusal]"
    )


def test_law_batch_rows_that_never_return():
    """Hertz + a constant dashpot: the slow speeds creep back and never reach q = 0
    (inf contact time, restitution 0, NaN-free zero-force fields), beside returning ones."""
    law, m, speeds = {"law": "linear", "c": 50.0}, 1e-3, (1e-4, 1.0, 3e-4, 0.1)
    sols = [solve_law_impact(PowerLaw(1e9, 1.5), m, v, law) for v in speeds]  # fresh objects
    assert not sols[0].returns_to_q0 and sols[1].returns_to_q0, "workload lost its creep"
    got = solve_impacts(PowerLaw(1e9, 1.5), m, np.array(speeds), law=law)
    for key in BATCH_FIELDS:
        ref = np.array([float(getattr(s, key)) for s in sols])
        assert_true(
            got[key].tobytes() == ref.tobytes(),
            got=f"{key} = {got[key]}",
            should=f"{ref} (solve_law_impact per speed, bit for bit)",
            claim="solve_impacts",
            call=f"solve_impacts(hertz, {m}, {speeds}, law={law})",
        )


@pytest.mark.parametrize(
    "make",
    (
        lambda: PowerLaw(1e9, 1.5),
        lambda: SumPotential(PowerLaw(3e5, 1.0), PowerLaw(1e9, 1.5), PowerLaw(1e14, 3.7)),
    ),
    ids=("hertz", "sum"),
)
def test_law_batch_tops_are_each_speeds_own_in_one_inverse(make):
    """The turning points of a batch come from one inverse of every energy (not one per
    speed: the serial Python loop that capped two cores), each bit for bit the speed's own
    `_validated_top` on a fresh potential, whatever the order (rising and falling speeds)."""
    rng = np.random.default_rng(27)
    v = 10.0 ** rng.uniform(-3.0, 2.0, 300)
    law = LAWS[4]
    prepared = prepare_law(make(), 0.01, law)
    pot = prepared._plan.potential
    calls = []
    inverse = pot._inverse
    pot._inverse = lambda u: calls.append(np.size(u)) or inverse(u)  # instance attribute
    got = _law_batch._tops(prepared._plan, prepared, v)
    want = np.array([_validated_top(make(), float(0.5 * 0.01 * x * x)) for x in v])
    assert_true(
        got.tobytes() == want.tobytes(),
        got=f"tops differ at {np.flatnonzero(got != want)[:3]}",
        should="each speed's own _validated_top, bit for bit",
        claim="solve_impacts",
        call=f"_law_batch._tops({type(pot).__name__}, 300 speeds)",
    )
    assert_true(
        len(calls) <= 2,
        got=f"{len(calls)} inverse calls (sizes {calls[:4]}...)",
        should="<= 2 (the check at the largest energy, one vectorised inverse)",
        claim="solve_impacts",
        call=f"_law_batch._tops({type(pot).__name__}, 300 speeds)",
    )


def test_law_batch_over_several_chunks_is_solve_law_impact_bit_for_bit():
    """More speeds than the largest chunk of the parallel loop (`_law_batch._CHUNK`), each
    chunk's speeds side by side in the Taylor kernel's lanes, and batches too small for the
    lanes (`_LANES_FROM`): every field of every speed as its own `solve_law_impact`, on one
    thread and on all (chunks, lanes and threads change no bit)."""
    v = 10.0 ** np.random.default_rng(38).uniform(-1.0, 1.0, 2 * _law_batch._CHUNK + 45)
    law = LAWS[4]
    pot, m = _hertz()
    sols = [solve_law_impact(pot, m, float(x), law) for x in v]
    every = {key: np.array([float(getattr(s, key)) for s in sols]) for key in BATCH_FIELDS}
    before = numba.get_num_threads()
    try:
        for threads, n in itertools.product(
            sorted({1, numba.config.NUMBA_NUM_THREADS}), (v.size, 1, 3, 4, 9)
        ):
            numba.set_num_threads(threads)
            got = solve_impacts(PowerLaw(1e9, 1.5), m, v[:n], law=law)
            for key, ref in every.items():
                ref = ref[:n]
                bad = np.flatnonzero(got[key].view(np.int64) != ref.view(np.int64))
                assert_true(
                    bad.size == 0,
                    got=f"{key} differs at {bad.size} speeds, first v0 = {v[bad[:1]]}: {got[key][bad[:1]]}",
                    should=f"{ref[bad[:1]]} (solve_law_impact per speed, bit for bit)",
                    claim="solve_impacts",
                    call=f"solve_impacts(hertz, {m}, {n} speeds, law={law}) on {threads} threads",
                )
    finally:
        numba.set_num_threads(before)


def test_law_batch_chunks_leave_every_thread_several():
    """Chunks of at most `_CHUNK` speeds, at least `LANES` (a chunk fills the lanes), and at
    least `_CHUNKS_PER_THREAD` of them per thread where the batch allows it."""
    cases = ((100_000, 2, 128), (100_000, 16, 128), (2000, 2, 63), (300, 2, 10), (130, 2, 8))
    for n, threads, want in cases:
        got = _law_batch._chunk(n, threads)
        assert_true(
            got == want,
            got=f"{got} speeds a chunk",
            should=f"{want}",
            claim="solve_impacts",
            call=f"_law_batch._chunk({n}, {threads})",
        )
