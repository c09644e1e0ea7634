"""The Taylor general-law kernel against the GBS kernel and the compiled DOP853 (issue 27, goal 3).

One row per damping law of the study (Hertz, `reference_impl.studies.laws.calibrated_laws`,
v0 = 1 m/s), each scored against its 30-digit truth (`solve_law_impact_mp`) over every
output (both ends, q_max, U'(q_max), the peak force, the time of q_max). Contestants,
timed interleaved in one process (CPU time, median of the blocks, as
`benchmarks.bench_exact`):

* ``old``: `solve_law_impact` as on main (the GBS kernel `_general_kernel.solve`);
* ``new``: the same call with its compiled kernel switched to `_general_taylor.solve`
  (the one-line change this module measures; `general_law` itself is not edited here);
* ``old_k`` / ``new_k``: the two kernels alone (the compiled call, no Python around it);
* ``new_lean``: the prepared call (`general_law.prepare_law`: the per-law planning done
  once and kept), checked to return the same solution;
* ``peer``: the numba DOP853 of `benchmarks.peer_dop853` at the cheapest rung of its
  tolerance ladder whose largest error is <= max(new's, 1e-14) ("equal error").

Run: ``python -m benchmarks.bench_general_taylor [--blocks N] [--json FILE]`` (~1 minute).
"""

from __future__ import annotations

import argparse
import sys
import types

import numpy as np

from reference_impl.exact import general_law as _gl
from reference_impl.exact._general_kernel import solve as _old_kernel
from reference_impl.exact._general_law_mp import solve_law_impact_mp
from reference_impl.exact._general_taylor import solve as _new_kernel
from reference_impl.exact._validate import _validated_top
from reference_impl.studies.laws import calibrated_laws, hertz
from reference_impl.theory.laws import law_from_dict

from ._machine import machine_info
from ._record import write_json
from .bench_exact import (
    _LAW_KEYS,
    EQUAL_ERROR_FLOOR,
    GOAL_RATIO_LAW,
    LAW_V0,
    TRUTH_DPS,
    _interleaved,
    _load,
    _peer_case,
    _peer_ladder,
    _rel,
)

__all__ = ["run", "main"]

_KEYS = (*_LAW_KEYS, "max_force", "time_of_max_penetration")


def _with_kernel(fn):
    """`solve_law_impact` with the name ``_compiled_solve`` bound to ``fn``: the same code
    objects (`solve_law_impact` and the `_solve_planned` it calls) in a copy of their
    module's namespace (what the one-line import change gives)."""
    ns = dict(vars(_gl))
    ns["_compiled_solve"] = fn
    # the call runs the Taylor kernel and its fields in one compiled call (issue 38): the
    # same fields from ``fn``'s row
    ns["_solve_formed"] = lambda v0, q_e, *arrays: _gl._form(fn(v0, q_e, *arrays), v0, q_e)
    for name in ("_solve_planned", "solve_law_impact"):
        f = getattr(_gl, name)
        ns[name] = types.FunctionType(f.__code__, ns, f.__name__, f.__defaults__, f.__closure__)
    return ns["solve_law_impact"]


_SOLVE = {"old": _with_kernel(_old_kernel), "new": _with_kernel(_new_kernel)}
_EPS = float(np.finfo(float).eps)
_PREPARED: dict = {}


def _lean(pot, m, v0, law):
    """`reference_impl.exact.general_law.prepare_law`'s call (the per-(potential, m, law)
    planning done once and kept; bit for bit `solve_law_impact`, tested): the "lean"
    wrapper this benchmark's prototype measured, now the package's."""
    key = (id(pot), m, repr(law))
    prepared = _PREPARED.get(key)
    if prepared is None:
        prepared = _PREPARED[key] = _gl.prepare_law(pot, m, law)
    return prepared(v0)


