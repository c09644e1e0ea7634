"""Damping laws C(q, q') of a normal contact, m q'' + C q' + U'(q) = 0 (issues 18, 37).

One registry of laws (`LAWS`, `register_law`), the same names and parameters in scenes
(``[damping] law = ...``), in `reference_impl.exact.api.solve` (``law=``) and in the
adapter protocol's ``implemented_law.damping``. Each law is a `LawFamily` subclass in a
module of this package (every public module here is imported, so a new law is one
module); its table of names, parameters, units and formulas is generated from the
registry into ``docs/scenes.md`` and ``docs/adapter-protocol.md`` when the site is built
(`reference_impl.theory.laws.docs_table`). Every parameter is validated here (one line
naming the value, `HCVInputError`); an unknown law name is refused in one line naming it.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys

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


# Modules of this package that hold no law (every other public module is one).
_NOT_LAWS = frozenset({"docs_table"})


def _import_law_modules() -> tuple[str, ...]:
    """Import every public module of this package not imported above (a law added
    later), in name order after the built-in ones, so that a new law is one module and
    no line here (issue 37's change exercise). Returns their names."""
    found = []
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if info.name.startswith("_") or info.name in _NOT_LAWS or info.ispkg:
            continue
        if f"{__name__}.{info.name}" not in sys.modules:
            importlib.import_module(f"{__name__}.{info.name}")
            found.append(info.name)
    return tuple(found)


_import_law_modules()


def is_harmonic(name: str) -> bool:
    """Whether the law ``name`` is solved by the harmonic map (the universal law at a
    zeta of its parameters: ``none``, ``universal``); unknown names are refused."""
    return law_family(name).route == "harmonic map"
