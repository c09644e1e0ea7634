"""What counts as a failure of the critical-step search, and the bounds of its sizes.

`EnergyGrowth` (sustained scenes: a runaway, confirmed), `ImpactGain` (single
impact: an accuracy threshold), `parse_criterion` (the CLI ``--criterion``
text), `SearchGrid` (scan and refinement), and the upper bounds of every
user-controlled size (`MAX_N_STEPS`, `MAX_CONFIRM_STEPS`, `MAX_FACTOR`,
`MAX_TOL`, `MAX_N_PHASES`, `MAX_SPEEDS`, `MAX_SCAN_POINTS`,
`MAX_REFINE_POINTS`, `MAX_LANES_PER_CALL`), checked before any work. The
search itself is `reference_impl.stability.search.search_scene`, which re-exports these.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential

__all__ = [
    "KINDS",
    "FAILURE_KINDS",
    "MAX_N_STEPS",
    "MAX_CONFIRM_STEPS",
    "MAX_FACTOR",
    "MAX_TOL",
    "MAX_N_PHASES",
    "MAX_SPEEDS",
    "MAX_SCAN_POINTS",
    "MAX_REFINE_POINTS",
    "MAX_LANES_PER_CALL",
    "EnergyGrowth",
    "ImpactGain",
    "Criterion",
    "SearchGrid",
    "default_criterion",
    "parse_criterion",
]

KINDS = ("impact", "two-sided", "two-walls")
# Values of DtCritResult.failure_kind (None: no failure in the search range).
FAILURE_KINDS = ("runaway", "bounded", "accuracy", None)

# Upper bounds of the user-controlled sizes, checked before any work starts.
# Step budget of a sustained lane: 1e7 steps is ~0.3 s of one lane at the
# measured 3.5e7 lane-steps/s, 100x the default.
MAX_N_STEPS = 10_000_000
# Steps of a lane followed on to its confirmation (n_steps * confirm_horizon):
# ~3 s per lane; a search confirms a few tens of lanes.
MAX_CONFIRM_STEPS = 100_000_000
# Energy factors (factor, and factor * confirm_factor): beyond 1e12 E_0 the
# energies of a finite-precision runaway turn non-finite anyway (caught as blown).
MAX_FACTOR = 1e12
# Impact energy tolerance: a rebound with 1000x the impact energy tests nothing.
MAX_TOL = 1e3
# Onset phases per step of the single impact: 1e4 is 600x the default; the
# search time grows linearly with it (its memory does not: lanes are chunked).
MAX_N_PHASES = 10_000
# Impact speeds of one search.
MAX_SPEEDS = 1_000
# Grid points of one scan, and refinement points per round.
MAX_SCAN_POINTS = 10_000
MAX_REFINE_POINTS = 1_024
# Lanes per engine call: bounds the memory of one round (~200 B per lane).
MAX_LANES_PER_CALL = 1 << 16


def _check_int(name: str, value, lo: int, hi: int) -> None:
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
    if not ok or not lo <= value <= hi:
        raise HCVInputError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


def _check_real(name: str, value, lo: float, hi: float, lo_open: bool = False) -> None:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if (
        not ok
        or not math.isfinite(value)
        or not (value > lo if lo_open else value >= lo)
        or value > hi
    ):
        raise HCVInputError(
            f"{name} must be a finite number in {'(' if lo_open else '['}{lo:g}, "
            f"{hi:g}], got {value!r}"
        )


@dataclass(frozen=True)
class EnergyGrowth:
    """Sustained-scene criterion: a runaway is E_n > factor E_0 for some n <= n_steps, confirmed.

    A lane that crosses factor E_0 is followed on: it is a runaway only if it
    also exceeds factor * confirm_factor E_0 within confirm_horizon * n_steps
    steps (or blows up); otherwise the excursion is bounded (not an instability).

    Attributes
    ----------
    factor : float
        Energy growth factor (> 1, <= `MAX_FACTOR`), default 100.
    n_steps : int
        Step budget N (1 .. `MAX_N_STEPS`), default 1e5.
    confirm_factor : float
        Further growth that confirms a runaway (> 1; factor * confirm_factor <=
        `MAX_FACTOR`), default 1e4: the linear spring's bounded orbit, peak
        E_0 / (1 - (omega dt/2)^2), then counts as a runaway only within
        5e-7 of 2/omega.
    confirm_horizon : int
        Steps of the confirmation in units of n_steps (>= 1; n_steps *
        confirm_horizon <= `MAX_CONFIRM_STEPS`), default 10.
    """

    factor: float = 100.0
    n_steps: int = 100_000
    confirm_factor: float = 1e4
    confirm_horizon: int = 10

    def __post_init__(self):
        _check_real("EnergyGrowth factor", self.factor, 1.0, MAX_FACTOR, lo_open=True)
        _check_int("EnergyGrowth n_steps", self.n_steps, 1, MAX_N_STEPS)
        _check_real(
            "EnergyGrowth confirm_factor",
            self.confirm_factor,
            1.0,
            MAX_FACTOR / self.factor,
            lo_open=True,
        )
        _check_int(
            "EnergyGrowth confirm_horizon",
            self.confirm_horizon,
            1,
            max(1, MAX_CONFIRM_STEPS // int(self.n_steps)),
        )

    @property
    def confirm_level(self) -> float:
        """Energy (in E_0) that confirms a runaway."""
        return self.factor * self.confirm_factor

    @property
    def confirm_steps(self) -> int:
        """Step budget of a lane followed on to its confirmation."""
        return int(self.n_steps) * int(self.confirm_horizon)

    def describe(self) -> str:
        """One line saying what counts as unstable (the rule used)."""
        return (
            f"runaway: E_n > {self.factor:g} E_0 for some n <= {int(self.n_steps)}, "
            f"confirmed by E_n > {self.confirm_level:g} E_0 within {self.confirm_steps} steps "
            f"(or q > q_sup / non-finite); a crossing that stays below is bounded, "
            f"not an instability"
        )


@dataclass(frozen=True)
class ImpactGain:
    """Single-impact criterion: unstable when the rebound energy exceeds (1 + tol) E_0.

    Attributes
    ----------
    tol : float
        Allowed relative energy gain of a passive collision (0 .. `MAX_TOL`), default 0.01.
    n_phases : int
        Number (0 .. `MAX_N_PHASES`) of onset phases phi = (j + 1/2) / n_phases inside a step (the
        contact starts a fraction phi of a step after a step boundary), tried
        in addition to phi = 0; default 16. 0 tries the step boundary only.
    """

    tol: float = 0.01
    n_phases: int = 16

    def __post_init__(self):
        _check_real("ImpactGain tol", self.tol, 0.0, MAX_TOL)
        _check_int("ImpactGain n_phases", self.n_phases, 0, MAX_N_PHASES)

    def describe(self) -> str:
        """One line saying what counts as a failure (an accuracy threshold, not an instability)."""
        return (
            f"accuracy: rebound energy > (1 + {self.tol:g}) E_0 at onset phase 0 or any of "
            f"{int(self.n_phases)} phases in a step (not an instability)"
        )

    def phases(self) -> np.ndarray:
        """Onset phases (fractions of a step): 0, then the stratified ones."""
        j = np.arange(int(self.n_phases))
        return np.concatenate([[0.0], (j + 0.5) / max(int(self.n_phases), 1)])


Criterion = EnergyGrowth | ImpactGain


def default_criterion(kind: str) -> Criterion:
    """The issue's default criterion for a scene kind."""
    _check_kind(kind)
    return ImpactGain() if kind == "impact" else EnergyGrowth()


