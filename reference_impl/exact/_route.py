"""The one place where an exact solve chooses its strategy from the damping law (issue 37).

`route` asks the law's registry entry (`reference_impl.theory.laws.LawFamily.route`)
how it is solved exactly; `solve_impact`, `solve_impacts` and `prepare`
(`reference_impl.exact.api` names them `solve`, `solve_batch`, `prepare`) call it and,
for the laws the harmonic map does not solve, hand the law to the strategy it names
here (`solve_other`, `batch_other`, `prepare_other`):

- "harmonic map": the exact quadrature at the law's zeta (`reference_impl.exact.solve`);
- "general": `reference_impl.exact.general_law` (closed form on the linear oscillator,
  the Taylor kernel on sums of powers, the extrapolation elsewhere; ~1e-14);
- "generic": `reference_impl.exact._generic_law` (any C(q, q'); scipy, bound ~1e-8).

The general-law solver is imported where a law needs it, so a universal-law solve does not load its kernels.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

import reference_impl.exact._generic_law as _generic_law
from reference_impl.errors import HCVInputError
from reference_impl.exact._oneshot_cache import cached_law
from reference_impl.theory.laws import DampingLaw

__all__ = ["Route", "batch_other", "prepare_other", "route", "solve_other"]


class Route(NamedTuple):
    """The strategy of a solve: ``kind`` (one of `reference_impl.theory.laws.ROUTES`), the
    universal law's ``zeta`` (harmonic map), the law (None when none was given)."""

    kind: str
    zeta: object
    law: DampingLaw | None


def route(law, zeta, what: str = "zeta") -> Route:
    """The strategy for ``law`` (a `DampingLaw`, a table or None) and ``zeta``.

    Parameters
    ----------
    law : DampingLaw, dict or None
        The damping law; None: the universal law at ``zeta``.
    zeta : float or array_like
        Damping ratio(s) of the universal law given beside it (must be 0 with a law).
    what : str
        The name of ``zeta`` in the caller's signature, for the message.

    Raises
    ------
    HCVInputError
        An unknown law or parameter (one line naming it), or the damping given twice.
    """
    if law is None:
        return Route("harmonic map", zeta, None)
    # Read once per exact table (`_oneshot_cache`): a one-shot call in a loop reads it once.
    dl = cached_law(law)
    # A plain 0 (the default) without numpy: np.asarray on a scalar is ~4 us of a one-shot call.
    if not ((type(zeta) is float or type(zeta) is int) and zeta == 0) and np.any(
        np.asarray(zeta, dtype=float) != 0
    ):
        if what == "zeta":
            raise HCVInputError(
                f"give the damping once: zeta = {zeta!r} and law = {dl.to_dict()} both set"
            )
        raise HCVInputError(f"give the damping once: {what} and law = {dl.to_dict()} both set")
    hz = dl.harmonic_zeta
    if hz is not None:
        return Route("harmonic map", hz, dl)
    return Route(dl.route, 0.0, dl)


def _solvers(kind: str):
    """The solver modules of a route that is not the harmonic map, imported on first use
    (so that a universal-law solve does not load the general-law kernels; `_generic_law`
    is light: it loads scipy only when it runs): ``(general_law, _law_batch)`` for the
    general-law solver, else ``(_generic_law, _generic_law)``."""
    got = _SOLVERS.get(kind)
    if got is not None:  # the import statements below cost ~0.5 us a call
        return got
    if kind == "general":
        import reference_impl.exact._law_batch as law_batch
        import reference_impl.exact.general_law as general_law

        got = general_law, law_batch
    else:
        got = _generic_law, _generic_law
    _SOLVERS[kind] = got
    return got


_SOLVERS: dict = {}


def _no_rtol_for_generic(r: Route, rtol) -> None:
    """Refuse an ``rtol`` for the generic route: its bound is an estimate from two scipy
    tolerances (~1e-8), which no rtol tightens or trades (one line naming it)."""
    if rtol is not None:
        raise HCVInputError(
            f"rtol = {rtol!r} does not apply to damping law {r.law.to_dict()} (route "
            f"{r.kind!r}: scipy at fixed tolerances, an estimated bound ~1e-8); leave rtol unset"
        )


def solve_other(r: Route, potential, m: float, v0: float, rtol=None):
    """One impact of a law the harmonic map does not solve (`LawImpactSolution`); ``rtol``
    as `reference_impl.exact._rtol` (None: full accuracy)."""
    one, _ = _solvers(r.kind)
    if r.kind == "general":
        return one.solve_law_impact(potential, m, v0, r.law, rtol=rtol)
    _no_rtol_for_generic(r, rtol)
    return one.solve_generic_law(potential, m, v0, r.law)


def batch_other(
    r: Route, potential, m: float, v0s, batch_max: int, rtol=None
) -> dict[str, np.ndarray]:
    """Many speeds of such a law: arrays of the `LawImpactSolution` fields
    (`reference_impl.exact._law_batch.LAW_FIELDS`)."""
    _, many = _solvers(r.kind)
    if r.kind == "general":
        # Every core: the compiled integrations in a prange loop (`_law_batch`).
        return many.solve_law_batch(potential, m, v0s, r.law, batch_max, rtol=rtol)
    _no_rtol_for_generic(r, rtol)
    return many.solve_generic_batch(potential, m, v0s, r.law, batch_max)


def prepare_other(r: Route, potential, m: float, rtol=None):
    """A solver ``(v0) -> LawImpactSolution`` of such a law, checked once."""
    one, _ = _solvers(r.kind)
    if r.kind == "general":
        return one.prepare_law(potential, m, r.law, rtol=rtol)
    _no_rtol_for_generic(r, rtol)
    return one.PreparedGeneric(potential, m, r.law)
