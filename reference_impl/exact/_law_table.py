"""A damping law's table read without the generic layers, where nothing can be refused (issue 38).

A one-shot `general_law.solve_law_impact` with a new law on every call reads the table
into its `DampingLaw` each time: `law_from_dict` and the law's ``__post_init__`` (the name
looked up twice, the keys compared, every value checked by `Param.clean`, the
decomposition) were ~6 us of a ~45 us call (measured 2026-11-29, Hertz with a linear
dashpot at rtol 1e-8). `fast_law` reads the common table, a registered family with the
registry's own checks (`LawFamily.clean` not overridden) and scalar parameters, every value
a Python float within its range, into the same `DampingLaw` (equal, the same cleaned
parameters in the declared order, the same decomposition). Anything else, and every value
the checks would refuse, returns None: the caller then asks `law_from_dict`, which builds
the law or refuses it in its one line, so a refusal is never phrased here.
"""

from __future__ import annotations

import math

from reference_impl.theory.laws import DampingLaw
from reference_impl.theory.laws._registry import LAWS, LawFamily

__all__ = ["fast_law"]

_DEFAULT_CLEAN = LawFamily.clean.__func__
_NEW = object.__new__
_finite = math.isfinite


def fast_law(table) -> DampingLaw | None:
    """The `DampingLaw` that ``law_from_dict(table)`` returns, or None where it must be asked.

    Parameters
    ----------
    table : object
        A ``[damping]`` table ``{"law": name, key: value, ...}`` (anything else: None).

    Returns
    -------
    DampingLaw or None
        None unless ``table`` is a dict naming a registered family whose checks are the
        registry's (`Param.clean` of each parameter, no coefficient lists), with exactly
        its keys besides ``"law"``, each value a Python float, finite and within the
        parameter's [low, high], and whose decomposition exists (route "general" or
        "harmonic map").
    """
    if type(table) is not dict:
        return None
    name = table.get("law")
    fam = LAWS._classes.get(name) if type(name) is str else None
    if fam is None or fam.clean.__func__ is not _DEFAULT_CLEAN:
        return None
    declared = fam.params
    if len(table) != len(declared) + 1:
        return None
    params = {}
    for p in declared:
        v = table.get(p.key)
        # Param.clean's checks (`_registry._number`) pass: a float (float(v) is v itself),
        # finite, in range.
        if type(v) is not float or p.coefficients or not (_finite(v) and p.low <= v <= p.high):
            return None
        params[p.key] = v
    d = fam.decompose(params)
    if d is None:
        return None
    # DampingLaw's __post_init__ would store these two (after the checks above); its
    # fields are the name and the parameters (test_general_law_fast compares the laws).
    law = _NEW(DampingLaw)
    law.__dict__.update(name=name, params=params, _decomposition=d)
    return law
