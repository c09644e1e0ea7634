"""The registry of damping laws: ``[damping] law = NAME`` -> its `LawFamily` (issue 37).

A damping law describes itself on its class, as a potential family does
(`reference_impl.potentials._families`): its name, its parameters with units and ranges,
its strength (the one parameter a restitution solves), how it is solved exactly
(`route`), its decomposition for the compiled kernels, its docs row. The scene parser,
the exact solvers, the bench, the adapters, the CLI and the docs table read it from here.
A new law is one module whose class is decorated with `register_law` and imported by
``reference_impl/theory/laws/__init__.py`` (or by the user's own code before a scene
names it); "Adding a damping law" in ``docs/contributing.md`` walks through it.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from reference_impl.errors import HCVInputError

__all__ = [
    "LAWS",
    "ROUTES",
    "Decomposition",
    "LawFamily",
    "Param",
    "law_family",
    "register_law",
    "unregister_law",
]

# How a law is solved exactly (`LawFamily.route`):
# - "harmonic map": C is the universal law's for every parameter value (Theorem 3): the
#   exact quadrature of `reference_impl.exact.solve` at the law's zeta (`harmonic_zeta`);
# - "general": C(q) = sum c_j q^e_j + alpha U' + A U'' + zeta's universal part
#   (`decompose`), solved by `reference_impl.exact.general_law` (closed form on the linear
#   oscillator, the Taylor kernel on sums of powers, the extrapolation elsewhere, ~1e-14);
# - "generic": any C(q, q') (`C`), integrated by `reference_impl.exact._generic_law`
#   (scipy's DOP853 twice, its error estimated from the two; slower, bound ~1e-8).
ROUTES = ("harmonic map", "general", "generic")


@dataclass(frozen=True)
class Param:
    """One parameter of a law.

    Parameters
    ----------
    key : str
        Its name in a ``[damping]`` table.
    unit : str
        Its SI unit as the docs print it ("-" for a number).
    low, high : float
        Its closed range.
    coefficients : bool
        A list of 1 to ``max_len`` numbers (each in [low, high]) instead of one number.
    max_len : int
        Longest list accepted (coefficients only).
    """

    key: str
    unit: str
    low: float = 0.0
    high: float = math.inf
    coefficients: bool = False
    max_len: int = 1

    def clean(self, law: str, value) -> float | tuple[float, ...]:
        """``value`` checked and as floats; one line naming it when it is out of range."""
        if not self.coefficients:
            return _number(law, self.key, value, self.unit, self.low, self.high)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            value = [value]
        if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= self.max_len:
            raise HCVInputError(
                f"damping law {law!r}: {self.key} must be a list of 1 to {self.max_len} "
                f"coefficients [c0, c1, ...], got {value!r}"
            )
        return tuple(
            _number(law, f"{self.key}[{i}]", v, self.unit, self.low, self.high)
            for i, v in enumerate(value)
        )


def _number(law: str, key: str, value, unit: str, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise HCVInputError(
            f"damping law {law!r}: {key} must be a real number [{unit}], got {value!r}"
        )
    v = float(value)
    if not math.isfinite(v) or not low <= v <= high:
        raise HCVInputError(
            f"damping law {law!r}: {key} = {value!r} is outside [{low:g}, {high:g}] [{unit}]"
        )
    return v


class Decomposition(NamedTuple):
    """C(q) = sum c_j q^e_j + alpha U'(q) + A U''(q) + 2 zeta sqrt(m) U'(q) / sqrt(2 U(q)).

    What the general-law kernels read (`reference_impl.exact.general_law._law_arrays`).
    ``never_pulls``: the total force U' + C q' provably never vanishes before q = 0
    (Hunt-Crossley's U' (1 + alpha q')), so no zero-force event is searched.
    """

    terms: tuple[tuple[float, float], ...] = ()  # (c_j [N s m^-(1+e_j)], e_j)
    alpha: float = 0.0  # s/m
    A: float = 0.0  # s
    zeta: float = 0.0  # -
    never_pulls: bool = False


class LawFamily:
    """A damping law C(q, q') of m q'' + C q' + U'(q) = 0: the numbered contract.

    1. ``name``: the law's name in scenes, ``law=`` and the adapter protocol.
    2. ``params``: its `Param` s (key, unit, range), in the order the docs list them.
    3. ``formula``: C in words for the docs row (kg/s); ``note``: what else the row says.
    4. ``strength``: the key a restitution asked at a speed solves (None: no strength);
       ``shape_scaled``: the strength is a factor on the given values (a polynomial).
    5. ``route``: how it is solved exactly, one of `ROUTES`; ``harmonic_zeta(params)``
       for "harmonic map", ``decompose(params)`` for "general", ``C(...)`` for every
       law (the generic form the "generic" route and the Verlet reference evaluate).
    6. ``example(c_ref, q_ref, K, m, u)``: parameters of typical strength, for the tests.

    Subclass, set the class attributes, override what differs, decorate with
    `register_law`. Laws are classes, not instances: a `DampingLaw` is the law with
    its parameters.
    """

    name: ClassVar[str] = ""
    params: ClassVar[tuple[Param, ...]] = ()
    formula: ClassVar[str] = ""
    note: ClassVar[str] = ""
    strength: ClassVar[str | None] = None
    shape_scaled: ClassVar[bool] = False
    route: ClassVar[str] = "general"

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The parameter keys, in order (formed once per class: asked on every law value)."""
        keys = cls.__dict__.get("_keys")
        if keys is None or keys[0] is not cls.params:
            keys = (cls.params, tuple(p.key for p in cls.params))
            cls._keys = keys
        return keys[1]

    @classmethod
    def clean(cls, params: dict) -> dict[str, Any]:
        """The parameters checked (`Param.clean`) and in the declared order; override to
        add checks between them."""
        return {p.key: p.clean(cls.name, params[p.key]) for p in cls.params}

    @classmethod
    def harmonic_zeta(cls, params: dict) -> float | None:
        """The universal law's zeta this law is for every potential, else None."""
        return None

    @classmethod
    def decompose(cls, params: dict) -> Decomposition | None:
        """C(q) in the kernels' terms (route "general" and "harmonic map"); None: C is
        not of that form (route "generic")."""
        return None

    @classmethod
    def C(cls, params: dict, pot, m: float, q, qdot, ns=np):
        """C(q, q') in kg/s on arrays (or mpmath numbers with ``ns=mpmath``), q > 0.

        The default evaluates the decomposition (q' unused); a "generic" law overrides it.
        """
        d = cls.decompose(params)
        if d is None:
            raise NotImplementedError(f"damping law {cls.name!r} defines neither C nor decompose")
        c = 0 * q
        for cj, ej in d.terms:
            c = c + cj * (q**ej if ej != 0 else 1)
        if d.alpha:
            c = c + d.alpha * pot._dU(q)
        if d.A:
            c = c + d.A * pot._d2U(q)
        if d.zeta:
            c = c + 2 * d.zeta * ns.sqrt(m) * pot._dU(q) / ns.sqrt(2 * pot._U(q))
        return c

    @classmethod
    def with_strength(cls, params: dict, s: float) -> dict:
        """The parameters at strength ``s`` (a shape-scaled law: its values times s)."""
        if cls.strength is None:
            raise HCVInputError(f"damping law {cls.name!r} has no strength")
        out = dict(params)
        key = cls.strength
        out[key] = tuple(s * c for c in params[key]) if cls.shape_scaled else float(s)
        return out

    @classmethod
    def strength_unit(cls, params: dict) -> str:
        """The strength's unit (a power law's depends on its exponent)."""
        return next(p.unit for p in cls.params if p.key == cls.strength)

    @classmethod
    def example(cls, c_ref: float, q_ref: float, K: float, m: float, u: tuple[float, ...]) -> dict:
        """Parameters with C ~ ``c_ref`` kg/s at overlap ``q_ref`` (m) for a mass ``m``
        (kg) on a contact of secant stiffness ``K`` (N/m); ``u``: four numbers in [0, 1)
        choosing a shape. The default: the strength at which C(q_ref, 0) on the spring
        U' = K q is c_ref, from the law at strength 1 (other parameters at their lower
        bound)."""
        if cls.strength is None:
            return {}
        base = {p.key: (p.low,) if p.coefficients else p.low for p in cls.params}
        unit = cls.clean(cls.with_strength(base, 1.0))
        c1 = float(np.asarray(cls.C(unit, _Spring(K), m, np.array([q_ref]), 0.0))[0])
        return cls.with_strength(unit, c_ref / c1)

    @classmethod
    def docs_row(cls) -> tuple[str, str, str, str]:
        """(law, parameters, C(q) [kg/s], how it is solved) cells of the docs table."""
        ps = ", ".join(
            f"`{p.key}` [{p.unit}]"
            + (f" (≥ {p.low:g})" if math.isinf(p.high) else f" ({p.low:g} to {p.high:g})")
            + (f", 1 to {p.max_len} values" if p.coefficients else "")
            for p in cls.params
        )
        formula = cls.formula + (f" ({cls.note})" if cls.note else "")
        how = {
            "harmonic map": "exact quadrature (harmonic map)",
            "general": "general-law solver (~1e-14)",
            "generic": "generic path (scipy DOP853, estimated bound)",
        }[cls.route]
        if cls.strength is not None:
            how += f"; strength `{cls.strength}`"
        return f"`{cls.name}`", ps, formula, how


class _Spring:
    """U = K q^2 / 2: the contact a law's default `LawFamily.example` is scaled on."""

    def __init__(self, K: float):
        self.K = K

    def _U(self, q):
        return 0.5 * self.K * q * q

    def _dU(self, q):
        return self.K * q

    def _d2U(self, q):
        return self.K + 0 * q


class _Laws(Mapping):
    """name -> `LawFamily` subclass, in registration order."""

    def __init__(self) -> None:
        self._classes: dict[str, type[LawFamily]] = {}

    def __getitem__(self, name: str) -> type[LawFamily]:
        return self._classes[name]

    def __contains__(self, name) -> bool:
        return name in self._classes

    def get(self, name, default=None):
        return self._classes.get(name, default)

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._classes))

    def __len__(self) -> int:
        return len(self._classes)

    def __repr__(self) -> str:
        return f"LAWS({', '.join(self._classes)})"


LAWS = _Laws()


def law_family(name) -> type[LawFamily]:
    """The registered law ``name``; one line naming it (and the near name) when unknown."""
    fam = LAWS._classes.get(name) if isinstance(name, str) else None
    if fam is not None:
        return fam
    near = (
        difflib.get_close_matches(name.replace("_", "-"), list(LAWS), n=1, cutoff=0.75)
        if isinstance(name, str)
        else []
    )
    hint = f" (did you mean {near[0]!r}?)" if near else ""
    raise HCVInputError(f"unknown damping law {name!r}; choose one of {', '.join(LAWS)}{hint}")


def register_law(cls: type[LawFamily]) -> type[LawFamily]:
    """Class decorator: make ``cls`` the damping law ``cls.name``.

    Raises
    ------
    HCVInputError
        ``cls`` is not a LawFamily subclass, names no law, declares an unknown route or a
        strength that is not one of its parameters, or takes a name already registered.
    """
    if not (isinstance(cls, type) and issubclass(cls, LawFamily)):
        raise HCVInputError(f"register_law: {cls!r} is not a LawFamily subclass")
    name = cls.name
    if not (isinstance(name, str) and name.strip() and name == name.strip()):
        raise HCVInputError(f"register_law: {cls.__name__}.name must name the law, got {name!r}")
    if cls.route not in ROUTES:
        raise HCVInputError(
            f"register_law: {cls.__name__}.route = {cls.route!r} is not one of {ROUTES}"
        )
    keys = [p.key for p in cls.params]
    if "law" in keys or len(set(keys)) != len(keys):
        raise HCVInputError(f"register_law: {cls.__name__}.params repeat a key or use 'law'")
    if cls.strength is not None and cls.strength not in keys:
        raise HCVInputError(
            f"register_law: {cls.__name__}.strength = {cls.strength!r} is not a parameter"
        )
    have = LAWS._classes.get(name)
    if have is not None and have is not cls:
        raise HCVInputError(
            f"register_law: law {name!r} is already {have.__module__}.{have.__qualname__}"
        )
    LAWS._classes[name] = cls
    return cls


def unregister_law(name: str) -> None:
    """Remove a law (for tests that define one)."""
    LAWS._classes.pop(name, None)
