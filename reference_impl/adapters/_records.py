"""What crosses the adapter contract: the scene handed to a code, the trajectory and the
law it hands back, and the errors of a run (items 2, 5 and 6 of the contract in
`reference_impl.adapters.base`, where every name here is importable from)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential
from reference_impl.scenes import potential_to_dict
from reference_impl.theory.damping import (
    restitution_from_zeta,
    restitution_zero_force_from_zeta,
)
from reference_impl.theory.laws import is_harmonic

__all__ = [
    "AdapterDeclined",
    "AdapterError",
    "AdapterOutputError",
    "AdapterRunError",
    "AdapterScene",
    "ImplementedLaw",
    "PowerDamping",
    "Trajectory",
]


class AdapterError(RuntimeError):
    """An adapter run failed (exception, crash, timeout or malformed output)."""


class AdapterOutputError(AdapterError):
    """The adapter returned something that is not a valid `Trajectory`."""


class AdapterRunError(AdapterError):
    """The adapter raised, crashed or timed out; ``stderr`` holds its diagnostics."""

    def __init__(self, message: str, stderr: str = ""):
        super().__init__(message)
        self.stderr = stderr


class AdapterDeclined(AdapterRunError):
    """The code declines the scene at run time (contract item 7): the scene is skipped.

    Raised by a Python adapter's ``_impact_impl`` / ``_sustained_impl``, or by the
    subprocess adapter for a ``{"unsupported": reason}`` answer of a ``cmd:`` program.

    Parameters
    ----------
    reason : str
        One line saying why (shown as the skip reason of the scene's metrics).
    """

    def __init__(self, reason: str):
        super().__init__(f"declined: {reason}")
        self.declined = reason


@dataclass(frozen=True)
class AdapterScene:
    """One run handed to an adapter (see the contract, item 2). SI units.

    Attributes
    ----------
    name : str
        Scene name.
    kind : str
        "impact" or "two-walls" (sustained).
    potential : Potential
        Contact potential U(q) (J, q in m).
    potential_spec : dict
        The potential as a scene table, e.g. {"family": "power", "k": ..., "p": ...}.
    mass : float
        Effective mass (kg).
    v0 : float
        Approach speed at contact onset (m/s, > 0).
    damping : str
        The damping law's name: "none", "universal" or another registered law of
        `reference_impl.theory.laws` (``LAWS``; ``hcv scenes --laws`` lists them).
    zeta : float
        Damping ratio of the universal law (0 for every other law).
    dt : float
        Time step (s).
    n_steps : int
        Step budget.
    velocities : tuple of float
        Every speed of the scene (m/s).
    gap : float or None
        Free-flight gap between the walls (m), "two-walls" only.
    law : dict
        The damping law with its (solved) parameters in the form of a scene's
        ``[damping]`` table and of ``implemented_law.damping``, e.g.
        ``{"law": "hunt-crossley", "alpha": 0.31}`` (s/m); empty: derived from
        ``damping`` and ``zeta``.
    restitution_asked : float or None
        The restitution the scene asks at ``restitution_end`` (at ``restitution_speed``
        for a speed-dependent law); None: the universal law's e from ``zeta`` at
        ``restitution_end`` (1 without damping).
    restitution_end : str
        Where the asked restitution is read: "overlap" (q back to 0) or "zero-force"
        (the total force first 0 after maximum compression).
    restitution_speed : float or None
        Impact speed (m/s) at which a speed-dependent law's restitution was asked
        (its strength was solved there); None for the universal law or a law given
        by its parameters.
    """

    name: str
    kind: str
    potential: Potential
    potential_spec: dict
    mass: float
    v0: float
    damping: str
    zeta: float
    dt: float
    n_steps: int
    velocities: tuple[float, ...] = ()
    gap: float | None = None
    law: dict = field(default_factory=dict)
    restitution_asked: float | None = None
    restitution_end: str = "overlap"
    restitution_speed: float | None = None

    def __post_init__(self):
        if not self.law:  # built by older callers from damping and zeta alone
            table = {"law": "universal", "zeta": float(self.zeta)}
            object.__setattr__(
                self, "law", table if self.damping == "universal" else {"law": "none"}
            )
        if self.restitution_asked is None:
            e = 1.0
            if self.damping == "universal" and self.zeta:
                e = float(
                    restitution_zero_force_from_zeta(self.zeta)
                    if self.restitution_end == "zero-force"
                    else restitution_from_zeta(self.zeta)
                )
            object.__setattr__(self, "restitution_asked", e)

    @property
    def restitution(self) -> float:
        """Protocol-1 restitution: the universal law's exp(-pi zeta / sqrt(1 - zeta^2))
        (the overlap end, whatever end the scene asks), 1 without damping; for any other
        law the asked one (`restitution_asked`). Read `restitution_asked` at
        `restitution_end` for what the scene asks."""
        if self.damping == "universal":
            return restitution_from_zeta(self.zeta)
        if self.damping == "none":
            return 1.0
        return float(self.restitution_asked)

    def universal_only(self, who: str) -> str | None:
        """Why a code that integrates the universal law only (or none) declines this
        scene (one line naming the law), or None when the scene's law is one of them."""
        if is_harmonic(self.damping):
            return None
        params = ", ".join(f"{k} = {v!r}" for k, v in self.law.items() if k != "law")
        asked = (
            f" (solved for e = {self.restitution_asked:g} at "
            f"{self.restitution_speed:g} m/s, {self.restitution_end} end)"
            if self.restitution_speed is not None
            else ""
        )
        return (
            f"{who} maps only the universal damping law (or none) onto the code's inputs, "
            f"not the scene's {self.damping!r} law ({params}){asked}"
        )

    def replace(self, **changes) -> AdapterScene:
        """A copy with some fields changed (e.g. dt, n_steps, v0). Changing ``damping`` or
        ``zeta`` alone re-derives ``law`` and ``restitution_asked`` from them."""
        from dataclasses import replace

        if ("zeta" in changes or "damping" in changes) and "law" not in changes:
            changes["law"] = {}
            changes.setdefault("restitution_asked", None)
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        """The scene in the JSON schema of the subprocess protocol (docs/adapter-protocol.md)."""
        out = {
            "name": self.name,
            "kind": self.kind,
            "potential": dict(self.potential_spec),
            "mass": self.mass,
            "v0": self.v0,
            "damping": {
                # protocol 1's fields, unchanged for the universal law and none
                "law": self.damping,
                "zeta": self.zeta,
                "restitution": self.restitution,
                # protocol 2: the law's (solved) parameters and what the scene asks
                "params": dict(self.law),
                "restitution_asked": self.restitution_asked,
                "restitution_end": self.restitution_end,
            },
            "dt": self.dt,
            "n_steps": int(self.n_steps),
            "velocities": list(self.velocities),
        }
        if self.restitution_speed is not None:
            out["damping"]["restitution_speed"] = self.restitution_speed
        if self.gap is not None:
            out["gap"] = self.gap
        return out

    @classmethod
    def from_scene(cls, scene, v0: float, dt: float, n_steps: int) -> AdapterScene:
        """Build from a validated `reference_impl.scenes.Scene` at one speed: any damping
        law, with its solved parameters and the restitution the scene asks."""
        law = scene.law.to_dict() if scene.law is not None else {"law": "none"}
        name = scene.damping_law
        zeta = float(scene.zeta or 0.0) if name == "universal" else 0.0
        eq = getattr(scene, "equivalent_universal_zeta", None)
        if not is_harmonic(name) and eq is not None:
            # The scene's law is the universal law at zeta = eq (a constant C on Hooke, or
            # a law at strength 0): sent as such, so a code that maps only the universal
            # law runs it instead of declining (`Scene.equivalent_universal_zeta`).
            name, zeta, law = "universal", float(eq), {"law": "universal", "zeta": float(eq)}
        if name == "universal" and zeta == 0.0:
            name, law = "none", {"law": "none"}
        end = getattr(scene, "restitution_end", "overlap")
        cal = getattr(scene, "calibration", None) or {}
        speed = cal.get("restitution_speed")
        if "restitution" in cal:
            asked = float(cal["restitution"])
        elif is_harmonic(name):
            asked = None  # from zeta at the asked end (`__post_init__`)
        else:
            # a law given by its parameters: its e depends on the speed; what it asks
            # is its own exact e at this run's speed (`reference_impl.exact.general_law`)
            asked = _law_restitution(scene, law, float(v0), end)
        return cls(
            name=scene.name,
            kind=scene.kind,
            potential=scene.potential,
            potential_spec=potential_to_dict(scene.potential),
            mass=float(scene.mass),
            v0=float(v0),
            damping=name,
            zeta=zeta,
            dt=float(dt),
            n_steps=int(n_steps),
            velocities=tuple(scene.velocities),
            gap=scene.gap,
            law=law,
            restitution_asked=asked,
            restitution_end=end,
            restitution_speed=None if speed is None else float(speed),
        )


def _law_restitution(scene, law: dict, v0: float, end: str) -> float:
    """Exact restitution of a scene's law (not the universal one) at v0 and ``end``."""
    from reference_impl.exact.general_law import solve_law_impact
    from reference_impl.theory.laws import law_from_dict

    sol = solve_law_impact(scene.potential, float(scene.mass), v0, law_from_dict(law))
    return float(sol.restitution_zero_force if end == "zero-force" else sol.restitution)


@dataclass
class Trajectory:
    """What an adapter returns for one run (contract, items 3-5).

    Attributes
    ----------
    t, q, v, force : numpy.ndarray
        Time (s), overlap (m), overlap rate (m/s) and normal contact force on the
        body (N, positive repulsive), at the same instants.
    meta : dict
        Free-form information (code version, parameters used, steps, ...).
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    force: np.ndarray
    meta: dict = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """Plain lists (non-finite values as null)."""

        def lst(a):
            return [float(x) if math.isfinite(x) else None for x in np.asarray(a, float)]

        return {
            "t": lst(self.t),
            "q": lst(self.q),
            "v": lst(self.v),
            "force": lst(self.force),
            "meta": self.meta,
        }


@dataclass(frozen=True)
class PowerDamping:
    """Damping coefficient C(q) = c q^exponent (kg/s): picklable, JSON-describable.

    Covers LAMMPS's models: velocity (exponent 0), viscoelastic (1/2), Tsuji
    (p - 1)/2. For a power law U' = k q^p the exponent (p - 1)/2 *is* the universal
    law, with zeta = c / (2 sqrt(m k (p + 1) / 2)) (`reference_impl.tsuji_coefficient`).
    """

    c: float
    exponent: float = 0.0

    def __call__(self, q):
        q = np.asarray(q, dtype=float)
        if self.exponent == 0.0:
            return self.c + 0.0 * q
        with np.errstate(invalid="ignore"):
            return self.c * np.where(q > 0, q, 0.0) ** self.exponent

    def to_json(self) -> dict:
        return {"law": "power", "c": self.c, "exponent": self.exponent}


@dataclass(frozen=True)
class ImplementedLaw:
    """The force law a code actually integrates (contract, item 6).

    Attributes
    ----------
    potential : Potential
        Elastic potential U(q).
    mass : float
        Effective mass (kg).
    zeta : float or None
        Damping ratio when the damping is the universal law (0: none); None when
        ``C`` is given instead.
    C : callable or None
        Damping coefficient q -> C(q) (kg/s) when it is not the universal law.
    clips_tension : bool
        True when the code sets an attractive total normal force to 0.
    description : str
        One line, e.g. "hertz k_n = ..., damping tsuji (alpha = ...)".
    params : dict
        The code's own parameter values, for the report.
    """

    potential: Potential
    mass: float
    zeta: float | None = 0.0
    C: Callable | None = None
    clips_tension: bool = False
    description: str = ""
    params: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.C is not None:
            if self.zeta:
                raise HCVInputError("ImplementedLaw: give either zeta or C, not both")
            object.__setattr__(self, "zeta", None)
        elif self.zeta is None or not (math.isfinite(self.zeta) and self.zeta >= 0):
            raise HCVInputError(
                f"ImplementedLaw: zeta must be >= 0 when C is not given, got {self.zeta!r}"
            )

    def damping_coefficient(self, q):
        """C(q) (kg/s) at overlaps q > 0."""
        q = np.asarray(q, dtype=float)
        if self.C is not None:
            return np.asarray(self.C(q), dtype=float)
        if not self.zeta:
            return np.zeros_like(q)
        pot = self.potential
        with np.errstate(divide="ignore", invalid="ignore"):
            c = 2.0 * self.zeta * math.sqrt(self.mass) * pot._dU(q) / np.sqrt(2.0 * pot._U(q))
        return np.where(q > 0, c, 0.0)

    def to_json(self) -> dict:
        damping: dict[str, Any]
        if self.C is not None:
            damping = (
                self.C.to_json()
                if hasattr(self.C, "to_json")
                else {"law": "callable", "repr": repr(self.C)}
            )
        else:
            damping = {"law": "universal" if self.zeta else "none", "zeta": self.zeta or 0.0}
        return {
            "potential": potential_to_dict(self.potential),
            "mass": self.mass,
            "damping": damping,
            "clips_tension": self.clips_tension,
            "description": self.description,
            "params": self.params,
        }
