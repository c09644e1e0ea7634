"""The exact solver's one entry point: `solve`, its batch form `solve_batch` and its
prepared form `prepare` (issue 37, item 2).

Each takes a potential, a mass, the speed(s), and the damping as ``zeta`` (the universal
law) or ``law=`` (any registered law, `reference_impl.theory.laws`); the strategy is
chosen in one place, from the law's registry entry (`reference_impl.exact._route`):

- the harmonic map (universal law, none): the exact quadrature, `ImpactSolution`
  (error <= `reference_impl.exact.solve.RTOL_STATED` of each time);
- a law of the general form C(q) = sum c q^e + alpha U' + A U'' (+ universal part):
  `reference_impl.exact.general_law` (~1e-14, bounded), `LawImpactSolution`;
- any other C(q, q'): the generic route `reference_impl.exact._generic_law` (an
  estimated bound ~1e-8), `LawImpactSolution`.

Each also takes ``rtol`` (None, the default: full accuracy, bit for bit): a relative error
bound asked of each time, which a power law's quadrature (fewer Gauss-Jacobi nodes) and the
general-law Taylor kernel (longer steps) trade for time, the bound still reported
(`reference_impl.exact._rtol`).

The older names are the same functions: `solve_impact` is `solve`, `solve_impacts` is
`solve_batch`, and `reference_impl.exact.prepared.prepare` is `prepare`;
`solve_law_impact` / `prepare_law` call the general-law strategy directly (which also
integrates the universal law, for cross-checks).
"""

from __future__ import annotations

from reference_impl.exact.batch import solve_impacts
from reference_impl.exact.prepared import prepare
from reference_impl.exact.solve import solve_impact

__all__ = ["prepare", "solve", "solve_batch"]

# One function each, under the entry point's names (the old names stay theirs, bit for
# bit the same calls).
solve = solve_impact
solve_batch = solve_impacts
