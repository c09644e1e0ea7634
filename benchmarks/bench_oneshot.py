"""One-shot against prepared calls, with and without the one-shot caches, beside the
strongest peer (issue 38, goals 3-4): ratios in one process, interleaved.

Contestants per row, each a loop over the same set of distinct random impacts (speeds
log-uniform in [0.05, 5] m/s, zeta uniform in [0, 0.85) for the universal law; for a
general law, either one law for every impact or, in the rows marked "new law each",
its strength times 10^u, u uniform in [-1, 0], per impact, as the work-precision bench
draws them (`benchmarks._equal_error.random_impacts`), so that no one-shot cache hits
while the set holds more impacts than the caches keep, `_oneshot_cache.KEPT` = 64):

* ``oneshot``: `reference_impl.solve` (the universal law) or `solve_law_impact`;
* ``oneshot_uncached``: the same with the one-shot caches bypassed (the power constants'
  `_constants.__wrapped__`, `general_law._new_plan`, `law_from_dict`), for the caches'
  share in the same process and load; the lazy turning point (`_strategies.Job.q_top`)
  stays on, so for the universal law this is faster than main's path;
* ``prepared``: `prepare(pot, m, rtol=...)` / `prepare_law` (with a new law each impact,
  one prepared solver per impact, built outside the timing, each called once);
* ``sundman``: the Sundman-regularised compiled DOP853 (`benchmarks.peer_sundman`, the
  strongest peer of issue 38) at the cheapest rung of its ladder whose worst relative
  error over the set (contact times and restitutions against ours at full accuracy,
  whose bound is ~1e-15) is at most the row's target (or its most accurate rung, marked
  ``best``, when none is).

At a target of 1e-8 ours runs with ``rtol=1e-8`` (its bound <= 1e-8 of each time). CPU
time (`time.process_time`), blocks of ~10 ms per contestant in turn, the median per
impact; the machine may be loaded: read the ratios, not the times. Nothing is recorded
(the lead regenerates committed records on a quiet machine).

Run: ``python -m benchmarks.bench_oneshot [--blocks N] [--impacts N]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import reference_impl as ri
import reference_impl.exact._oneshot_cache as oneshot_cache
import reference_impl.exact._power_kernel as power_kernel
import reference_impl.exact._route as route_mod
import reference_impl.exact.general_law as general_law
from reference_impl import PowerLaw
from reference_impl.theory.laws import law_from_dict

from . import peer_dop853 as plain
from . import peer_sundman as sundman
from ._dop853_core import OUT_FIELDS
from ._equal_error import LOG_STRENGTH

__all__ = ["main", "run"]

M = 0.1
K = 1e6
BLOCK_S = 0.01  # CPU seconds per contestant and block
TARGETS = (1e-14, 1e-8)
RUNG_RTOLS = tuple(10.0 ** (-k / 2) for k in range(12, 33))  # the peer's ladder 1e-6..1e-16
_KEYS = ("contact_time", "restitution", "contact_time_zero_force", "restitution_zero_force")


class _Uncached:
    """Within it, the one-shot caches are bypassed (main's path before them)."""

    def __enter__(self):
        self._saved = (power_kernel._constants, general_law._plan, route_mod.cached_law)
        power_kernel._constants = power_kernel._constants.__wrapped__
        general_law._plan = general_law._new_plan
        route_mod.cached_law = lambda law, where="damping": law_from_dict(law, where=where)
        return self

    def __exit__(self, *exc):
        power_kernel._constants, general_law._plan, route_mod.cached_law = self._saved
        oneshot_cache._LAWS.clear()


def _loop(fn, cases, uncached=False):
    def run_all():
        if uncached:
            with _Uncached():
                for c in cases:
                    fn(*c)
        else:
            for c in cases:
                fn(*c)

    return run_all


def _interleaved(contestants: dict, blocks: int, n_cases: int) -> dict:
    """Median CPU microseconds per impact of each contestant, timed block by block."""
    inner = {}
    for name, fn in contestants.items():
        fn()  # compile / warm
        t0 = time.process_time()
        fn()
        inner[name] = max(1, int(BLOCK_S / max(time.process_time() - t0, 1e-7)))
    times = {name: [] for name in contestants}
    for _ in range(blocks):
        for name, fn in contestants.items():
            t0 = time.process_time()
            for _ in range(inner[name]):
                fn()
            times[name].append((time.process_time() - t0) / inner[name] / n_cases * 1e6)
    return {name: statistics.median(ts) for name, ts in times.items()}


def _peer_rung(pot, law, impacts, truths, target):
    """The peer's cheapest rung (fewest evaluations) at worst error <= target, its calls;
    when no rung gets there, its most accurate rung, marked ``best`` (ours is then ahead
    in accuracy as well as time)."""
    el = plain.elastic_table(pot)
    best, closest = None, None
    for rtol in RUNG_RTOLS:
        calls, worst, nfev = [], 0.0, 0
        for (v0, zeta), truth in zip(impacts, truths, strict=True):
            # ``zeta`` is the impact's own law where the row draws one per impact
            lw = zeta if law is not None else {"law": "universal", "zeta": zeta}
            da, z = plain.damping_table(pot, lw)
            n = sundman.sundman_n(el, da, z)
            out = np.empty(len(OUT_FIELDS))
            sundman.solve_sundman(M, v0, z, el, da, n, rtol, sundman.S_BOUND, 0.0, out)
            got = {
                "contact_time": out[0],
                "restitution": -out[1] / v0,
                "contact_time_zero_force": out[2],
                "restitution_zero_force": -out[3] / v0,
            }
            worst = max(worst, *(abs(got[k] / truth[k] - 1.0) for k in _KEYS))
            nfev += int(out[7])
            calls.append((M, v0, z, el, da, n, rtol, sundman.S_BOUND, 0.0, out))
        if worst <= target and (best is None or nfev < best[0]):
            best = (nfev, rtol, worst, calls, "")
        if closest is None or worst < closest[2]:
            closest = (nfev, rtol, worst, calls, " best")
    return best or closest


def _scaled(law: dict, factor: float) -> dict:
    """``law`` with its one strength parameter (c or alpha) times ``factor``."""
    key = "c" if "c" in law else "alpha"
    return {**law, key: factor * law[key]}


def _row(name, pot, law, blocks, n, target, seed=5, distinct=False):
    rng = np.random.default_rng(seed)
    v0s = 10.0 ** rng.uniform(np.log10(0.05), np.log10(5.0), n)
    zetas = rng.uniform(0.0, 0.85, n) if law is None else np.zeros(n)
    impacts = list(zip(v0s.tolist(), zetas.tolist(), strict=True))
    if law is not None:  # each impact with its law (the same one unless ``distinct``)
        f = 10.0 ** rng.uniform(*LOG_STRENGTH, n) if distinct else np.ones(n)
        impacts = [
            (v, _scaled(law, g) if distinct else law)
            for v, g in zip(v0s.tolist(), f.tolist(), strict=True)
        ]
    rtol = None if target < 1e-12 else target
    if law is None:
        truths = [ri.solve(pot, M, v, z).to_dict() for v, z in impacts]
        one = [(pot, M, v, z, rtol) for v, z in impacts]
        prep = ri.prepare(pot, M, rtol=rtol)
        contestants = {
            "oneshot": _loop(lambda p, m, v, z, r: ri.solve(p, m, v, z, rtol=r), one),
            "oneshot_uncached": _loop(
                lambda p, m, v, z, r: ri.solve(p, m, v, z, rtol=r), one, uncached=True
            ),
            "prepared": _loop(prep, impacts),
        }
    else:
        truths = [general_law.solve_law_impact(pot, M, v, lw).to_dict() for v, lw in impacts]
        one = [(pot, M, v, lw, rtol) for v, lw in impacts]
        if distinct:
            preps = [(general_law.prepare_law(pot, M, lw, rtol=rtol), v) for v, lw in impacts]
        else:
            prep = general_law.prepare_law(pot, M, law, rtol=rtol)
            preps = [(prep, v) for v, _ in impacts]
        call = general_law.solve_law_impact
        contestants = {
            "oneshot": _loop(lambda p, m, v, lw, r: call(p, m, v, lw, rtol=r), one),
            "oneshot_uncached": _loop(
                lambda p, m, v, lw, r: call(p, m, v, lw, rtol=r), one, uncached=True
            ),
            "prepared": _loop(lambda pr, v: pr(v), preps),
        }
    peer = _peer_rung(pot, law, impacts, truths, target)
    if peer is not None:
        contestants["sundman"] = _loop(sundman.solve_sundman, peer[3])
    t = _interleaved(contestants, blocks, n)
    line = f"{name:28s} target {target:.0e}: " + ", ".join(f"{k} {v:.1f} us" for k, v in t.items())
    if peer is not None:
        p = t["sundman"]
        line += (
            f" | peer rung {peer[1]:.1e}{peer[4]} (worst {peer[2]:.1e}); ratios peer/ours: oneshot "
            f"{p / t['oneshot']:.2f} (uncached {p / t['oneshot_uncached']:.2f}), "
            f"prepared {p / t['prepared']:.2f}"
        )
    line += f"; cached/uncached one-shot {t['oneshot_uncached'] / t['oneshot']:.2f}x"
    print(line, flush=True)
    return t


# The general laws' rows: a linear dashpot and Hunt-Crossley at about e = 0.8 at 1 m/s
# (HC: e ~ 1 - 2 alpha v0 / 3).
DASHPOT = {"law": "linear", "c": 30.0}
HUNT_CROSSLEY = {"law": "hunt-crossley", "alpha": 0.3}


def run(blocks: int = 7, impacts: int = 200) -> None:
    """Print each row's times and ratios (universal Hertz and p = 2; Hertz with a dashpot
    and Hunt-Crossley, one law for all impacts and a new law each)."""
    print(f"load before {os.getloadavg()[0]:.2f}", flush=True)
    rows = (
        ("universal Hertz", PowerLaw(K, 1.5), None, False),
        ("universal p = 2", PowerLaw(K, 2.0), None, False),
        ("Hertz + linear dashpot", PowerLaw(K, 1.5), DASHPOT, False),
        ("Hertz + dashpot, new law each", PowerLaw(K, 1.5), DASHPOT, True),
        ("Hertz + Hunt-Crossley", PowerLaw(K, 1.5), HUNT_CROSSLEY, False),
        ("Hertz + HC, new law each", PowerLaw(K, 1.5), HUNT_CROSSLEY, True),
    )
    for target in TARGETS:
        for name, pot, law, distinct in rows:
            _row(name, pot, law, blocks, impacts, target, distinct=distinct)
    print(f"load after {os.getloadavg()[0]:.2f}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=7)
    ap.add_argument("--impacts", type=int, default=200)
    a = ap.parse_args(argv)
    run(a.blocks, a.impacts)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
