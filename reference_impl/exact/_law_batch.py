"""Many speeds of one general damping law on every core: the ``law=`` branch of `solve_impacts`.

`solve_law_impact` of each speed, bit for bit (test), run by a numba ``prange`` loop over
chunks of up to `_CHUNK` speeds (`_chunk`): in a chunk, the Taylor kernel steps `_taylor_lanes.LANES`
speeds side by side (`_taylor_lanes`: their series in one pass, each lane's operations
the single call's), and each row is formed into its fields as the single call forms it
(`_general_fields.form`); a speed the lanes do not take runs the single call's compiled
call (`_general_fields.solve_formed`, the GBS kernel included). Neither the thread
count, the schedule, the chunk nor the lane changes a bit (issue 27, goal 4). Each speed's validated top ``qE`` (`_validate._validated_top`: the speed's
own turning point, whatever was solved before) comes from one vectorised inverse of every
energy, bit for bit the per-speed value (`_tops`; a refusal is raised by the per-speed
loop, in order, as the serial loop raises it). What else is not compiled stays as in
`solve_law_impact`, one speed after another, in order:

* the linear oscillator in closed form and the potentials without a compiled kernel
  (sphere, ellipsoid, expression): the whole impact, by `prepare_law`,
* an integration that did not finish: `prepare_law`'s call of that speed again, which
  raises the message of `solve_law_impact`; a lost return: `general_law._refuse_lost_return`.

The bounds and fields are formed from each kernel row in that same compiled call, by the
one function that forms them for `solve_law_impact` (`_general_fields.form`); `_fields`
only puts them in the speed's column (the test compares every field with
`solve_law_impact` bit for bit).

Where the time goes (issue 38 goal 5, 100 000 Hertz impacts, linear dashpot and
Hunt-Crossley, one thread): the compiled loop is all but ~1 % of a batch (the planning,
the vectorised tops and `_finish` are each < 0.1 us an impact; chunks of 4, 64 or numba's
equal shares time alike), and in it the Taylor kernel (`_general_taylor`, K = 30: 9 steps
a linear-dashpot impact, 10 Hunt-Crossley on average, none handed to the GBS kernel).
Re-measured on 20 000 Hertz speeds (0.1-10 m/s, one thread, by variants of the kernel:
a part run twice or not at all; 2026-11-29), of ~17 us an impact: the series'
recurrences ~8 us (~47 %: a series costs ~0.85 us; four partial sums per convolution,
or the oldest terms summed first, measured slower, +2 us), the event scans and their
roots ~4 us (~25 %: 4 peak scans a linear-dashpot impact, 3 before the turning point,
and 1.1 zero-force scans; 4.8 peak scans a Hunt-Crossley one, 4.1 before it), the step's
radius ~0.7 us (~4 %), the turning point's and the exit's roots ~0.3 us each; 18 more
small arrays an impact cost nothing measurable (< 0.05 us). Since then the series run
side by side, eight lanes in one loop body (`_taylor_lanes`, 2026-11-30): ~0.36 us a lane
against ~0.85 alone, so the same 20 000 speeds take 11.8 us an impact at rtol 1e-11
(15.5 before; Hunt-Crossley 10.9, was 14.5), every field bit for bit. The rest (scans,
roots, radius) is each impact's own, stepped lane by lane.
"""

from __future__ import annotations

import numba
import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact._general_fields import FAILED, FORMED, form, solve_formed
from reference_impl.exact._general_kernel import OUT_FIELDS
from reference_impl.exact._general_kernel import solve as _gbs_solve
from reference_impl.exact._taylor_lanes import HANDED, LANES, solve_lanes
from reference_impl.exact._validate import _validated_top
from reference_impl.exact.general_law import _refuse_lost_return, prepare_law

__all__ = ["LAW_FIELDS", "solve_law_batch"]

# Fields of the returned dict, as floats: `solve_law_impact`'s as `form` gives them
# (`FORMED`: `LawImpactSolution`'s names, in its order), less the time of q_max and the step
# count, which a batch does not return.
LAW_FIELDS = tuple(k for k in FORMED if k not in ("time_of_max_penetration", "n_steps"))
# Speeds per chunk of the parallel loop, run side by side in the Taylor kernel's lanes
# (~2 ms each: the hand-out costs far less; the lanes idle only as a chunk drains).
_CHUNK = 128
# Chunks per thread at least, where the batch is small enough to need smaller chunks: a
# thread that ends first waits, on average, half a chunk for the others (2000 speeds on 2
# threads in chunks of 128: ~6 % of the call), while a chunk's lanes drain for about one
# impact's steps (~1 impact of series work a chunk, ~1.5 % of a chunk of 64).
_CHUNKS_PER_THREAD = 16
# Fewer speeds than this in a chunk run one at a time: a round of the lanes costs the
# series of all of them (~0.36 us a lane, eight lanes), one speed alone ~0.85 us, so the
# lanes gain from ~3.4 busy lanes on.
_LANES_FROM = 4


