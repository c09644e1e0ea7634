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
from reference_impl.theory.damping import restitution_from_zeta

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
        "none" or "universal".
    zeta : float
        Damping ratio of the universal law (0 for "none").
    dt : float
        Time step (s).
    n_steps : int
        Step budget.
    velocities : tuple of float
        Every speed of the scene (m/s).
    gap : float or None
        Free-flight gap between the walls (m), "two-walls" only.
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

    @property
    def restitution(self) -> float:
        """Restitution asked for: exp(-pi zeta / sqrt(1 - zeta^2)), 1 without damping."""
        return restitution_from_zeta(self.zeta) if self.damping == "universal" else 1.0

    def replace(self, **changes) -> AdapterScene:
        """A copy with some fields changed (e.g. dt, n_steps, v0)."""
        from dataclasses import replace

        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        """The scene in the JSON schema of the subprocess protocol (docs/adapter-protocol.md)."""
        out = {
            "name": self.name,
            "kind": self.kind,
            "potential": dict(self.potential_spec),
            "mass": self.mass,
            "v0": self.v0,
            "damping": {"law": self.damping, "zeta": self.zeta, "restitution": self.restitution},
            "dt": self.dt,
            "n_steps": int(self.n_steps),
            "velocities": list(self.velocities),
        }
        if self.gap is not None:
            out["gap"] = self.gap
        return out

    @classmethod
    def from_scene(cls, scene, v0: float, dt: float, n_steps: int) -> AdapterScene:
        """Build from a validated `reference_impl.scenes.Scene` at one speed."""
        if scene.damping_law not in ("none", "universal"):
            # Sending it as "none" would score codes against the wrong law.
            raise HCVInputError(
                f"scene {scene.name!r}: hcv bench sends scenes with damping law 'none' or "
                f"'universal' (got {scene.damping_law!r}); a code that integrates another law "
                "declares it in implemented_law.damping and is scored against it"
            )
        zeta = float(scene.zeta or 0.0) if scene.damping_law == "universal" else 0.0
        return cls(
            name=scene.name,
            kind=scene.kind,
            potential=scene.potential,
            potential_spec=potential_to_dict(scene.potential),
            mass=float(scene.mass),
            v0=float(v0),
            damping=scene.damping_law if zeta > 0 else "none",
            zeta=zeta,
            dt=float(dt),
            n_steps=int(n_steps),
            velocities=tuple(scene.velocities),
            gap=scene.gap,
        )


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
