"""The compiled peers of `benchmarks.bench_exact`, one call per impact and tolerance (issue 38).

Each peer is built once per potential and mass (`peer_cases`), then gives, for an impact
speed and a damping law, a call ``call(rtol) -> out`` (`OUT_FIELDS` of
`benchmarks._dop853_core`, physical units) whose tolerances scale with the impact as
`benchmarks.peer_dop853`'s always did (atol = rtol x the elastic turning point and x v0;
the Sundman peer's state is scaled by them). Building the tables is outside the call,
for every peer alike: what is timed is the compiled integration alone.

Peers (`PEERS`, the column names of the benchmark's rows):

* ``dop853``: the plain DOP853 on (q, q') with numba's pow (the benchmark's peer since
  issue 27, kept as a column);
* ``dop853_sqrt``: the same with powers in quarters by square roots (q^1.5 = q sqrt(q));
* ``sundman``: DOP853 on the Sundman-regularised equations (`benchmarks.peer_sundman`;
  power laws and sums of them only: None for caps);
* ``numbalsoda``: numbalsoda's dop853 on the regularised equations
  (`benchmarks.peer_numbalsoda`), where numbalsoda is installed.
"""

from __future__ import annotations

import numpy as np

from . import peer_dop853 as plain
from . import peer_sundman as sundman
from ._dop853_core import OUT_FIELDS

__all__ = ["PEERS", "PEER_LABELS", "outputs", "peer_cases"]

try:  # numbalsoda needs a Fortran compiler to build: a column only where it is installed
    from . import peer_numbalsoda as _nbs
except ImportError:  # pragma: no cover - depends on the machine
    _nbs = None

PEER_LABELS = {
    "dop853": "numba DOP853 (benchmarks.peer_dop853.solve_dop853)",
    "dop853_sqrt": "numba DOP853, q^1.5 as q sqrt(q) (benchmarks.peer_dop853.solve_dop853_sqrt)",
    "sundman": "numba DOP853 on the Sundman-regularised equations (benchmarks.peer_sundman)",
    "numbalsoda": "numbalsoda dop853 on the regularised equations (benchmarks.peer_numbalsoda)",
}
PEERS = tuple(k for k in PEER_LABELS if k != "numbalsoda" or _nbs is not None)
# Longest contact integrated, in units of the elastic turning point over v0 (the plain
# peers' t_bound; a Hertz contact lasts ~3.2 of them, a creeping damped return longer).
_T_BOUND = 50.0


def outputs(out, v0) -> dict:
    """The outputs of a peer's ``out`` by the names of the exact solvers' solutions."""
    return {
        "contact_time": out[0],
        "restitution": -out[1] / v0,
        "contact_time_zero_force": out[2],
        "restitution_zero_force": -out[3] / v0,
        "max_penetration": out[4],
        "max_force": out[5],
        "peak_force": out[6],
    }


def _plain_case(fn, el, pot, m):
    def case(v0, law):
        da, zeta = plain.damping_table(pot, law)
        q_scale = pot.turning_point(0.5 * m * v0 * v0, check=False)
        t_bound = _T_BOUND * q_scale / v0
        out = np.empty(len(OUT_FIELDS))

        def call(rtol):
            return fn(m, v0, zeta, el, da, rtol, rtol * q_scale, rtol * v0, t_bound, 0.0, out)

        return call

    return case


def _sundman_case(el, pot, m):
    def case(v0, law):
        da, zeta = plain.damping_table(pot, law)
        n = sundman.sundman_n(el, da, zeta)
        if n == 0:
            return None
        out = np.empty(len(OUT_FIELDS))

        def call(rtol):
            return sundman.solve_sundman(m, v0, zeta, el, da, n, rtol, sundman.S_BOUND, 0.0, out)

        return call

    return case


def peer_cases(pot, m) -> dict:
    """``{peer: case}`` for the peers that run ``pot``; ``case(v0, law)`` gives the call
    ``call(rtol) -> out`` of one impact (None where the peer does not run that law)."""
    el = plain.elastic_table(pot)
    cases = {
        "dop853": _plain_case(plain.solve_dop853, el, pot, m),
        "dop853_sqrt": _plain_case(plain.solve_dop853_sqrt, el, pot, m),
    }
    if sundman.sundman_n(el, np.zeros((0, 2)), 0.0):
        cases["sundman"] = _sundman_case(el, pot, m)
        if _nbs is not None:
            cases["numbalsoda"] = _nbs.case_factory(el, pot, m)
    return cases
