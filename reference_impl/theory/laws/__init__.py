"""Damping laws C(q, q') of a normal contact, m q'' + C q' + U'(q) = 0 (issues 18, 37).

One registry of laws (`LAWS`, `register_law`), the same names and parameters in scenes
(``[damping] law = ...``), in `reference_impl.exact.api.solve` (``law=``) and in the
adapter protocol's ``implemented_law.damping``. Each law is a `LawFamily` subclass in a
module of this package; its table of names, parameters, units and formulas is generated
from the registry into ``docs/scenes.md`` and ``docs/adapter-protocol.md``
(`reference_impl.theory.laws._docs`). Every parameter is validated here (one line naming
the value, `HCVInputError`); an unknown law name is refused in one line naming it.
"""

from __future__ import annotations

# The built-in laws register on import, in the order of the docs table and of every
# "choose one of" message (registration order), so the order of these lines is kept.
# isort: off
from reference_impl.theory.laws import none, universal  # noqa: F401
from reference_impl.theory.laws import linear, power, polynomial  # noqa: F401
from reference_impl.theory.laws import viscoelastic, hunt_crossley  # noqa: F401

# isort: on
from reference_impl.theory.laws._registry import (
    LAWS,
    ROUTES,
    Decomposition,
    LawFamily,
    Param,
    law_family,
    register_law,
    unregister_law,
)
from reference_impl.theory.laws._value import DampingLaw, law_C, law_from_dict
from reference_impl.theory.laws.polynomial import MAX_POLY_TERMS
from reference_impl.theory.laws.power import MAX_EXPONENT

__all__ = [
    "LAWS",
    "MAX_EXPONENT",
    "MAX_POLY_TERMS",
    "ROUTES",
    "DampingLaw",
    "Decomposition",
    "LawFamily",
    "Param",
    "is_harmonic",
    "law_C",
    "law_family",
    "law_from_dict",
    "register_law",
    "unregister_law",
]


def is_harmonic(name: str) -> bool:
    """Whether the law ``name`` is solved by the harmonic map (the universal law at a
    zeta of its parameters: ``none``, ``universal``); unknown names are refused."""
    return law_family(name).route == "harmonic map"