# Cached (its first compile takes seconds). It compiles in the kernel of other modules:
# the cache directory is keyed by the content of every compiled source
# (`reference_impl._numba_dir._COMPILED_SOURCES`, this file included), so a change of
# that kernel selects a fresh directory instead of reusing this machine code.
# error_model "numpy" on this loop and all it calls: an exception inside a prange loop
# cannot be carried out and poisoned every later call (issue 36); inf/NaN fails `form`.
@numba.njit(cache=True, parallel=True, error_model="numpy")
def _solve_rows(v, q_top, ks, ps, cs, es, sc, out, flags, chunk):  # pragma: no cover - compiled
    """``out[:, i]`` = the `LAW_FIELDS` of speed ``v[i]`` and ``flags[i]`` its flag of
    `_general_fields.form` (``chunk`` speeds per thread step, side by side in the Taylor
    kernel's lanes, `_taylor_lanes`: no bit depends on the threads, the lanes or the
    chunks): `OK`; `FAILED` (not finished within the step budget) and `LOST` (lost its
    return) are raised by `_finish`, in the order of the speeds."""
    n = v.shape[0]
    for c in numba.prange((n + chunk - 1) // chunk):
        lo = c * chunk
        hi = min(n, lo + chunk)
        rows = np.empty((hi - lo, len(OUT_FIELDS)))
        codes = np.ones(hi - lo, np.int64)  # 1: the single call
        if hi - lo >= _LANES_FROM:
            solve_lanes(v[lo:hi], q_top[lo:hi], ks, ps, cs, es, sc, rows, codes)
        for j in range(hi - lo):
            i = lo + j
            if codes[j] == 0:  # the row `solve_taylor` gives, formed as `solve_formed` forms it
                flags[i] = _fields(form(rows[j], v[i], q_top[i]), out[:, i])
            elif codes[j] == HANDED:  # `solve_taylor` hands it over alike: the GBS kernel's row
                flags[i] = _fields(
                    form(_gbs_solve(v[i], q_top[i], ks, ps, cs, es, sc), v[i], q_top[i]), out[:, i]
                )
            else:  # not for the lanes: the single call (the GBS kernel included)
                flags[i] = _fields(solve_formed(v[i], q_top[i], ks, ps, cs, es, sc), out[:, i])


@numba.njit(cache=True, error_model="numpy")
def _fields(f, col):  # pragma: no cover - compiled
    """``col`` = the `LAW_FIELDS` of one speed from `_general_fields.form`'s tuple ``f`` (its
    fields by `FORMED`'s names, `solve_law_impact`'s own numbers); returns its flag.

    Placed here, in the parallel loop, and not by numpy on the whole batch afterwards
    (~0.25 ms for 2000 speeds, serial: 1 % of the batch on one thread)."""
    (flag, q_max, max_force, peak_force, _t_peak, t_end, e, t_zf, e_zf, returns, err_t, err_w,
     _n_steps) = f  # fmt: skip
    # In `LAW_FIELDS`' order (the test compares each field with solve_law_impact by name).
    col[0] = q_max
    col[1] = max_force
    col[2] = peak_force
    col[3] = t_end
    col[4] = e
    col[5] = t_zf
    col[6] = e_zf
    col[7] = 1.0 if returns else 0.0
    col[8] = err_t
    col[9] = err_w
    return flag


def solve_law_batch(
    potential, m, v0s, law, max_impacts: int, *, rtol: float | None = None
) -> dict[str, np.ndarray]:
    """`solve_law_impact` of every speed of ``v0s``, as arrays of `LAW_FIELDS`.

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Mass (kg), > 0.
    v0s : array_like
        Approach speeds (m/s), > 0.
    law : DampingLaw or dict
        As for `solve_law_impact`.
    max_impacts : int
        Largest number of speeds accepted (`batch.BATCH_MAX`).
    rtol : float, optional
        As for `solve_law_impact` (None: full accuracy).

    Returns
    -------
    dict of numpy.ndarray
        One float array per field of `LAW_FIELDS`, of the shape of ``v0s``
        (``returns_to_q0`` as 1.0 / 0.0).
    """
    v = np.asarray(v0s, dtype=float)
    if v.size > max_impacts:
        raise HCVInputError(f"{v.size} impacts requested, more than BATCH_MAX = {max_impacts}")
    shape, v = v.shape, np.ascontiguousarray(v).ravel()
    out = np.full((len(LAW_FIELDS), v.size), np.nan)
    if not v.size:
        return {key: out[j].reshape(shape) for j, key in enumerate(LAW_FIELDS)}
    prepared = prepare_law(potential, m, law, rtol=rtol)
    plan = prepared._plan
    if plan.lin is not None or plan.pk is None:
        # Closed form, or a Python potential: no compiled loop to spread over the cores.
        for i in range(v.size):
            _store(out, i, prepared(float(v[i])))
        return {key: out[j].reshape(shape) for j, key in enumerate(LAW_FIELDS)}
    q_top = _tops(plan, prepared, v)
    flags = np.empty(v.size, dtype=np.int8)
    # Speeds cost unequal step counts: chunks handed out one by one as threads free up,
    # not one equal share each (rows do not depend on who computes them).
    with numba.parallel_chunksize(1):
        _solve_rows(
            v, q_top, plan.pk[0], plan.pk[1], plan.cs, plan.es, plan.sc, out, flags,
            _chunk(v.size, numba.get_num_threads()),
        )  # fmt: skip
    _finish(out, v, flags, prepared)
    return {key: out[j].reshape(shape) for j, key in enumerate(LAW_FIELDS)}


def _chunk(n: int, threads: int) -> int:
    """Speeds per chunk of the parallel loop: `_CHUNK`, or fewer where that would give a
    thread fewer than `_CHUNKS_PER_THREAD` chunks, down to `_taylor_lanes.LANES` (the
    rows do not depend on it)."""
    want = -(-n // (_CHUNKS_PER_THREAD * max(1, threads)))
    return int(min(_CHUNK, max(LANES, want)))


def _store(out: np.ndarray, i: int, sol) -> None:
    for j, key in enumerate(LAW_FIELDS):
        out[j, i] = float(getattr(sol, key))


def _tops(plan, prepared, v: np.ndarray) -> np.ndarray:
    """The ``qE`` of each speed, as `_solve_planned` takes it: `_validated_top` of its energy,
    bit for bit (test), all at once.

    `_validated_top(pot, E)` is the speed's own turning point ``pot._inverse([E])[0]``
    (no dependence on the speeds before it), checked on (0, qE]. The potentials that
    reach here (``plan.pk``: a power law or a sum of power laws) invert by elementwise
    numpy (`PowerLaw._inverse` in closed form; `Potential._numeric_inverse`, whose
    bracket and Newton steps update each element under its own mask), so one call on
    every energy gives each energy's bits; the check at the largest energy covers every
    (0, qE] (the cache of `_validated_top` skips the lower ones alike). This was a serial
    Python loop, one inverse per speed (~3 us for Hertz): 19 % of a 2000-speed Hertz +
    Hunt-Crossley batch on one thread, which capped two cores at 1.65x.

    Anything refused (a bad speed, a failed check, a non-positive turning point) is
    raised by the speed-by-speed loop, in order, so that the message is the serial one.
    """
    with np.errstate(all="ignore"):
        energy = 0.5 * plan.m * v * v  # as _solve_planned: (0.5 m v0) v0
    bad = ~(np.isfinite(v) & (v > 0) & np.isfinite(energy) & (energy > 0))
    for i in np.flatnonzero(bad)[:1]:
        prepared(float(v[i]))  # raises solve_law_impact's message for this speed
    pot = plan.potential
    try:
        _validated_top(pot, float(energy.max()))
        with np.errstate(all="ignore"):
            q_top = pot._inverse(energy)
        # turning_point's own test of each q_max (NoTurningPointError otherwise)
        refused = not bool(np.all(np.isfinite(q_top) & (q_top > 0)))
    except HCVInputError:
        refused = True
    if refused:
        return np.array([_validated_top(pot, float(e)) for e in energy])
    return q_top


def _finish(out: np.ndarray, v: np.ndarray, flags: np.ndarray, prepared) -> None:
    """The speeds `_solve_rows` flagged, in order, as the serial loop meets them."""
    plan = prepared._plan
    for i in np.flatnonzero(flags):
        if flags[i] == FAILED:
            # Not finished within the step budget: the single call raises its message.
            _store(out, i, prepared(float(v[i])))
        else:
            _refuse_lost_return(plan.potential, plan.law, plan.m, float(v[i]))
