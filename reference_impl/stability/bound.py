"""The section 6 time-step bound Delta t_safe and the geometry class.

Delta t_safe = 2 sqrt(m) / max_{[0, q_max]} U'(q) / sqrt(2 U(q)): the paper's
claim is that velocity Verlet is stable for any Delta t <= Delta t_safe. This
module only evaluates the bound; whether it holds is measured in `dtcrit`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials._checks import positive, show
from reference_impl.potentials.base import Potential

__all__ = [
    "SafeStep",
    "dt_safe",
    "dt_safe_shortcut",
    "geometry_class",
    "stiffening_indicator",
]

# Grid on which the supremum is located before a bounded scalar refinement; the
# log part resolves q -> 0, where softening contacts take their supremum.
_SUP_GRID_LIN = 801
_SUP_GRID_LOG = 200
# Location tolerance of the bounded refinement, relative to q_max: the ratio is
# flat at its maximum, so a q error of 1e-10 q_max changes it by ~1e-20.
_SUP_XATOL = 1e-10
# Smallest normal float64 (below it values have lost relative precision).
_TINY = float(np.finfo(float).tiny)
# Relative band within which 2UU'' - U'^2 counts as zero (round-off of the
# products, a few ulps times the size of U'^2).
_INDICATOR_RTOL = 1e-10


def _ratio_at_zero(pot: Potential) -> float:
    """lim_{q -> 0+} U'(q) / sqrt(2 U(q)) from the leading term U ~ c q^n (N / sqrt(J)).

    U'/sqrt(2U) ~ n sqrt(c / 2) q^(n/2 - 1): infinite for n < 2, 0 for n > 2
    and sqrt(2 c) = sqrt(U''(0)) for n = 2. The case is decided by the exact
    leading exponent, never by a float evaluation near 0.
    """
    n = pot.leading_exponent
    if n < 2:
        return math.inf
    if n > 2:
        return 0.0
    c = pot.leading_coefficient
    if c is not None:
        return math.sqrt(2.0 * c)
    return math.sqrt(float(pot._d2U(np.array([0.0]))[0]))


def _ratio(pot: Potential, q: np.ndarray) -> np.ndarray:
    """U'(q) / sqrt(2 U(q)) (N / sqrt(J)); the limit value is used at q = 0.

    Where U underflows to 0 or below the normal range at q > 0 the leading-term limit stands in (the
    ratio there is within round-off of its limit for n = 2 and negligible
    against the supremum for n > 2; for n < 2 the supremum is infinite anyway).
    """
    q = np.asarray(q, dtype=float)
    U = pot._U(q)
    dU = pot._dU(q)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = dU / np.sqrt(2 * U)
    # A subnormal U has lost relative precision (m = 1e-300 made the supremum 15 %
    # too high, issue 22): there, as where U underflows, the limit stands in.
    return np.where(U >= _TINY, r, _ratio_at_zero(pot))


def stiffening_indicator(pot: Potential, q) -> np.ndarray:
    """Relative sign function (2 U U'' - U'^2) / U'^2 (section 6).

    Positive where U'/sqrt(2U) increases (stiffening), negative where it decreases.
    """
    q = np.atleast_1d(np.asarray(q, dtype=float))
    U, dU, d2U = pot._U(q), pot._dU(q), pot._d2U(q)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (2 * U * d2U - dU**2) / dU**2


def geometry_class(pot: Potential, q_max: float) -> str:
    """'stiffening', 'softening', 'linear' or 'mixed' on (0, q_max] from 2UU'' - U'^2."""
    q = q_max * np.concatenate(
        [np.logspace(-8, 0, _SUP_GRID_LOG), np.linspace(0, 1, _SUP_GRID_LIN)[1:]]
    )
    s = stiffening_indicator(pot, q)
    s = s[np.isfinite(s)]
    pos, neg = np.any(s > _INDICATOR_RTOL), np.any(s < -_INDICATOR_RTOL)
    if pos and neg:
        return "mixed"
    if pos:
        return "stiffening"
    if neg:
        return "softening"
    return "linear"


@dataclass(frozen=True)
class SafeStep:
    """Result of `dt_safe`.

    Attributes
    ----------
    dt_safe : float
        2 sqrt(m) / sup U'/sqrt(2U) over [0, q_max] (s); 0 when the supremum is infinite.
    q_star : float
        Overlap at which the supremum is attained (m).
    dt_shortcut : float
        The endpoint formula 2 m v0 / U'(q_max) (s).
    geometry : str
        Geometry class on (0, q_max].
    interior : bool
        True when the supremum lies strictly inside (0, q_max).
    """

    dt_safe: float
    q_star: float
    dt_shortcut: float
    geometry: str
    interior: bool


def dt_safe_shortcut(pot: Potential, m: float, v0: float, q_max: float | None = None) -> float:
    """Endpoint shortcut 2 m v0 / U'(q_max) of section 6, item 1 (s)."""
    if q_max is None:
        q_max = pot.turning_point(0.5 * m * v0 * v0)
    return 2.0 * m * v0 / float(pot._dU(np.array([q_max]))[0])


def _energy(m: float, v0: float, owner: str) -> float:
    """m v0^2 / 2 (J), refused when it is not a positive float64."""
    E = 0.5 * m * v0 * v0
    if not (math.isfinite(E) and E >= _TINY):
        raise HCVInputError(
            f"{owner}: kinetic energy m v0^2 / 2 = {E!r} J (m = {m!r}, v0 = {v0!r}) is not a "
            "positive float64 in the normal range; rescale the units (e.g. mm, g, ms)"
        )
    return E


def dt_safe(pot: Potential, m: float, v0: float) -> SafeStep:
    """Delta t_safe as the supremum over the whole path [0, q_max] (section 6).

    Parameters
    ----------
    pot : Potential
        Contact potential.
    m : float
        Mass (kg).
    v0 : float
        Impact speed (m/s); E = m v0^2 / 2 fixes q_max.
    """
    if not isinstance(pot, Potential):
        raise HCVInputError(f"dt_safe: potential must be a Potential, got {show(pot)}")
    m = positive("m", m, "dt_safe")
    v0 = positive("v0", v0, "dt_safe")
    q_max = pot.turning_point(_energy(m, v0, "dt_safe"))
    grid = q_max * np.concatenate(
        [np.logspace(-12, 0, _SUP_GRID_LOG), np.linspace(0, 1, _SUP_GRID_LIN)]
    )
    grid = np.unique(grid)
    r = _ratio(pot, grid)
    i = int(np.argmax(r))
    q_star, r_star = float(grid[i]), float(r[i])
    geometry = geometry_class(pot, q_max)
    # Where the ratio rises to q_max (stiffening or linear on the whole grid: section 6,
    # U'/sqrt(2U) grows where 2UU'' - U'^2 > 0) its supremum is the endpoint the grid
    # holds; the refinement could only land inside [grid[-2], q_max], below it. Skipping
    # it saves importing scipy.optimize (0.1 s) in every new process (issue 20).
    at_end = i == len(grid) - 1 and geometry in ("stiffening", "linear")
    if math.isfinite(r_star) and 0 < i and not at_end:
        # Refine the maximum between its grid neighbours (at the last point the
        # bracket is [previous point, q_max], so an interior maximum just below
        # q_max is not mistaken for the endpoint).
        from scipy.optimize import minimize_scalar  # here: 0.1 s to import; mixed geometry only

        res = minimize_scalar(
            lambda q: -float(_ratio(pot, np.array([q]))[0]),
            bounds=(grid[i - 1], grid[min(i + 1, len(grid) - 1)]),
            method="bounded",
            options={"xatol": _SUP_XATOL * q_max},
        )
        if -res.fun > r_star:
            q_star, r_star = float(res.x), float(-res.fun)
    dt = 0.0 if not math.isfinite(r_star) else 2.0 * math.sqrt(m) / r_star
    interior = 0 < q_star < q_max * (1 - 1e-9)
    return SafeStep(
        dt_safe=dt,
        q_star=q_star,
        dt_shortcut=dt_safe_shortcut(pot, m, v0, q_max),
        geometry=geometry,
        interior=interior,
    )
