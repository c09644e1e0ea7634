"""The adapter contract: how a third-party contact code is plugged into the suite.

The suite benchmarks other people's contact codes by running the same normal
impacts through them and through the exact solution (`reference_impl.solve_impact`),
then comparing. A code is plugged in through an *adapter*: a subclass of
`ContactAdapter` (Python), or a command speaking JSON on stdin/stdout
(`reference_impl.adapters.subprocess`, schema in ``docs/adapter-protocol.md``).

Implementer contract
--------------------
The items hold for both forms; where the JSON form of a ``cmd:`` program
differs, the item says so (``docs/adapter-protocol.md`` has its full schema).

1. Subclass `ContactAdapter`, give it a short ``name`` and implement
   ``_impact_impl(self, scene: AdapterScene) -> Trajectory`` (a mapping with the
   keys ``t, q, v, force`` and optionally ``meta`` is accepted too). Do not
   override `ContactAdapter.impact`: it validates what you return. Run it with
   ``hcv bench package.module:Class`` (constructor arguments
   ``package.module:Class[key=value,...]``); a program in another language with
   ``hcv bench "cmd:COMMAND"`` (one JSON request on stdin, one JSON response on
   stdout per run).
2. What a scene gives (`AdapterScene`, SI units): the contact potential U(q)
   (``potential``, a `Potential`; ``potential_spec`` is the same as a plain dict,
   e.g. ``{"family": "power", "k": 1e10, "p": 1.5}`` for U' = k q^p), the
   *effective* mass ``mass`` (kg), the approach speed ``v0`` (m/s, > 0), the
   damping asked for (``damping`` = "none" or "universal" with ratio ``zeta``, i.e.
   C(q) = 2 zeta sqrt(m) U'/sqrt(2U), whose restitution is ``restitution`` at every
   speed), the time step ``dt`` (s) and a step budget ``n_steps``; ``velocities``
   lists every speed of the scene (for codes that calibrate a damping constant).
   ``cmd:``: the ``"scene"`` object of the request (`AdapterScene.to_json`).
3. Start at contact onset: t = 0, overlap q = 0, dq/dt = v0 (q > 0 is overlap,
   dq/dt > 0 approaching). For two bodies, q is the total overlap and ``mass``
   the reduced mass m1 m2 / (m1 + m2).
4. Integrate with exactly ``scene.dt`` and record every step. Stop at the first
   step after the overlap has returned to q <= 0 (the body has separated), or
   after ``scene.n_steps`` steps, whichever comes first. Keep that first
   out-of-contact sample: the restitution is read from its velocity.
5. Return 1-D float arrays of equal length >= 2: time ``t`` (s, t[0] = 0,
   strictly increasing), overlap ``q`` (m; <= 0 is a gap), its rate ``v`` (m/s)
   and the normal contact ``force`` on the body (N, positive = repulsive,
   negative = attractive, 0 out of contact), all at the same instants. A blown-up
   run may contain inf/NaN: that is a result (unstable), not malformed output.
   Anything else (missing key, wrong length, t not increasing) is malformed and
   the run fails with a one-line reason. ``cmd:``: JSON arrays, non-finite
   numbers as ``null``.
6. Optional: ``implemented_law(scene) -> ImplementedLaw`` says which force law the
   code *actually* integrates (potential, mass, damping: a universal ratio
   ``zeta`` or a coefficient ``C(q)``, e.g. `PowerDamping`, or any law of
   `reference_impl.theory.laws` as a `LawDamping` (built by
   `reference_impl.adapters.implemented_law_from_table`); ``clips_tension`` if
   the code never lets the total force pull). The scorecard compares the code with
   the exact solution of that law as well as with what was asked; the references
   (exact solution, textbook Verlet) run every law of the table, not an opaque
   callable. The default claims the scene's own law. For adapters run in a worker
   process the law is pickled: use `LawDamping`, `PowerDamping` or a module-level
   function for ``C``. ``cmd:``: the ``"implemented_law"`` key of the response.
7. Declining a scene. Optional: ``supports(scene) -> str | None`` returns why a
   scene cannot be run (e.g. "only power laws with p = 1 or 1.5"); such scenes
   are skipped, not failed. A code that finds out only while running raises
   `AdapterDeclined` ("one-line reason") from ``_impact_impl`` /
   ``_sustained_impl``: the whole scene is skipped with that reason. A ``cmd:``
   program answers ``{"unsupported": "one-line reason"}`` instead of a
   trajectory (``{"error": "..."}`` or a non-zero exit is a failed run, not a skip).
8. Optional: ``variants() -> list[ContactAdapter]`` splits one adapter into
   several configurations benchmarked separately (e.g. one per damping model);
   each variant needs a distinct ``label``.
9. Optional, sustained scenes (kind "two-walls"), sent only to adapters that
   declare them (undeclared: skipped, "runs single impacts only"). Python: set
   ``supports_sustained = True`` and implement ``_sustained_impl(scene)``, which
   returns the trajectory of ``scene.n_steps`` steps of a body bouncing between
   two walls ``scene.gap`` apart (q measured at the wall being touched, as in
   `reference_impl.integrators.verlet`). ``cmd:`` program: give it as
   ``cmd[sustained=true]:COMMAND`` and answer requests with ``"request":
   "sustained"`` the same way (or decline one, item 7).
10. Be deterministic and self-contained: no files left behind, nothing printed on
    stdout (use stderr for diagnostics; it is kept and shown when a run fails; a
    Python adapter's stdout is discarded with one warning naming it, a ``cmd:``
    program's stdout is its JSON answer). A run that raises, crashes or exceeds
    the per-run timeout is reported as a failure of that run only; the benchmark
    goes on (after a timeout, the code's other runs on that scene are not started).
11. Staggered quantities. Report q, v and force at the same instants t[n] when
    you can. A code that stores some of them shifted in time may return them as
    stored and declare the shift in ``staggering`` (a mapping, class or instance
    attribute; the ``"staggering"`` key of a ``cmd:`` response does the same):
    ``{"force": k}`` (integer k, 1 to 4) when force[n] is the force at t[n - k] (a
    force stored one step late, e.g. Kratos' Symplectic_Euler: k = 1);
    ``{"v": 0.5}`` when v[n] is the velocity at t[n] - dt/2 (leapfrog). `impact`
    re-aligns before anything is measured: force[n] <- force[n + k] and
    v[n] <- (v[n] + v[n + 1]) / 2; the last k samples (last sample for v) keep 0
    force / their own velocity when out of contact (q <= 0), NaN otherwise. The
    run's ``meta["staggering_aligned"]`` records what was done.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
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
    "ContactAdapter",
    "ImplementedLaw",
    "PowerDamping",
    "Trajectory",
    "align_staggered",
    "check_staggering",
    "trajectory_from_mapping",
]

# t[0] must be 0 within this fraction of the trajectory's duration.
_T0_RTOL = 1e-9
# Declarable staggering (contract item 11): the quantity and the allowed shifts.
_STAGGER_KEYS = ("force", "v")
_MAX_FORCE_LAG = 4  # a larger lag is a mistake, not a scheme


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


_NONE = object()


def _short_repr(value, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _array(name: str, value, who: str) -> np.ndarray:
    if value is None:
        raise AdapterOutputError(f"{who}: output has no {name!r}")
    if isinstance(value, (list, tuple)):
        # Numbers only: numpy would read "1.5" or true as numbers, hiding a wrong writer.
        bad = next(
            (
                x
                for x in value
                if x is not None
                and not isinstance(x, (list, tuple))  # nested: refused below as not 1-D
                and (isinstance(x, bool) or not isinstance(x, (int, float)))
            ),
            _NONE,
        )
        if bad is not _NONE:
            raise AdapterOutputError(
                f"{who}: {name!r} is not an array of numbers (or null): it holds {_short_repr(bad)}"
            )
        value = [np.nan if x is None else x for x in value]
    elif isinstance(value, (str, bytes, Mapping)):
        raise AdapterOutputError(
            f"{who}: {name!r} is not an array of numbers, got {_short_repr(value)}"
        )
    else:
        kind = getattr(np.asarray(value), "dtype", np.dtype(object)).kind
        if kind not in "fiu":
            raise AdapterOutputError(
                f"{who}: {name!r} is not an array of numbers (dtype kind {kind!r})"
            )
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise AdapterOutputError(f"{who}: {name!r} is not an array of numbers") from None
    if a.ndim != 1:
        raise AdapterOutputError(f"{who}: {name!r} must be 1-D, got shape {a.shape}")
    return a


def check_staggering(value, who: str = "adapter") -> dict:
    """Validate a staggering declaration (contract item 11); returns a plain dict.

    Raises
    ------
    AdapterOutputError
        One line naming the offending key or value.
    """
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise AdapterOutputError(
            f"{who}: 'staggering' must be a mapping such as {{\"force\": 1}}, got {value!r}"
        )
    out: dict = {}
    for key, shift in value.items():
        if key not in _STAGGER_KEYS:
            raise AdapterOutputError(
                f"{who}: staggering key {key!r} is not one of {', '.join(_STAGGER_KEYS)}"
            )
        if key == "force":
            if (
                isinstance(shift, bool)
                or not isinstance(shift, (int, float))
                or shift != int(shift)
                or not 0 <= shift <= _MAX_FORCE_LAG
            ):
                raise AdapterOutputError(
                    f"{who}: staggering 'force' must be an integer lag in "
                    f"0..{_MAX_FORCE_LAG} steps, got {shift!r}"
                )
            if shift:
                out["force"] = int(shift)
        elif shift not in (0, 0.0, 0.5):
            raise AdapterOutputError(
                f"{who}: staggering 'v' must be 0 or 0.5 (half a step behind), got {shift!r}"
            )
        elif shift:
            out["v"] = 0.5
    return out


def align_staggered(tr: Trajectory, staggering: Mapping) -> Trajectory:
    """Re-align staggered force / velocity samples onto t (contract item 11)."""
    if not staggering:
        return tr
    q = tr.q
    out_of_contact = q <= 0
    force, v = tr.force, tr.v
    done = {}
    k = int(staggering.get("force", 0))
    if k:
        k_in = min(k, q.size)  # a lag longer than the run leaves no known force
        tail = np.where(out_of_contact[q.size - k_in :], 0.0, np.nan)
        force = np.concatenate([force[k_in:], tail])
        done["force"] = f"force[n] <- force[n + {k}]"
    if staggering.get("v"):
        last = v[-1] if out_of_contact[-1] else np.nan
        v = np.concatenate([0.5 * (v[:-1] + v[1:]), [last]])
        done["v"] = "v[n] <- (v[n] + v[n + 1]) / 2"
    return Trajectory(tr.t, q, v, force, {**tr.meta, "staggering_aligned": done})


def trajectory_from_mapping(obj, who: str = "adapter", staggering=None) -> Trajectory:
    """Validate an adapter's output (a `Trajectory` or a mapping) and return a `Trajectory`.

    A ``"staggering"`` key of a mapping, or the ``staggering`` argument (the
    adapter's declaration), re-aligns shifted samples (contract item 11).

    Raises
    ------
    AdapterOutputError
        With one line saying what is wrong.
    """
    if isinstance(obj, Trajectory):
        data: Mapping = {"t": obj.t, "q": obj.q, "v": obj.v, "force": obj.force, "meta": obj.meta}
    elif isinstance(obj, Mapping):
        data = obj
    else:
        raise AdapterOutputError(
            f"{who}: returned {type(obj).__name__}, expected a Trajectory or a mapping with "
            "t, q, v, force"
        )
    arrays = {k: _array(k, data.get(k), who) for k in ("t", "q", "v", "force")}
    n = arrays["t"].size
    for k, a in arrays.items():
        if a.size != n:
            raise AdapterOutputError(f"{who}: {k!r} has {a.size} samples but 't' has {n}")
    if n < 2:
        raise AdapterOutputError(f"{who}: need at least 2 samples, got {n}")
    t = arrays["t"]
    if not np.all(np.isfinite(t)):
        raise AdapterOutputError(f"{who}: 't' contains non-finite values")
    if np.any(np.diff(t) <= 0):
        i = int(np.argmax(np.diff(t) <= 0))
        raise AdapterOutputError(
            f"{who}: 't' must increase strictly (t[{i}] = {t[i]!r}, t[{i + 1}] = {t[i + 1]!r})"
        )
    if abs(t[0]) > _T0_RTOL * (t[-1] - t[0]):
        raise AdapterOutputError(f"{who}: 't' must start at 0 (contact onset), got {t[0]!r}")
    meta = data.get("meta") or {}
    if not isinstance(meta, Mapping):
        raise AdapterOutputError(f"{who}: 'meta' must be a mapping, got {type(meta).__name__}")
    declared = check_staggering(staggering, who)
    declared.update(
        check_staggering(data.get("staggering"), who) if isinstance(data, Mapping) else {}
    )
    tr = Trajectory(arrays["t"], arrays["q"], arrays["v"], arrays["force"], dict(meta))
    return align_staggered(tr, declared)


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


class ContactAdapter:
    """Base class of every adapter; see the module docstring for the contract.

    Class attributes
    ----------------
    name : str
    # Constructor arguments a spec may give by value alone (``kratos[hertz,verlet]``):
    # key -> accepted values; a ``True`` flag key is given by its own name
    # (``lammps[tsuji,limit_damping]``). Listed by ``hcv bench --help``.
    spec_values: dict = {}
        Registry-style name of the code ("lammps", "reference", ...).
    isolate : bool
        Run this adapter in a worker process (crash and hang isolation). True by
        default for third-party code; adapters that are themselves isolated (the
        subprocess adapter) or trusted (the reference) set it False.
    supports_sustained : bool
        Implements `_sustained_impl` (contract item 9).
    staggering : dict
        Time shifts of the returned samples (contract item 11), e.g. {"force": 1}
        when the force is stored one step late; `impact` re-aligns them. Empty:
        every quantity is at t[n].
    """

    name: str = "adapter"
    isolate: bool = True
    supports_sustained: bool = False
    staggering: Mapping = {}

    @property
    def label(self) -> str:
        """Name of this configuration in scorecards (unique among `variants`)."""
        return self.name

    # -- the hooks an implementer provides -----------------------------------
    def _impact_impl(self, scene: AdapterScene):  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} must implement _impact_impl(scene)")

    def _sustained_impl(self, scene: AdapterScene):
        raise NotImplementedError(f"{type(self).__name__} does not implement sustained scenes")

    def supports(self, scene: AdapterScene) -> str | None:
        """None when the scene can be run, else a one-line reason (the scene is skipped)."""
        if scene.kind != "impact" and not self.supports_sustained:
            return f"{self.label} runs single impacts only (scene kind {scene.kind!r})"
        return None

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        """The law the code integrates for this scene; default: exactly the scene's."""
        return ImplementedLaw(
            scene.potential,
            scene.mass,
            zeta=scene.zeta,
            description="as asked (the adapter declares no other law)",
        )

    def variants(self) -> list[ContactAdapter]:
        """Configurations benchmarked separately; default: this adapter alone."""
        return [self]

    def describe(self) -> dict:
        """Code name, version and settings (goes into the JSON report)."""
        return {"name": self.name, "label": self.label}

    # -- the public, validated interface ---------------------------------------
    def impact(self, scene: AdapterScene) -> Trajectory:
        """Run one normal impact and return the validated trajectory.

        Raises
        ------
        AdapterOutputError
            The output breaks the contract (one-line reason).
        """
        out = self._impact_impl(scene)
        return trajectory_from_mapping(out, who=self.label, staggering=self.staggering)

    def sustained(self, scene: AdapterScene) -> Trajectory:
        """Run one sustained scene (two-walls) and return the validated trajectory."""
        out = self._sustained_impl(scene)
        return trajectory_from_mapping(out, who=self.label, staggering=self.staggering)

    def close(self) -> None:
        """Release resources (called once at the end of a benchmark)."""

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.label}>"