def _row(name, law, blocks):
    pot, m = hertz()
    v0 = LAW_V0
    truth = solve_law_impact_mp(pot, m, v0, law, dps=TRUTH_DPS)
    sols = {k: f(pot, m, v0, law) for k, f in _SOLVE.items()}
    errs = {k: {key: _rel(getattr(s, key), truth[key]) for key in _KEYS} for k, s in sols.items()}
    worst = {k: max(e.values()) for k, e in errs.items()}
    # the reported bounds, relative, and whether they hold against the truth
    bound_ok = {
        k: bool(
            abs(s.contact_time - float(truth["contact_time"])) <= s.error_time
            and abs(s.restitution - float(truth["restitution"])) <= s.error_restitution
            and abs(s.contact_time_zero_force - float(truth["contact_time_zero_force"]))
            <= s.error_time
            and abs(s.restitution_zero_force - float(truth["restitution_zero_force"]))
            <= s.error_restitution
        )
        for k, s in sols.items()
    }
    lean = _lean(pot, m, v0, law)
    lean_same = all(
        getattr(lean, f) == getattr(sols["new"], f)
        for f in _gl.LawImpactSolution.__dataclass_fields__
    )
    call = _peer_case(pot, m, v0, law)
    pk = _peer_ladder(call, v0, truth, _LAW_KEYS, max(worst["new"], EQUAL_ERROR_FLOOR))
    dl = law_from_dict(law)
    cs, es, sc = _gl._law_arrays(dl, m, pot)
    ks, ps = _gl._power_terms(pot)
    qE = _validated_top(pot, 0.5 * m * v0 * v0)
    kargs = (v0, qE, ks, ps, cs, es, sc)

    old, new = _SOLVE["old"], _SOLVE["new"]
    t = _interleaved(
        {
            "old": lambda: old(pot, m, v0, law),
            "new": lambda: new(pot, m, v0, law),
            "new_lean": lambda: _lean(pot, m, v0, law),
            "old_k": lambda: _old_kernel(*kargs),
            "new_k": lambda: _new_kernel(*kargs),
            "peer": lambda: call(pk["rtol"]),
        },
        blocks,
    )
    us = {k: v * 1e6 for k, v in t.items()}
    return {
        "law": name,
        "damping": law,
        "us": us,
        "max_rel_error": worst,
        "rel_errors": errs,
        "bound_holds": bound_ok,
        "n_steps": {k: s.n_steps for k, s in sols.items()},
        "peer_rtol": pk["rtol"],
        "peer_max_rel_error": pk["max_rel_error"],
        "peer_at_equal_error": pk["at_equal_error"],
        "ratio_new_vs_peer": us["peer"] / us["new"],
        "ratio_new_lean_vs_peer": us["peer"] / us["new_lean"],
        "new_lean_same_solution": bool(lean_same),
        "ratio_old_vs_peer": us["peer"] / us["old"],
        "kernel_speedup": us["old_k"] / us["new_k"],
        "goal_met": bool(us["peer"] / us["new"] >= GOAL_RATIO_LAW and pk["at_equal_error"]),
    }


def run(blocks: int = 7) -> dict:
    load0 = _load()
    rows = [_row(n, law, blocks) for n, law in calibrated_laws().items() if n != "universal"]
    return {
        "rows": rows,
        "truth": f"solve_law_impact_mp, {TRUTH_DPS} digits",
        "timing": f"CPU time, {blocks} interleaved blocks, median",
        "load_average_1min": load0,
        "load_average_1min_after": _load(),
        "machine": machine_info(),
    }


def _print(res: dict) -> None:
    print(f"general laws on Hertz, v0 = {LAW_V0} m/s; truth: {res['truth']}; {res['timing']}")
    print(
        f"{'law':14s} {'old us':>7s} {'new us':>7s} {'old_k':>7s} {'new_k':>7s} {'peer us':>7s}"
        f" {'lean us':>7s} {'err old':>8s} {'err new':>8s} {'peer err':>8s} {'new/peer':>8s} {'old/peer':>8s} {'lean/peer':>9s}"
        f" {'kernel':>7s} steps  bound"
    )
    for r in res["rows"]:
        u = r["us"]
        print(
            f"{r['law']:14s} {u['old']:7.1f} {u['new']:7.1f} {u['old_k']:7.1f} {u['new_k']:7.1f}"
            f" {u['peer']:7.1f} {u['new_lean']:7.1f} {r['max_rel_error']['old']:8.1e} {r['max_rel_error']['new']:8.1e}"
            f" {r['peer_max_rel_error']:8.1e} {r['ratio_new_vs_peer']:7.2f}x"
            f" {r['ratio_old_vs_peer']:7.2f}x {r['ratio_new_lean_vs_peer']:8.2f}x"
            f" {r['kernel_speedup']:6.1f}x"
            f" {r['n_steps']['old']:3d}/{r['n_steps']['new']:<3d}"
            f" {'holds' if r['bound_holds']['new'] else 'BROKEN'}"
            f"{'' if r['peer_at_equal_error'] else ' (peer best)'}"
            f"{'' if r['new_lean_same_solution'] else ' LEAN DIFFERS'}"
        )
    mi = res["machine"]
    lean_met = sum(r["ratio_new_lean_vs_peer"] >= GOAL_RATIO_LAW for r in res["rows"])
    print(
        f"goal >= {GOAL_RATIO_LAW:g}x the peer: new (solve_law_impact as is, Taylor kernel) meets it"
        f" on {sum(r['goal_met'] for r in res['rows'])}/{len(res['rows'])} laws; the prepared"
        f" call (prepare_law) on {lean_met}/{len(res['rows'])}; load "
        f"{res['load_average_1min']} before, {res['load_average_1min_after']} after, "
        f"commit {mi['commit']}"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="also write the result to this JSON file")
    ap.add_argument("--blocks", type=int, default=7, help="interleaved blocks (median; >= 5)")
    args = ap.parse_args(argv)
    if args.blocks < 5:
        print(f"bench_general_taylor: error: --blocks {args.blocks}: at least 5", file=sys.stderr)
        return 2
    res = run(args.blocks)
    _print(res)
    if args.json:
        write_json(
            args.json, res, default=lambda x: x.item() if isinstance(x, np.generic) else str(x)
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
