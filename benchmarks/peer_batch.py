"""The strongest compiled peers over many impacts, in one numba ``prange`` loop (issue 38, goal 5).

`reference_impl.solve_impacts` runs a batch on every core; its fair peer is the fastest
per-impact integrator of `benchmarks._peers` run the same way: one compiled, parallel
loop over the impacts, each impact the very call the serial peer makes (the same
compiled function, the same arguments, so the same bits: test), one impact per thread
step. Two peers, the ones that are fastest at equal error in `benchmarks.bench_exact`:

* ``sundman``: `benchmarks.peer_sundman.solve_sundman` (DOP853 on the
  Sundman-regularised equations; power laws and their sums);
* ``dop853_sqrt``: `benchmarks.peer_dop853.solve_dop853_sqrt` (DOP853 on (q, q') with
  q^1.5 as q sqrt(q)).

The plain ``dop853`` is left out: it takes the steps of ``dop853_sqrt`` with a costlier
power per evaluation (1.6x, issue 38), so it is never the fastest.

`batch_call` builds, once per batch, everything the serial peer builds per impact in
Python (the tables, the turning point that scales the plain peer's tolerances, N of the
transformation), outside the call it returns: what that call does, and what a benchmark
times, is the compiled loop alone, for the peer as in `benchmarks._peers`.
"""

from __future__ import annotations

import numba
import numpy as np

from . import peer_dop853 as plain
from . import peer_sundman as sundman
from ._dop853_core import OUT_FIELDS
from ._peers import _T_BOUND, PEER_LABELS

__all__ = ["BATCH_PEERS", "batch_call"]

BATCH_PEERS = ("sundman", "dop853_sqrt")
assert all(p in PEER_LABELS for p in BATCH_PEERS)


# error_model "numpy" as every peer kernel (and because an exception cannot leave a prange
# loop: `reference_impl.exact.batch`, issue 36): a bad step gives inf/NaN and a status.
@numba.njit(cache=True, parallel=True, error_model="numpy")
def _sundman_rows(m, v0, zeta, EL, DA, N, rtol, s_bound, out):  # pragma: no cover - compiled
    """``out[i]`` = `solve_sundman` of impact i (one impact per thread step)."""
    for i in numba.prange(v0.shape[0]):
        sundman.solve_sundman(m, v0[i], zeta[i], EL, DA, N[i], rtol, s_bound, 0.0, out[i])


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _sqrt_rows(m, v0, zeta, EL, DA, rtol, q_scale, t_bound, out):  # pragma: no cover - compiled
    """``out[i]`` = `solve_dop853_sqrt` of impact i, its tolerances scaled as
    `benchmarks._peers` scales them (atol = rtol q_scale and rtol v0)."""
    for i in numba.prange(v0.shape[0]):
        plain.solve_dop853_sqrt(
            m, v0[i], zeta[i], EL, DA, rtol, rtol * q_scale[i], rtol * v0[i], t_bound[i],
            0.0, out[i],
        )  # fmt: skip


def batch_call(peer: str, pot, m: float, v0s, zetas=None, law: dict | None = None):
    """The call ``call(rtol) -> out`` of ``peer`` over every impact, or None.

    Parameters
    ----------
    peer : str
        One of `BATCH_PEERS`.
    pot : Potential
        The contact potential (a power law or a sum of them for ``sundman``).
    m : float
        Mass (kg).
    v0s : array_like
        Impact speeds (m/s).
    zetas : array_like, optional
        The universal law's damping ratio of each impact (broadcast against ``v0s``);
        with ``law`` None.
    law : dict, optional
        One damping law of `reference_impl.theory.laws` for every impact (then ``zetas``
        is None).

    Returns
    -------
    callable or None
        ``call(rtol)`` returns an array of shape (len(v0s), len(`OUT_FIELDS`)): row i is
        the serial peer's ``out`` of impact i at ``rtol``, bit for bit (physical units).
        None where the peer does not run ``pot`` (the Sundman peer on a cap).
    """
    if peer not in BATCH_PEERS:
        raise ValueError(f"peer must be one of {BATCH_PEERS}, got {peer!r}")
    if (zetas is None) == (law is None):
        raise ValueError("give either zetas (the universal law) or law, not both")
    v = np.ascontiguousarray(v0s, dtype=float).ravel()
    el = plain.elastic_table(pot)
    if law is None:
        da = np.zeros((0, 2))
        z = np.ascontiguousarray(np.broadcast_to(np.asarray(zetas, float), v.shape))
    else:
        da, z0 = plain.damping_table(pot, law)
        z = np.full(v.shape, z0)
    out = np.empty((v.size, len(OUT_FIELDS)))
    if peer == "sundman":
        # sundman_n reads zeta only as zeta > 0 (the universal law's own exponent): two values.
        n_on, n_off = sundman.sundman_n(el, da, 1.0), sundman.sundman_n(el, da, 0.0)
        if min(n_on, n_off) == 0:
            return None
        n = np.where(z > 0.0, n_on, n_off).astype(np.int64)

        def call(rtol):
            _sundman_rows(m, v, z, el, da, n, rtol, sundman.S_BOUND, out)
            return out

        return call
    # The serial peer's turning point (`benchmarks._peers._plain_case`), impact by impact.
    q_scale = np.array([pot.turning_point(0.5 * m * x * x, check=False) for x in v])
    t_bound = _T_BOUND * q_scale / v

    def call(rtol):
        _sqrt_rows(m, v, z, el, da, rtol, q_scale, t_bound, out)
        return out

    return call
