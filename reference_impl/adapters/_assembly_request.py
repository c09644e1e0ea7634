"""The assembly request of the adapter contract (item 14 in `reference_impl.adapters.base`).

A chain scene handed to a code: spheres of one radius on the x axis, each touching its
neighbours at the start (the contacts at their onset, overlap 0), fixed walls at none, the
right or both ends, no gravity, the scene's initial velocities along x. The code runs it at
one step for a number of steps and returns the bodies' positions and velocities after every
step (`ChainRun`); the suite computes the energy from them with the scene's own law and
decides a runaway with its own criterion, so nothing of the decision is the code's.

Geometry (SI units): body i (0-based, left to right) starts at x_i = R + 2 R i; the left
wall (``walls = "both"``) is the plane x = 0, the right wall (``"one"``, ``"both"``) the
plane x = 2 R N. Every contact, sphere-sphere and sphere-wall, has the scene's normal law
U(q), q its overlap; a code whose wall contact differs from its sphere contact (Hertz:
R_eff = R on a wall, R/2 between spheres) gives its walls a material that makes them equal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from reference_impl.adapters._records import AdapterOutputError
from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential

__all__ = ["ChainRequest", "ChainRun", "chain_energy", "chain_run_from_mapping"]

_WALLS = ("none", "one", "both")
# Steps of one code run: a code prints every step (~10 numbers per body), so 1e6 steps of
# five bodies is ~100 MB of text; the searches run a few thousand.
MAX_CODE_STEPS = 1_000_000


@dataclass(frozen=True)
class ChainRequest:
    """A chain of spheres on the x axis for a contact code (contract item 14). SI units.

    Attributes
    ----------
    name : str
        The scene's name.
    potential : Potential
        The normal law U(q) of every contact (a code maps it to its own inputs).
    masses : tuple of float
        Body masses (kg), left to right.
    radius : float
        Sphere radius R (m); the bodies start 2 R apart, touching.
    walls : str
        ``"none"``, ``"one"`` (the plane x = 2 R N) or ``"both"`` (and x = 0).
    velocities : tuple of float
        Initial velocity of each body along x (m/s).
    dt : float
        The time step (s).
    n_steps : int
        Steps to run (the code returns n_steps + 1 samples, the first the start).
    stop_energy : float
        The code may end the run after the first step whose kinetic energy exceeds this
        (J; that sample included): the suite has decided a runaway by then (its
        confirmation level). Infinite: run every step.
    """

    name: str
    potential: Potential
    masses: tuple
    radius: float
    walls: str
    velocities: tuple
    dt: float
    n_steps: int
    stop_energy: float = math.inf

    def __post_init__(self):
        n = len(self.masses)
        if n < 1 or len(self.velocities) != n:
            raise HCVInputError(
                f"chain request {self.name!r}: {n} masses and {len(self.velocities)} velocities; "
                "give one of each per body (>= 1)"
            )
        if not all(math.isfinite(m) and m > 0 for m in self.masses):
            raise HCVInputError(f"chain request {self.name!r}: masses must be > 0 (kg)")
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise HCVInputError(f"chain request {self.name!r}: radius must be > 0 (m), "
                                f"got {self.radius!r}")  # fmt: skip
        if self.walls not in _WALLS:
            raise HCVInputError(f"chain request {self.name!r}: walls {self.walls!r} is not one "
                                f"of {', '.join(map(repr, _WALLS))}")  # fmt: skip
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise HCVInputError(f"chain request {self.name!r}: dt must be > 0 (s), "
                                f"got {self.dt!r}")  # fmt: skip
        steps = self.n_steps
        if (
            isinstance(steps, bool)
            or not isinstance(steps, int)
            or not 1 <= steps <= MAX_CODE_STEPS
        ):
            raise HCVInputError(f"chain request {self.name!r}: n_steps must be an integer in "
                                f"[1, {MAX_CODE_STEPS}], got {steps!r}")  # fmt: skip

    def stop_kinetic(self, cap: float) -> float:
        """The kinetic energy (J) at which a code stops: `stop_energy`, and at most ``cap``
        times the initial kinetic energy (a code's own bound on a runaway's run)."""
        m = np.asarray(self.masses, dtype=float)
        ke0 = 0.5 * float(np.sum(m * np.asarray(self.velocities, dtype=float) ** 2))
        return min(self.stop_energy, cap * ke0)

    @property
    def n_bodies(self) -> int:
        """Number of bodies N."""
        return len(self.masses)

    def x0(self) -> np.ndarray:
        """Initial positions x_i = R + 2 R i (m)."""
        return self.radius * (1.0 + 2.0 * np.arange(self.n_bodies))

    def wall_planes(self) -> list[tuple[float, int]]:
        """(x of the plane (m), side: -1 left, +1 right) of each wall."""
        out = [(0.0, -1)] if self.walls == "both" else []
        if self.walls in ("one", "both"):
            out.append((2.0 * self.radius * self.n_bodies, 1))
        return out


@dataclass
class ChainRun:
    """What a code returns for a `ChainRequest`: the state after every step. SI units.

    Attributes
    ----------
    x, v : numpy.ndarray
        Positions (m) and velocities (m/s) along x, shape (samples, N); sample 0 is the
        start, sample n the state after step n. A run that blew up may hold inf/NaN (a
        result) or stop early (the code could not go on: ``meta["stopped"]`` says why).
    meta : dict
        Code, version, inputs written; ``v_staggering`` 0.5 when v[n] is the velocity at
        t[n] - dt/2 (leapfrog), else 0.
    """

    x: np.ndarray
    v: np.ndarray
    meta: dict = field(default_factory=dict)


def _checked_states(out, run_type: type, kind: str, sample: tuple, n_steps: int, who: str):
    """The x, v arrays and meta of what a code returned for an assembly request, checked.

    One check for both assembly runs (`ChainRun`, and `LatticeRun` of
    `reference_impl.adapters._lattice_request`), so that a chain and a lattice refuse a
    malformed return with the same words.

    Parameters
    ----------
    out : object
        What the code returned: an instance of ``run_type``, or a mapping with ``x``, ``v``
        and optionally ``meta``.
    run_type : type
        The run class the contract names (`ChainRun` or `LatticeRun`).
    kind : str
        ``"chain"`` or ``"lattice"``, for the message.
    sample : tuple of int
        The shape of one sample: ``(N,)`` for a chain (x along the axis, m), ``(N, 3)`` for
        a lattice (m).
    n_steps : int
        Steps of the request: at most n_steps + 1 samples, at least 2 (the start and one step).
    who : str
        The code's label, first in every message.

    Returns
    -------
    x, v : numpy.ndarray
        Positions (m) and velocities (m/s) as floats, shape (samples, *sample).
    meta : dict
        A copy of the code's meta (empty when it gave none).

    Raises
    ------
    AdapterOutputError
        One line: a missing key, a wrong shape, more samples than steps + 1.
    """
    if isinstance(out, run_type):
        x, v, meta = out.x, out.v, out.meta
    elif isinstance(out, dict) and "x" in out and "v" in out:
        x, v, meta = out["x"], out["v"], out.get("meta", {})
    else:
        raise AdapterOutputError(f"{who}: a {kind} run must return a {run_type.__name__} or "
                                 f"x, v; got {type(out).__name__}")  # fmt: skip
    try:
        x = np.asarray(x, dtype=float)
        v = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise AdapterOutputError(f"{who}: {kind} x and v must be arrays of numbers") from None
    if x.ndim != 1 + len(sample) or x.shape[1:] != tuple(sample) or v.shape != x.shape:
        want = ", ".join(["samples", *map(str, sample)])
        raise AdapterOutputError(f"{who}: {kind} x and v must have shape ({want}), "
                                 f"got {x.shape} and {v.shape}")  # fmt: skip
    if not 2 <= x.shape[0] <= n_steps + 1:
        raise AdapterOutputError(f"{who}: {kind} run of {n_steps} steps returned "
                                 f"{x.shape[0]} samples (2 to {n_steps + 1})")  # fmt: skip
    return x, v, dict(meta)


def chain_run_from_mapping(out, req: ChainRequest, who: str) -> ChainRun:
    """Check what a code returned for ``req`` (a `ChainRun` or a mapping with x, v, meta).

    Raises
    ------
    AdapterOutputError
        One line: a missing key, a wrong shape, more samples than steps + 1.
    """
    x, v, meta = _checked_states(out, ChainRun, "chain", (req.n_bodies,), req.n_steps, who)
    return ChainRun(x, v, meta)


def chain_energy(req: ChainRequest, run: ChainRun) -> np.ndarray:
    """Kinetic plus elastic energy (J) of each sample, with the scene's own law U(q).

    The overlaps come from the positions (2 R - (x_{i+1} - x_i) between spheres, R minus
    the distance to a wall's plane); only q > 0 is a contact. A leapfrog code's velocities
    are half a step off the positions: the kinetic energy is then that of the half step,
    which differs from the on-step one by O(dt) of the energy, far below the factor 100 of
    a runaway. NaN where a sample is not finite.
    """
    x, v = run.x, run.v
    m = np.asarray(req.masses, dtype=float)
    R = req.radius
    ke = 0.5 * np.sum(m[None, :] * v * v, axis=1)
    qs = [2.0 * R - np.diff(x, axis=1)] if req.n_bodies > 1 else []
    for plane, side in req.wall_planes():
        body = x[:, 0] if side < 0 else x[:, -1]
        qs.append((R - side * (plane - body))[:, None])
    with np.errstate(all="ignore"):
        if qs:
            q = np.concatenate(qs, axis=1)
            u = np.where(q > 0, req.potential._U(np.maximum(q, 0.0)), 0.0)
            e = ke + np.sum(u, axis=1)
        else:
            e = ke
    bad = ~(np.all(np.isfinite(x), axis=1) & np.all(np.isfinite(v), axis=1))
    e = np.where(bad | ~np.isfinite(e), np.nan, e)
    return e