def parse_criterion(text: str, kind: str) -> Criterion:
    """Criterion from ``"key=value,key=value"`` text (for the CLI ``--criterion``).

    Keys: ``factor``, ``n_steps``, ``confirm_factor``, ``confirm_horizon``
    (sustained scenes); ``tol``, ``n_phases`` (impact). Values are decimal
    numbers (``1e5`` allowed); integer keys refuse non-integral values (1.5 is
    not truncated). Empty text or items, unknown or repeated keys, non-finite
    values and values beyond the stated bounds raise `HCVInputError` with one
    line naming the value.
    """
    _check_kind(kind)
    base = default_criterion(kind)
    if kind == "impact":
        fields = {"tol": float, "n_phases": int}
    else:
        fields = {"factor": float, "n_steps": int, "confirm_factor": float, "confirm_horizon": int}
    if not isinstance(text, str) or not text.strip():
        raise HCVInputError(f"criterion is empty; give key=value items ({', '.join(fields)})")
    kw: dict[str, Any] = {}
    for part in (s.strip() for s in text.split(",")):
        key, sep, val = part.partition("=")
        key, val = key.strip(), val.strip()
        if not sep or key not in fields:
            raise HCVInputError(
                f"criterion for {kind!r} takes {', '.join(fields)} as key=value, got {part!r}"
            )
        if key in kw:
            raise HCVInputError(f"criterion key {key!r} given twice (second value {val!r})")
        try:
            num = float(val)
        except ValueError:
            raise HCVInputError(f"criterion value {key}={val!r} is not a number") from None
        if not math.isfinite(num):
            raise HCVInputError(f"criterion value {key}={val!r} is not finite")
        if fields[key] is int:
            if num != math.floor(num):
                raise HCVInputError(f"criterion value {key}={val!r} is not an integer")
            kw[key] = int(num)
        else:
            kw[key] = num
    return type(base)(**{**asdict(base), **kw})


