"""Many speeds of one general damping law on every core: the ``law=`` branch of `solve_impacts`.

`solve_law_impact` of each speed, bit for bit (test), with the compiled integration of
the speeds (`general_law._compiled_solve`, the kernel `solve_law_impact` itself calls) run
by a numba ``prange`` loop, one speed per thread step, so that neither the thread count
nor the schedule changes a bit (issue 27, goal 4). What is not compiled stays as in
`solve_law_impact`, one speed after another, in the order given:

* each speed's checks and its validated top ``qE`` (`_validate._validated_top`, whose
  cache makes ``qE`` depend on the speeds solved before: so the same order),
* the linear oscillator in closed form and the potentials without a compiled kernel
  (sphere, ellipsoid, expression): the whole impact, by `prepare_law`,
* an integration that did not finish: `prepare_law`'s call of that speed again, which
  raises the message of `solve_law_impact`; a lost return: `general_law._refuse_lost_return`.

The bounds and fields are then formed from the kernel's row as `general_law._solve_planned`
forms them (`_finish`; the test compares every field with `prepare_law` bit for bit, so the
two cannot drift apart unseen).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact import general_law as _gl
from reference_impl.exact._general_kernel import OUT_FIELDS, STOP_NO_RETURN_Q
from reference_impl.exact._validate import _validated_top

__all__ = ["LAW_FIELDS", "solve_law_batch"]

# Fields of the returned dict (`LawImpactSolution`'s names), as floats.
LAW_FIELDS = (
    "max_penetration",
    "max_force",
    "peak_force",
    "contact_time",
    "restitution",
    "contact_time_zero_force",
    "restitution_zero_force",
    "returns_to_q0",
    "error_time",
    "error_restitution",
)
_COL = {name: j for j, name in enumerate(OUT_FIELDS)}
_EPS = np.finfo(float).eps
# Speeds per chunk of the parallel loop (~20-200 us each: the hand-out costs far less).
_CHUNK = 4
# The compiled integration `solve_law_impact` calls (bound once; a global of the loop below).
_SOLVE = _gl._compiled_solve


# Cached (its first compile takes seconds): like `_general_taylor.solve`, which calls the
# GBS kernel of another module, a change of the called kernel alone does not refresh the
# cache; the bit-for-bit test against `solve_law_impact` then fails (clear __pycache__).
@numba.njit(cache=True, parallel=True)
def _solve_rows(v, q_top, ks, ps, cs, es, sc, rows):  # pragma: no cover - compiled
    """``rows[i]`` = the kernel's `OUT_FIELDS` of speed ``v[i]`` (one speed per thread step)."""
    for i in numba.prange(v.shape[0]):
        rows[i, :] = _SOLVE(v[i], q_top[i], ks, ps, cs, es, sc)


def solve_law_batch(potential, m, v0s, law, max_impacts: int) -> dict[str, np.ndarray]:
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
    prepared = _gl.prepare_law(potential, m, law)
    plan = prepared._plan
    if plan.lin is not None or plan.pk is None:
        # Closed form, or a Python potential: no compiled loop to spread over the cores.
        for i in range(v.size):
            _store(out, i, prepared(float(v[i])))
        return {key: out[j].reshape(shape) for j, key in enumerate(LAW_FIELDS)}
    q_top = np.empty(v.size)
    for i in range(v.size):
        vi = float(v[i])
        energy = 0.5 * plan.m * vi * vi
        if not (math.isfinite(vi) and vi > 0 and math.isfinite(energy) and energy > 0):
            prepared(vi)  # raises solve_law_impact's message for this speed
        q_top[i] = _validated_top(plan.potential, energy)
    rows = np.empty((v.size, len(OUT_FIELDS)))
    # Speeds cost unequal step counts: small chunks handed out as threads free up, not
    # one equal share each (rows do not depend on who computes them).
    with numba.parallel_chunksize(_CHUNK):
        _solve_rows(v, q_top, plan.pk[0], plan.pk[1], plan.cs, plan.es, plan.sc, rows)
    for i in range(v.size):
        _finish(out, i, float(v[i]), float(q_top[i]), rows[i], prepared)
    return {key: out[j].reshape(shape) for j, key in enumerate(LAW_FIELDS)}


def _store(out: np.ndarray, i: int, sol) -> None:
    for j, key in enumerate(LAW_FIELDS):
        out[j, i] = float(getattr(sol, key))


def _finish(out: np.ndarray, i: int, v0: float, q_top: float, row: np.ndarray, prepared) -> None:
    """Column ``i`` of ``out`` from the kernel's row, as `general_law._solve_planned`."""
    r = {name: float(row[j]) for name, j in _COL.items()}
    if r["status"] != 0.0 or not math.isfinite(r["q_max"]):
        # Not finished within the step budget: the single call raises its message.
        _store(out, i, prepared(v0))
        return
    returns = r["returns"] == 1.0
    if not returns and r["stop"] == STOP_NO_RETURN_Q:
        plan = prepared._plan
        _gl._refuse_lost_return(plan.potential, plan.law, plan.m, v0)
    nst = int(r["n_steps"])
    t_scale = q_top / v0
    t_end = r["t_end"] if returns else math.inf
    err_t = _gl.ERROR_SAFETY * r["err_t"] * t_scale + 100 * nst * _EPS * (
        t_end if returns else r["t_zf"] if math.isfinite(r["t_zf"]) else t_scale
    )
    if r["err_zf"] > 0.0:  # the zero-force instant's own sensitivity (_general_kernel)
        err_t += _gl.ERROR_SAFETY * r["err_zf"]
    err_w = _gl.ERROR_SAFETY * r["err_w"] + 100 * nst * _EPS
    col = (
        r["q_max"],
        r["max_force"],
        r["peak_force"],
        t_end,
        -r["w_end"] / v0 if returns else 0.0,
        r["t_zf"],
        -r["w_zf"] / v0,
        1.0 if returns else 0.0,
        err_t,
        err_w,
    )
    for j, value in enumerate(col):
        out[j, i] = value
