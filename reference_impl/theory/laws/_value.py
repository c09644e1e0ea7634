"""A damping law with its parameters (`DampingLaw`), read from a ``[damping]`` table.

The law's family (`reference_impl.theory.laws._registry.LAWS`) answers every question
about it; this value only holds the name and the checked parameters and asks the family.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.theory.laws._registry import LAWS, Decomposition, LawFamily, law_family

__all__ = ["DampingLaw", "law_C", "law_from_dict"]

_NO_TERMS = Decomposition()


@dataclass(frozen=True)
class DampingLaw:
    """One registered damping law with its parameters (validated on construction).

    Parameters
    ----------
    name : str
        A registered law (`reference_impl.theory.laws.LAWS`).
    params : dict
        Its parameters in SI units (the docs table, ``docs/scenes.md``); ``polynomial``
        takes ``c`` as a sequence of coefficients c0, c1, ... (each >= 0).
    """

    name: str
    params: dict = field(default_factory=dict)

    def __post_init__(self):
        fam = law_family(self.name)
        if not isinstance(self.params, dict):
            raise HCVInputError(f"damping law parameters must be a table, got {self.params!r}")
        want = fam.keys()
        if len(self.params) != len(want) or not all(k in self.params for k in want):
            extra = sorted(set(self.params).difference(want))
            if extra:
                raise HCVInputError(
                    f"damping law {self.name!r} takes {', '.join(want) or 'no parameters'}; "
                    f"got unknown {extra[0]!r}"
                )
            missing = [k for k in want if k not in self.params]
            raise HCVInputError(f"damping law {self.name!r} needs {missing[0]!r}")
        params = fam.clean(self.params)
        object.__setattr__(self, "params", params)
        # Asked several times per solve (the kernels' arrays, the creep test, the linear
        # case): formed once per law value, which is frozen. Not a field (eq, repr).
        d = fam.decompose(params)
        object.__setattr__(self, "_decomposition", _NO_TERMS if d is None else d)

    @property
    def family(self) -> type[LawFamily]:
        """The registered law (`LawFamily` subclass)."""
        return LAWS[self.name]

    @property
    def route(self) -> str:
        """How it is solved exactly: "harmonic map", "general" or "generic" (`ROUTES`)."""
        return self.family.route

    @property
    def harmonic_zeta(self) -> float | None:
        """The universal law's zeta when the harmonic map solves this law, else None."""
        return self.family.harmonic_zeta(self.params) if self.route == "harmonic map" else None

    def decomposition(self) -> Decomposition:
        """C(q) in the kernels' terms (empty for a "generic" law)."""
        return self._decomposition

    # -- the decomposition's parts, as the solvers read them --------------------------
    def terms(self) -> tuple[tuple[float, float], ...]:
        """(c_j, e_j) of the part sum c_j q^e_j of C(q)."""
        return self._decomposition.terms

    @property
    def alpha(self) -> float:
        """Coefficient of U'(q) in C(q), s/m."""
        return self._decomposition.alpha

    @property
    def A(self) -> float:
        """Coefficient of U''(q) in C(q), s."""
        return self._decomposition.A

    @property
    def zeta(self) -> float:
        """Damping ratio of the universal part of C(q)."""
        return self._decomposition.zeta

    def is_zero(self) -> bool:
        """True when C = 0 identically (a generic law: when it says so, `LawFamily`)."""
        if self.route == "generic":
            return bool(getattr(self.family, "is_zero", lambda p: False)(self.params))
        d = self.decomposition()
        return not d.terms and d.alpha == 0 and d.A == 0 and d.zeta == 0

    def with_strength(self, s: float) -> DampingLaw:
        """The law at strength ``s`` (`LawFamily.with_strength`)."""
        return DampingLaw(self.name, self.family.with_strength(self.params, s))

    def to_dict(self) -> dict[str, Any]:
        """The law as a ``[damping]`` table (JSON-safe)."""
        out: dict[str, Any] = {"law": self.name}
        for k, v in self.params.items():
            out[k] = list(v) if isinstance(v, tuple) else v
        return out


def law_from_dict(table: dict, *, where: str = "damping") -> DampingLaw:
    """A `DampingLaw` from a table ``{"law": name, **params}`` (scene or protocol form)."""
    if isinstance(table, DampingLaw):
        return table
    if not isinstance(table, dict):
        raise HCVInputError(f"{where} must be a table with a 'law' key, got {table!r}")
    name = table.get("law", "none")
    if not isinstance(name, str):
        raise HCVInputError(f"{where}.law must be a string, got {name!r}")
    params = {k: v for k, v in table.items() if k != "law"}
    fam = LAWS.get(name)
    want = fam.keys() if fam is not None else None
    extra = sorted(set(params) - set(want)) if want is not None else []
    if extra:
        # Named by its full path ('implemented_law.damping.c'), as every scene and protocol
        # error names the offending key.
        raise HCVInputError(
            f"unknown key '{where}.{extra[0]}' for damping law {name!r} "
            f"(it takes {', '.join(want) or 'no parameters'})"
        )
    try:
        return DampingLaw(name, params)
    except HCVInputError as exc:
        raise HCVInputError(f"{where}: {exc}") from None


def law_C(law: DampingLaw, pot, m: float, q, ns=np, qdot=None):
    """C(q, q') in kg/s on an array (or an mpmath number with ``ns=mpmath``), q > 0;
    ``qdot`` (m/s) is read by a "generic" law only, which needs it.

    Raises
    ------
    UnsupportedError
        A "generic" law asked without ``qdot`` (a caller that evaluates C(q) alone, e.g.
        the reference Verlet's damping, cannot run it).
    """
    if qdot is None and law.route == "generic":
        raise UnsupportedError(
            f"damping law {law.name!r} depends on the speed q' (C(q, q')): asked for C(q) "
            "alone, which it does not define"
        )
    return law.family.C(law.params, pot, m, q, qdot, ns)
