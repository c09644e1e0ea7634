"""Scenes of the exact solver's frozen oracle (`test_exact_frozen.py`).

One case per path through the quadrature loops of `reference_impl.exact`: each
strategy (power law by Gauss-Jacobi, split, fused Gauss-Jacobi and tanh-sinh, the
general path with compiled or numpy node values, its common rows, its rise-only,
negligible-stretch, long-stretch and overdamped rows) and the trajectory's
tanh-sinh sums (`Solution.state`). `python -m verification._exact_frozen_cases`
writes the values of the code checked out to `_exact_frozen.json` (what the test reads).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

__all__ = ["CASES", "DATA_FILE", "key", "outputs"]

DATA_FILE = Path(__file__).with_name("_exact_frozen.json")

# (name, potential builder, m, v0, zetas, levels, trajectory times as fractions of the
# contact time, or None).
_ZETAS = (0.0, 1e-12, 0.2, 0.61, 0.8999, 0.95, 1.0, 1.7)


def _scenes():
    from reference_impl import PowerLaw
    from reference_impl.potentials.saturating import SaturatingForce
    from reference_impl.studies.workprecision import family_scenes

    out = [(sc.name, sc.potential, sc.m, sc.v0) for sc in family_scenes()]
    out.append(("power-law p = 3", PowerLaw(1.0e12, 3.0), 0.01, 4.0))
    # beta = 2/6 - 1 < -0.5: no Gauss-Jacobi rule, tanh-sinh with the closed-form nodes.
    out.append(("power-law p = 5", PowerLaw(1.0e15, 5.0), 0.01, 2.0))
    # No compiled node function: numpy node values.
    out.append(("saturating", SaturatingForce(2.0e3, 1.0e-4), 0.02, 1.5))
    # Sums the fused Gauss-Jacobi rule does not take (exponents 3 and 3.97 share no small
    # substitution order; a higher term above _GJ_RATIO_MAX): the fused tanh-sinh kernel.
    out.append(("sum 1.5 + 2.97", PowerLaw(1e9, 1.5) + PowerLaw(1e10, 2.97), 0.01, 1.0))
    out.append(("sum crossover", PowerLaw(1e6, 1.5) + PowerLaw(1e9, 3.0), 0.01, 3.0))
    # The terms hand over inside the contact (issue 22): the split quadrature.
    out.append(("split sum", PowerLaw(1e-12, 0.01) + PowerLaw(1.0, 20.0), 1.0, 100.0))
    return out


def _cases():
    cases = []
    for name, pot, m, v0 in _scenes():
        for zeta in _ZETAS:
            cases.append((name, pot, m, v0, zeta, None))
        for zeta in (0.0, 0.2, 0.95, 1.7):
            cases.append((name, pot, m, v0, zeta, 5))
    return cases


CASES = _cases()
_TIMES = (0.0, 1e-9, 0.3, 0.5, 0.77, 1.0)


def _fields(sol) -> list[str]:
    vals = []
    for f in dataclasses.fields(sol):
        v = getattr(sol, f.name)
        if isinstance(v, float):
            vals.append(f"{f.name}={float.hex(v)}")
    return vals


def outputs(case) -> list[str]:
    """The frozen strings of one case: every float field of the solution as a hex
    float, then q and dq/dt at a few times (undamped and zeta = 0.2 cases), or
    the error's class and message."""
    from reference_impl import solve_impact

    name, pot, m, v0, zeta, level = case
    try:
        sol = solve_impact(pot, m, v0, zeta, level=level)
    except Exception as exc:  # noqa: BLE001 - the refusal is what is frozen
        return [f"{type(exc).__name__}: {exc}"]
    vals = _fields(sol)
    if level is None and zeta in (0.0, 0.2):
        t = np.array(_TIMES) * sol.contact_time
        q, dq = sol.state(t)
        vals += [f"q={float.hex(float(a))}" for a in q]
        vals += [f"dq={float.hex(float(a))}" for a in dq]
    return vals


def key(case) -> str:
    name, _, m, v0, zeta, level = case
    return f"{name} m={m!r} v0={v0!r} zeta={zeta!r} level={level!r}"


if __name__ == "__main__":
    DATA_FILE.write_text(json.dumps({key(c): outputs(c) for c in CASES}, indent=1) + "\n")
