"""Any damping law of `reference_impl.theory.laws` as the ``C`` of an `ImplementedLaw` (issue 18).

`LawDamping` is picklable (Python adapters run in worker processes) and describes
itself in the protocol's ``implemented_law.damping`` form, so a code that declares,
e.g., ``{"law": "hunt-crossley", "alpha": 0.2}`` is scored against the exact
solution of that law and against textbook Verlet with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reference_impl.adapters._records import AdapterScene, ImplementedLaw, PowerDamping
from reference_impl.potentials.base import Potential
from reference_impl.theory.laws import DampingLaw, is_harmonic, law_C, law_from_dict

__all__ = ["LawDamping", "implemented_law_from_table", "scene_law"]


@dataclass(frozen=True)
class LawDamping:
    """C(q) (kg/s) of a `DampingLaw` for one potential and mass.

    Parameters
    ----------
    law : DampingLaw
        The law (its ``alpha`` / ``A`` / universal terms need U, hence the potential).
    potential : Potential
        The elastic potential of the implemented law.
    mass : float
        Reduced mass (kg).
    """

    law: DampingLaw
    potential: Potential
    mass: float

    def __call__(self, q):
        q = np.asarray(q, dtype=float)
        with np.errstate(all="ignore"):
            c = law_C(self.law, self.potential, self.mass, np.where(q > 0, q, 0.0))
        return np.where(q > 0, c, 0.0) if np.ndim(c) else c

    def to_json(self) -> dict:
        return self.law.to_dict()


def implemented_law_from_table(pot: Potential, mass: float, table, **kw) -> ImplementedLaw:
    """An `ImplementedLaw` from a protocol ``damping`` table (every law of the table).

    ``none`` and ``universal`` keep the exact quadrature (``zeta``); ``power`` stays a
    `PowerDamping` (the form whose Tsuji exponent is recognised as universal); the
    others are a `LawDamping`.
    """
    law = law_from_dict(table, where="implemented_law.damping")
    if law.harmonic_zeta is not None:
        return ImplementedLaw(pot, float(mass), zeta=law.harmonic_zeta, **kw)
    if law.name == "power":
        return ImplementedLaw(
            pot, float(mass), C=PowerDamping(law.params["c"], law.params["exponent"]), **kw
        )
    if law.A and float(pot.leading_exponent) < 2.0:
        from reference_impl.errors import HCVInputError

        raise HCVInputError(
            "implemented_law.damping: 'viscoelastic' needs U'' finite at contact (leading "
            f"exponent >= 2), got {float(pot.leading_exponent):.6g}"
        )
    return ImplementedLaw(pot, float(mass), C=LawDamping(law, pot, float(mass)), **kw)


def law_of(damping) -> DampingLaw | None:
    """The `DampingLaw` behind an ImplementedLaw's C (None for an opaque callable)."""
    if isinstance(damping, LawDamping):
        return damping.law
    if isinstance(damping, PowerDamping):
        return DampingLaw("power", {"c": damping.c, "exponent": damping.exponent})
    return None


def scene_law(scene: AdapterScene, **kw) -> ImplementedLaw:
    """The law an `AdapterScene` asks, as an `ImplementedLaw` (any law of the table, with
    its solved parameters; keywords such as ``description`` go to `ImplementedLaw`)."""
    if is_harmonic(scene.damping):
        return ImplementedLaw(scene.potential, scene.mass, zeta=scene.zeta, **kw)
    return implemented_law_from_table(scene.potential, scene.mass, dict(scene.law), **kw)
