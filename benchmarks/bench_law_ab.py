"""General laws before and after a change, beside the Sundman peer, in one process (issue 38, goal 4).

The package of another commit (the "before", e.g. main) is loaded beside this checkout's
under the name ``reference_impl_old``, so that both run in the same process, interleaved
block by block with the strongest peer (`benchmarks.peer_sundman` at the cheapest rung of
its ladder whose worst relative error over the set is at most the target,
`benchmarks.bench_oneshot._peer_rung`): on a loaded machine the ratios hold where the
times do not. Rows: Hertz (k = 1e6, m = 0.1) with a linear dashpot and with Hunt-Crossley,
a new law every impact (strength times 10^u, u uniform in [-1, 0]; speeds log-uniform in
[0.05, 5] m/s, as `bench_oneshot`'s "new law each" rows), at 1e-8 (``rtol=1e-8``) and 1e-14
(full accuracy); contestants ``oneshot`` (`solve_law_impact`) and ``prepared``
(`prepare_law`, one per impact, built outside the timing), each before and after. Before
timing, every full-accuracy result of the two packages is compared field by field (they
must be equal) and the differences at the row's rtol are printed. Nothing is recorded.

Make the "before" copy (here of main) and run::

    mkdir -p /tmp/ab && git archive main reference_impl | tar -x -C /tmp/ab
    mv /tmp/ab/reference_impl /tmp/ab/reference_impl_old
    grep -rl reference_impl /tmp/ab/reference_impl_old | \\
        xargs sed -i 's/\\breference_impl\\b/reference_impl_old/g'
    NUMBA_CACHE_DIR=/tmp/ab/numba python -m benchmarks.bench_law_ab --old-root /tmp/ab

(``NUMBA_CACHE_DIR``: both copies then keep their machine code by numba's own rule, per
source file, instead of the package's keyed directory, which each copy would set.)
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import sys

import numpy as np

__all__ = ["main", "run"]

M = 0.1
K = 1e6


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (isinstance(a[k], float) and math.isnan(a[k]) and math.isnan(b[k]))
        for k in a
    )


def run(old_root: str, blocks: int = 7, impacts: int = 200) -> None:
    """Print, per row, the median CPU time per impact and the peer's time over ours."""
    sys.path.insert(0, old_root)
    old = importlib.import_module("reference_impl_old.exact.general_law")
    old_power = importlib.import_module("reference_impl_old").PowerLaw
    from reference_impl import PowerLaw
    from reference_impl.exact import general_law as new

    from . import bench_oneshot as bo
    from . import peer_sundman as sundman

    print(f"load before {os.getloadavg()[0]:.2f}", flush=True)
    for target in (1e-8, 1e-14):
        for name, law in (("dashpot", bo.DASHPOT), ("hunt-crossley", bo.HUNT_CROSSLEY)):
            pot, opot = PowerLaw(K, 1.5), old_power(K, 1.5)
            rng = np.random.default_rng(5)
            v0s = 10.0 ** rng.uniform(np.log10(0.05), np.log10(5.0), impacts)
            f = 10.0 ** rng.uniform(-1.0, 0.0, impacts)
            cases = [(v, bo._scaled(law, g)) for v, g in zip(v0s.tolist(), f.tolist(), strict=True)]
            rtol = None if target < 1e-12 else target
            truths = [new.solve_law_impact(pot, M, v, lw).to_dict() for v, lw in cases]
            differ = 0
            for (v, lw), truth in zip(cases, truths, strict=True):
                if not _same(old.solve_law_impact(opot, M, v, lw).to_dict(), truth):
                    raise SystemExit(f"full accuracy differs before/after: v0 = {v!r}, {lw}")
                a = new.solve_law_impact(pot, M, v, lw, rtol=rtol).to_dict()
                differ += not _same(a, old.solve_law_impact(opot, M, v, lw, rtol=rtol).to_dict())
            new_prep = [(new.prepare_law(pot, M, lw, rtol=rtol), v) for v, lw in cases]
            old_prep = [(old.prepare_law(opot, M, lw, rtol=rtol), v) for v, lw in cases]
            # the loop's values bound as defaults (each set is timed before the next row)
            contestants = {
                "oneshot after": bo._loop(
                    lambda v, lw, c=new.solve_law_impact, p=pot, r=rtol: c(p, M, v, lw, rtol=r),
                    cases,
                ),
                "oneshot before": bo._loop(
                    lambda v, lw, c=old.solve_law_impact, p=opot, r=rtol: c(p, M, v, lw, rtol=r),
                    cases,
                ),
                "prepared after": bo._loop(lambda p, v: p(v), new_prep),
                "prepared before": bo._loop(lambda p, v: p(v), old_prep),
            }
            peer = bo._peer_rung(pot, law, cases, truths, target)
            contestants["sundman"] = bo._loop(sundman.solve_sundman, peer[3])
            t = bo._interleaved(contestants, blocks, impacts)
            p = t.pop("sundman")
            print(
                f"{name:14s} {target:.0e} (rtol {rtol}; {differ} of {impacts} differ at it) "
                f"peer rung {peer[1]:.1e}{peer[4]} (worst {peer[2]:.1e}) {p:.1f} us | "
                + ", ".join(f"{k} {v:.1f} us ({p / v:.2f}x)" for k, v in t.items()),
                flush=True,
            )
    print(f"load after {os.getloadavg()[0]:.2f}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old-root", required=True, help="folder holding reference_impl_old")
    ap.add_argument("--blocks", type=int, default=7)
    ap.add_argument("--impacts", type=int, default=200)
    a = ap.parse_args(argv)
    run(a.old_root, a.blocks, a.impacts)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