@dataclass(frozen=True)
class SearchGrid:
    """Grid scan and refinement of the search, in units of the reference step.

    The reference step is Delta t_safe, or `tangent_step` when Delta t_safe = 0.

    Attributes
    ----------
    lo, hi, step : float
        Uniform scan lo, lo + step, ..., hi (plus exactly 1, i.e. Delta t_safe).
    resolution : float
        Final bracket width; the issue asks for 0.1 % of Delta t_safe.
    refine_points : int
        Interior points per refinement round.
    hi_max : float
        Upward extension limit when no scanned step fails (geometric, x1.25).
    lo_min : float
        Downward extension limit when the smallest scanned step fails (x0.5).
    """

    lo: float = 0.02
    hi: float = 3.0
    step: float = 0.01
    resolution: float = 1e-3
    refine_points: int = 16
    hi_max: float = 100.0
    lo_min: float = 1e-4

    def __post_init__(self):
        _check_real("SearchGrid lo", self.lo, 0.0, 1e6, lo_open=True)
        _check_real("SearchGrid hi", self.hi, self.lo, 1e6)
        _check_real("SearchGrid step", self.step, 0.0, 1e6, lo_open=True)
        n = (self.hi - self.lo) / self.step + 1
        if n > MAX_SCAN_POINTS:
            raise HCVInputError(
                f"SearchGrid scan has {n:.6g} points, more than "
                f"{MAX_SCAN_POINTS}; widen step={self.step!r}"
            )
        # Below 1e-12 relative the bracket is below the round-off of the steps themselves.
        _check_real("SearchGrid resolution", self.resolution, 1e-12, 1.0)
        _check_int("SearchGrid refine_points", self.refine_points, 1, MAX_REFINE_POINTS)
        _check_real("SearchGrid hi_max", self.hi_max, self.hi, 1e6)
        _check_real("SearchGrid lo_min", self.lo_min, 1e-12, self.lo)

    def scan(self) -> np.ndarray:
        """The scanned steps in units of the reference step."""
        n = int(round((self.hi - self.lo) / self.step)) + 1
        return np.unique(np.concatenate([self.lo + self.step * np.arange(n), [1.0]]))


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise HCVInputError(f"scene kind must be one of {', '.join(KINDS)}; got {kind!r}")


def _validated(potential, m, velocities, kind, gap, zeta, criterion):
    """Checked (speeds, zeta, criterion) of a search, or `HCVInputError` naming the value."""
    _check_kind(kind)
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    if not (isinstance(m, (int, float)) and math.isfinite(m) and m > 0):
        raise HCVInputError(f"mass m must be a finite number > 0 (kg), got {m!r}")
    it = velocities if isinstance(velocities, Iterable) else [velocities]
    vs = [float(v) for v in itertools.islice(it, MAX_SPEEDS + 1)]
    if len(vs) > MAX_SPEEDS:
        raise HCVInputError(f"at most {MAX_SPEEDS} impact speeds per search, got more")
    if not vs or not all(math.isfinite(v) and v > 0 for v in vs):
        raise HCVInputError(f"velocities must be finite numbers > 0 (m/s), got {velocities!r}")
    if gap is not None and not (math.isfinite(gap) and gap >= 0):
        raise HCVInputError(f"gap must be a finite number >= 0 (m), got {gap!r}")
    z = 0.0 if zeta is None else float(zeta)
    if not (math.isfinite(z) and z >= 0):
        raise HCVInputError(f"damping ratio zeta must be finite and >= 0, got {zeta!r}")
    crit = default_criterion(kind) if criterion is None else criterion
    want = ImpactGain if kind == "impact" else EnergyGrowth
    if not isinstance(crit, want):
        raise HCVInputError(f"scene kind {kind!r} needs a {want.__name__} criterion, got {crit!r}")
    return vs, z, crit
