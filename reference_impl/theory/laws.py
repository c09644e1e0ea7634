"""Damping laws C(q) of a normal contact, m q'' + C(q) q' + U'(q) = 0 (issue 18).

One table of laws, the same names and parameters in scenes (``[damping] law = ...``),
in `solve_impact` / `solve_impacts` (``law=``) and in the adapter protocol's
``implemented_law.damping``. The damping force is C(q) q' (N), C in kg/s:

=================  ===============================  ==========================================
law                parameters (SI units)             C(q) [kg/s]
=================  ===============================  ==========================================
``none``                                             0
``universal``      ``zeta`` (-) [+ restitution_end]  2 zeta sqrt(m) U'(q) / sqrt(2 U(q))
``linear``         ``c`` [N s/m]                     c
``power``          ``c`` [N s m^-(1+e)], ``exponent`` e >= 0   c q^e
``polynomial``     ``c = [c0, c1, ...]`` (ci >= 0, [N s m^-(1+i)])  sum ci q^i
``viscoelastic``   ``A`` [s]                         A U''(q)  (Kuwabara-Kono / Brilliantov)
``hunt-crossley``  ``alpha`` [s/m]                   alpha U'(q)
=================  ===============================  ==========================================

Every parameter is validated here (one line naming the value, `HCVInputError`).
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from reference_impl.errors import HCVInputError

__all__ = [
    "LAWS",
    "MAX_POLY_TERMS",
    "DampingLaw",
    "law_from_dict",
    "law_C",
]

LAWS = ("none", "universal", "linear", "power", "polynomial", "viscoelastic", "hunt-crossley")
# Every user-controlled size is bounded: a polynomial of degree 15 is already far beyond any
# published impedance law; more terms would only cost time.
MAX_POLY_TERMS = 16
# Largest damping exponent accepted: C ~ q^e with e > 20 is negligible over any contact that
# float64 resolves, and larger values only risk overflow.
MAX_EXPONENT = 20.0
_PARAMS = {
    "none": (),
    "universal": ("zeta",),
    "linear": ("c",),
    "power": ("c", "exponent"),
    "polynomial": ("c",),
    "viscoelastic": ("A",),
    "hunt-crossley": ("alpha",),
}
_UNITS = {
    "linear": {"c": "N s/m"},
    "power": {"c": "N s m^-(1+exponent)", "exponent": "-"},
    "polynomial": {"c": "N s m^-(1+i)"},
    "viscoelastic": {"A": "s"},
    "hunt-crossley": {"alpha": "s/m"},
    "universal": {"zeta": "-"},
}


def _num(law: str, key: str, value, *, low: float = 0.0, high: float = math.inf) -> float:
    unit = _UNITS.get(law, {}).get(key, "")
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


@dataclass(frozen=True)
class DampingLaw:
    """One damping law of the table (validated on construction).

    Parameters
    ----------
    name : str
        One of `LAWS`.
    params : dict
        Its parameters in SI units (see the module table); ``polynomial`` takes
        ``c`` as a sequence of coefficients c0, c1, ... (each >= 0).
    """

    name: str
    params: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.name not in LAWS:
            near = (
                difflib.get_close_matches(self.name.replace("_", "-"), LAWS, n=1, cutoff=0.75)
                if isinstance(self.name, str)
                else []
            )
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise HCVInputError(
                f"unknown damping law {self.name!r}; choose one of {', '.join(LAWS)}{hint}"
            )
        if not isinstance(self.params, dict):
            raise HCVInputError(f"damping law parameters must be a table, got {self.params!r}")
        want = _PARAMS[self.name]
        extra = sorted(set(self.params) - set(want))
        if extra:
            raise HCVInputError(
                f"damping law {self.name!r} takes {', '.join(want) or 'no parameters'}; "
                f"got unknown {extra[0]!r}"
            )
        missing = [k for k in want if k not in self.params]
        if missing:
            raise HCVInputError(f"damping law {self.name!r} needs {missing[0]!r}")
        clean: dict[str, Any] = {}
        for key in want:
            val = self.params[key]
            if self.name == "polynomial":
                if isinstance(val, (int, float)) and not isinstance(val, bool):
                    val = [val]
                if not isinstance(val, (list, tuple)) or not 1 <= len(val) <= MAX_POLY_TERMS:
                    raise HCVInputError(
                        "damping law 'polynomial': c must be a list of 1 to "
                        f"{MAX_POLY_TERMS} coefficients [c0, c1, ...], got {val!r}"
                    )
                clean[key] = tuple(_num(self.name, f"c[{i}]", v) for i, v in enumerate(val))
            elif key == "exponent":
                clean[key] = _num(self.name, key, val, high=MAX_EXPONENT)
            else:
                clean[key] = _num(self.name, key, val)
        object.__setattr__(self, "params", clean)

    # -- the law as power terms ---------------------------------------------
    def terms(self) -> tuple[tuple[float, float], ...]:
        """(c_j, e_j) of the part sum c_j q^e_j of C(q) (empty for other laws)."""
        p = self.params
        if self.name == "linear":
            return ((p["c"], 0.0),)
        if self.name == "power":
            return ((p["c"], p["exponent"]),)
        if self.name == "polynomial":
            return tuple((c, float(i)) for i, c in enumerate(p["c"]) if c != 0.0)
        return ()

    @property
    def alpha(self) -> float:
        """Coefficient of U'(q) in C(q) (hunt-crossley), s/m."""
        return self.params["alpha"] if self.name == "hunt-crossley" else 0.0

    @property
    def A(self) -> float:
        """Coefficient of U''(q) in C(q) (viscoelastic), s."""
        return self.params["A"] if self.name == "viscoelastic" else 0.0

    @property
    def zeta(self) -> float:
        """Damping ratio of the universal part (0 for other laws)."""
        return self.params["zeta"] if self.name == "universal" else 0.0

    def is_zero(self) -> bool:
        """True when C(q) = 0 identically."""
        return self.name == "none" or (
            not self.terms() and self.alpha == 0 and self.A == 0 and self.zeta == 0
        )

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
    want = _PARAMS.get(name)
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


def law_C(law: DampingLaw, pot, m: float, q, ns=np):
    """C(q) in kg/s on an array (or an mpmath number with ``ns=mpmath``), q > 0."""
    c = 0 * q
    for cj, ej in law.terms():
        c = c + cj * (q**ej if ej != 0 else 1)
    if law.alpha:
        c = c + law.alpha * pot._dU(q)
    if law.A:
        c = c + law.A * pot._d2U(q)
    if law.zeta:
        c = c + 2 * law.zeta * ns.sqrt(m) * pot._dU(q) / ns.sqrt(2 * pot._U(q))
    return c
