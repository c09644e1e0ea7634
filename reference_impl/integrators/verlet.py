"""Velocity-Verlet lane engine: many (time step, impact speed, phase) runs at once.

Each *lane* is one run of velocity Verlet (central difference) of one particle
of mass m against one or two contacts. The engine integrates many lanes in
one call and stops a lane as soon as it has blown up or finished; the
critical-step searches of `reference_impl.dtcrit` are built on it.

Conventions (decided here, used everywhere in the package)
-----------------------------------------------------------
* Variant: kick-drift-kick velocity Verlet with the force at the new position,

      v_{n+1/2} = v_n + dt/2 * F(y_n) / m
      y_{n+1}   = y_n + dt * v_{n+1/2}
      v_{n+1}   = v_{n+1/2} + dt/2 * F(y_{n+1}) / m,

  algebraically identical to the central difference y_{n+1} - 2 y_n + y_{n-1}
  = dt^2 F(y_n) / m. With damping the dashpot force at y_{n+1} uses the
  half-step velocity v_{n+1/2} (the usual explicit DEM treatment).
* Energy: the physical energy E_n = m v_n^2 / 2 + U(q_n) at the synchronised
  integer steps (position and velocity of the same step n).
* Geometry: ``y`` is the particle position (m). Scene IMPACT has one wall: the
  overlap is q = y where y > 0, free flight where y <= 0. Scene WALLS has two
  walls: overlap q = y - gap where y > gap (force towards -y) and q = -y where
  y < 0 (force towards +y); the two-sided oscillator U(|q|) is WALLS with
  gap = 0. The potential is evaluated only at overlaps q > 0, never at q <= 0.
* Blow-up: a lane stops as *blown* when q exceeds the potential's domain
  q_sup (e.g. 2a for the ellipsoid: the body has passed through the wall) or a
  state becomes non-finite, and as *unstable* when E_n exceeds its energy limit.
* Confirmation: a lane given ``e_confirm > e_limit`` does not stop at its first
  crossing of ``e_limit``; it runs on up to ``confirm_steps`` steps and stops as
  over-limit only if E_n also exceeds ``e_confirm``, else as *bounded* (a large
  but saturating excursion, e.g. the linear spring just below 2/omega, whose
  orbit peaks at E_0 / (1 - (omega dt / 2)^2)). Bounded lanes are not failures.
* Interrupts: the compiled kernel returns to Python every ~4e6 lane-steps and
  is resumed from saved per-lane state, so Ctrl-C (KeyboardInterrupt) gets
  through within a fraction of a second even for lanes of 1e8 steps.

Potentials of the known families (PowerLaw, Ellipsoid, Sphere,
`SaturatingForce`, and sums of them) run in one numba kernel that receives the
family parameters as arrays. A user `Expression` runs in the same kernel with
its sympy U', U compiled in (`_expression_kernel`, once per distinct expression
and process) when the batch is long enough to repay the compile; any other
`Potential`, or a short batch, runs in a numpy fallback that advances all lanes
together, one step per vectorised call of ``Potential._dU``/``_U``.
"""

from __future__ import annotations

import math
import types
from dataclasses import dataclass

import numba
import numpy as np
import sympy as sp

from ..errors import HCVInputError
from ..potentials.base import Potential, SumPotential
from ..potentials.power import PowerLaw
from ..potentials.volumetric import Ellipsoid, Sphere

__all__ = [
    "SCENE_IMPACT",
    "SCENE_WALLS",
    "STATUS_NAMES",
    "LaneBatch",
    "LaneResult",
    "SaturatingForce",
    "kernel_terms",
    "run_lanes",
]

SCENE_IMPACT = 0
SCENE_WALLS = 1

# Lane status codes (see STATUS_NAMES).
_ST_SKIPPED = 0  # not run: a smaller dt of its group already failed
_ST_COMPLETED = 1  # ran all its steps with E_n <= limit
_ST_SEPARATED = 2  # impact: left the wall (y <= 0 after contact)
_ST_OVER_LIMIT = 3  # E_n exceeded the lane's energy limit
_ST_BLOWN = 4  # q > q_sup or non-finite state
_ST_NO_SEPARATION = 5  # impact: still in contact after max_steps
_ST_END_GAIN = 6  # finished, but its last energy exceeds the lane's final limit
_ST_BOUNDED = 7  # crossed e_limit, then ran confirm_steps without exceeding e_confirm
STATUS_NAMES = (
    "skipped",
    "completed",
    "separated",
    "over-limit",
    "blown",
    "no-separation",
    "end-over-limit",
    "bounded",
)

# Kernel family codes and the row layout of the parameter array.
_FAM_POWER = 0  # (k, p, 1 / (p + 1), -)
_FAM_CAP = 1  # (c0 = pi b c / a^2, a, Kn, alpha)
_FAM_SATURATING = 2  # (F0, q_s, -, -)
_N_PAR = 4
# Below this x = q/q_s the saturating energy q_s F0 (x - atan x) is taken from
# its series, because the difference loses all digits as x -> 0.
_SAT_SERIES_X = 1e-2


class SaturatingForce(Potential):
    """Stiffening-then-softening contact, U'(q) = F0 x^2 / (1 + x^2), x = q / q_s.

    U'/sqrt(2U) vanishes at q -> 0 (U ~ x^3) and as q -> infinity (U' -> F0), so
    its supremum along a long enough path is interior: the third geometry class
    of section 6. With F0 = 1 N and q_s = 1 m this is U'(q) = q^2 / (1 + q^2).

    Parameters
    ----------
    F0 : float
        Saturation force (N, > 0).
    q_s : float
        Crossover overlap (m, > 0).
    """

    leading_exponent = 3.0

    def __init__(self, F0: float = 1.0, q_s: float = 1.0):
        if not (math.isfinite(F0) and F0 > 0 and math.isfinite(q_s) and q_s > 0):
            raise HCVInputError(
                f"SaturatingForce needs F0 > 0 and q_s > 0, got F0={F0!r}, q_s={q_s!r}"
            )
        self.F0, self.q_s = float(F0), float(q_s)
        self.q_scale = self.q_s

    def _U(self, q):
        ns = self._ns(q)
        x = q / self.q_s
        if ns is np:
            x = np.asarray(x, dtype=float)
            series = x**3 / 3 - x**5 / 5 + x**7 / 7
            with np.errstate(invalid="ignore"):
                exact = x - np.arctan(x)
            return self.F0 * self.q_s * np.where(x < _SAT_SERIES_X, series, exact)
        return self.F0 * self.q_s * (x - ns.atan(x))

    def _dU(self, q):
        x = q / self.q_s
        return self.F0 * x**2 / (1 + x**2)

    def _d2U(self, q):
        x = q / self.q_s
        return self.F0 / self.q_s * 2 * x / (1 + x**2) ** 2

    def params(self) -> dict:
        return {"F0": self.F0, "q_s": self.q_s}

    def __repr__(self) -> str:
        return f"SaturatingForce(F0={self.F0!r}, q_s={self.q_s!r})"


def kernel_terms(pot: Potential) -> tuple[np.ndarray, np.ndarray] | None:
    """Family codes and parameter rows of ``pot`` for the numba kernel.

    Returns
    -------
    (fam, par) or None
        ``fam`` int64 (n_terms,), ``par`` float64 (n_terms, 4); None when some
        term is not of a known family (the numpy fallback is then used).
    """
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    fam = np.zeros(len(terms), dtype=np.int64)
    par = np.zeros((len(terms), _N_PAR))
    for i, t in enumerate(terms):
        if type(t) is PowerLaw:
            fam[i], par[i, :3] = _FAM_POWER, (t.k, t.p, 1.0 / (t.p + 1.0))
        elif type(t) in (Ellipsoid, Sphere):  # exact types: a subclass may change the law
            fam[i] = _FAM_CAP
            par[i] = (math.pi * t._bc / t._a**2, t._a, t.Kn, t.alpha)
        elif type(t) is SaturatingForce:
            fam[i], par[i, :2] = _FAM_SATURATING, (t.F0, t.q_s)
        else:
            return None
    return fam, par


# ----------------------------------------------------------------------------
# numba kernel
# ----------------------------------------------------------------------------
@numba.njit(cache=True, inline="always")
def _force_energy(q, fam, par):
    """U'(q) (N) and U(q) (J) for q > 0, summed over the kernel terms."""
    F = 0.0
    U = 0.0
    for i in range(fam.shape[0]):
        f = fam[i]
        if f == _FAM_POWER:
            k = par[i, 0]
            p = par[i, 1]
            kqp = k * q**p
            F += kqp
            U += kqp * q * par[i, 2]
        elif f == _FAM_CAP:
            c0 = par[i, 0]
            a = par[i, 1]
            Kn = par[i, 2]
            al = par[i, 3]
            V = c0 * (a * q * q - q * q * q / 3.0)
            S = c0 * (2.0 * a * q - q * q)
            KVa = Kn * V**al
            F += KVa * S
            U += KVa * V / (al + 1.0)
        else:
            F0 = par[i, 0]
            qs = par[i, 1]
            x = q / qs
            x2 = x * x
            F += F0 * x2 / (1.0 + x2)
            if x < _SAT_SERIES_X:
                U += F0 * qs * (x2 * x / 3.0 - x2 * x2 * x / 5.0 + x2 * x2 * x2 * x / 7.0)
            else:
                U += F0 * qs * (x - math.atan(x))
    return F, U


# Lanes advanced in lockstep by the kernel: independent lanes interleaved in the
# inner loop hide the latency of pow(). Measured on the bench machine (CPU time,
# PowerLaw p = 1.37): 2.3e7 lane-steps/s one lane at a time, 3.5e7 with 8;
# 4 and 16 within 10 % of 8.
_BLOCK = 8


@numba.njit(cache=True, inline="always")
def _overlap(y, gap, scene):
    """Overlap q (m, > 0 in contact) and the sign of the contact force on y."""
    if scene == SCENE_IMPACT:
        return y, -1.0
    if y > gap:
        return y - gap, -1.0
    return -y, 1.0


# Lane-steps one call of the kernel may take before it returns to Python, where
# a pending SIGINT (Ctrl-C) is raised: ~0.1 s at the measured 3.5e7 lane-steps/s,
# while the cost of a call (~20 us) stays below 1e-3 of the work.
_CHUNK_LANE_STEPS = 1 << 22

# Columns of the per-lane state saved between kernel calls.
_FS_Y, _FS_V, _FS_F, _FS_E, _FS_E0, _FS_EM = range(6)
_IS_N, _IS_CP, _IS_TOUCHED, _IS_TRIPPED = range(4)
# Status of a lane not yet finished: not started, or started and saved.
_PENDING = -1
_RUNNING = -2


@numba.njit(cache=True)
def _kernel(
    fam,
    par,
    q_sup,
    m,
    scene,
    c_damp,
    dt,
    y0,
    v0,
    gaps,
    e_limit,
    e_confirm,
    confirm_steps,
    e_final,
    max_steps,
    group,
    order,
    skip_after_fail,
    checkpoints,
    block,
    b_start,
    budget,
    fail_dt,
    fs,
    istate,
    st,
    steps,
    emax,
    eend,
    hist,
):
    """Integrate lanes from block ``b_start`` on for about ``budget`` lane-steps.

    Lanes are taken in ``order`` in blocks of ``block`` advanced in lockstep. With
    ``skip_after_fail`` a lane whose dt is >= the smallest failing dt already
    seen in its group (``fail_dt``) is skipped, or stopped (status skipped) if
    running. The state of unfinished lanes is kept in ``fs``/``istate`` so that
    the caller can resume; returns the index (into ``order``) of the first block
    not yet finished, ``order.shape[0]`` when every lane has finished.
    """
    n_cp = checkpoints.shape[0]
    B = block
    lane = np.zeros(B, dtype=np.int64)
    act = np.zeros(B, dtype=np.bool_)
    touched = np.zeros(B, dtype=np.bool_)
    tripped = np.zeros(B, dtype=np.bool_)
    cp = np.zeros(B, dtype=np.int64)
    nB = np.zeros(B, dtype=np.int64)
    y = np.zeros(B)
    v = np.zeros(B)
    F = np.zeros(B)
    E = np.zeros(B)
    E0 = np.zeros(B)
    em = np.zeros(B)
    hB = np.zeros(B)  # per-lane constants copied next to the state
    halfB = np.zeros(B)
    gapB = np.zeros(B)
    limB = np.zeros(B)
    nmaxB = np.zeros(B, dtype=np.int64)
    work = 0
    b0 = b_start
    while b0 < order.shape[0]:
        nb = min(B, order.shape[0] - b0)
        n_act = 0
        for j in range(nb):
            ln = order[b0 + j]
            lane[j] = ln
            act[j] = False
            if st[ln] == _PENDING:
                if skip_after_fail and dt[ln] >= fail_dt[group[ln]]:
                    st[ln] = _ST_SKIPPED
                    continue
                q, sgn = _overlap(y0[ln], gaps[ln], scene)
                f0 = 0.0
                U = 0.0
                if q > 0.0:  # a lane may start in contact
                    fe, U = _force_energy(q, fam, par)
                    f0 = sgn * fe
                e0 = 0.5 * m * v0[ln] * v0[ln] + U
                fs[ln, _FS_Y] = y0[ln]
                fs[ln, _FS_V] = v0[ln]
                fs[ln, _FS_F] = f0
                fs[ln, _FS_E] = e0
                fs[ln, _FS_E0] = e0
                fs[ln, _FS_EM] = e0
                istate[ln, _IS_N] = 0
                istate[ln, _IS_CP] = 0
                istate[ln, _IS_TOUCHED] = 1 if q > 0.0 else 0
                istate[ln, _IS_TRIPPED] = 0
                st[ln] = _RUNNING
            if st[ln] != _RUNNING:
                continue
            y[j] = fs[ln, _FS_Y]
            v[j] = fs[ln, _FS_V]
            F[j] = fs[ln, _FS_F]
            E[j] = fs[ln, _FS_E]
            E0[j] = fs[ln, _FS_E0]
            em[j] = fs[ln, _FS_EM]
            nB[j] = istate[ln, _IS_N]
            cp[j] = istate[ln, _IS_CP]
            touched[j] = istate[ln, _IS_TOUCHED] != 0
            tripped[j] = istate[ln, _IS_TRIPPED] != 0
            hB[j] = dt[ln]
            halfB[j] = 0.5 * dt[ln] / m
            gapB[j] = gaps[ln]
            limB[j] = e_confirm[ln] if tripped[j] else e_limit[ln]
            nmaxB[j] = confirm_steps[ln] if tripped[j] else max_steps[ln]
            act[j] = True
            n_act += 1
        while n_act > 0 and work < budget:
            for j in range(nb):
                if not act[j]:
                    continue
                work += 1
                nB[j] += 1
                n = nB[j]
                h = hB[j]
                half = halfB[j]
                vh = v[j] + half * F[j]
                yy = y[j] + h * vh
                y[j] = yy
                q, sgn = _overlap(yy, gapB[j], scene)
                status = -1
                U = 0.0
                f = 0.0
                if q > 0.0:
                    if not q <= q_sup:  # also catches NaN
                        status = _ST_BLOWN
                    else:
                        fe, U = _force_energy(q, fam, par)
                        f = sgn * fe
                        if c_damp > 0.0 and U > 0.0:
                            f -= c_damp * fe / math.sqrt(2.0 * U) * vh
                        touched[j] = True
                if status < 0:
                    F[j] = f
                    vv = vh + half * f
                    v[j] = vv
                    e = 0.5 * m * vv * vv + U
                    if not e < math.inf:  # non-finite velocity or energy
                        status = _ST_BLOWN
                    else:
                        E[j] = e
                        if e > em[j]:
                            em[j] = e
                        while cp[j] < n_cp and checkpoints[cp[j]] <= n:
                            hist[lane[j], cp[j]] = em[j] / E0[j]
                            cp[j] += 1
                        if e > limB[j]:
                            ln = lane[j]
                            if not tripped[j] and e_confirm[ln] > e_limit[ln]:
                                # First crossing: follow the lane on to the confirmation.
                                tripped[j] = True
                                limB[j] = e_confirm[ln]
                                nmaxB[j] = confirm_steps[ln]
                                if e > limB[j]:
                                    status = _ST_OVER_LIMIT
                            else:
                                status = _ST_OVER_LIMIT
                        if status >= 0:
                            pass
                        elif scene == SCENE_IMPACT and touched[j] and yy <= 0.0:
                            status = _ST_SEPARATED
                        elif n >= nmaxB[j]:
                            if tripped[j]:
                                status = _ST_BOUNDED
                            elif scene == SCENE_IMPACT:
                                status = _ST_NO_SEPARATION
                            else:
                                status = _ST_COMPLETED
                if status < 0:
                    continue
                # The lane has finished.
                ln = lane[j]
                if (
                    status != _ST_OVER_LIMIT
                    and status != _ST_BLOWN
                    and status != _ST_BOUNDED
                    and E[j] > e_final[ln]
                ):
                    status = _ST_END_GAIN
                st[ln] = status
                steps[ln] = n
                emax[ln] = em[j]
                eend[ln] = np.nan if status == _ST_BLOWN else E[j]
                act[j] = False
                n_act -= 1
                if status == _ST_OVER_LIMIT or status == _ST_BLOWN or status == _ST_END_GAIN:
                    g = group[ln]
                    if h < fail_dt[g]:
                        fail_dt[g] = h
                    if skip_after_fail:  # stop block-mates that can no longer matter
                        for i in range(nb):
                            li = lane[i]
                            if act[i] and group[li] == g and dt[li] >= h:
                                st[li] = _ST_SKIPPED
                                steps[li] = nB[i]
                                act[i] = False
                                n_act -= 1
        if n_act > 0:  # out of budget: save the running lanes and return
            for j in range(nb):
                if act[j]:
                    ln = lane[j]
                    fs[ln, _FS_Y] = y[j]
                    fs[ln, _FS_V] = v[j]
                    fs[ln, _FS_F] = F[j]
                    fs[ln, _FS_E] = E[j]
                    fs[ln, _FS_EM] = em[j]
                    istate[ln, _IS_N] = nB[j]
                    istate[ln, _IS_CP] = cp[j]
                    istate[ln, _IS_TOUCHED] = 1 if touched[j] else 0
                    istate[ln, _IS_TRIPPED] = 1 if tripped[j] else 0
            return b0
        b0 += B
    return b0


# ----------------------------------------------------------------------------
# public interface
# ----------------------------------------------------------------------------
@dataclass
class LaneBatch:
    """The lanes of one engine call (all arrays have one entry per lane).

    Attributes
    ----------
    dt : ndarray
        Time step (s).
    y0, v0 : ndarray
        Start position (m, see the module conventions) and velocity (m/s).
    e_limit : ndarray
        Energy (J) above which the lane stops as over-limit; ``inf`` for none.
    max_steps : ndarray of int
        Step budget of the lane (>= 1).
    gap : ndarray or float
        Free-flight gap between the walls of `SCENE_WALLS` (m, >= 0; 0 is the
        two-sided oscillator U(|q|)); ignored by `SCENE_IMPACT`. Default 0.
    e_final : ndarray or float
        Energy (J) that the last E_n of a lane which ran to its end (or
        separated) must not exceed, else the lane ends as end-over-limit
        (the single-impact criterion); default ``inf`` (none).
    group : ndarray of int, optional
        Group index (>= 0) for ``skip_after_fail``; default all 0.
    e_confirm : ndarray or float, optional
        Confirmation energy (J, >= e_limit); default ``e_limit`` (the lane stops
        at its first crossing of e_limit). See the module conventions.
    confirm_steps : ndarray of int, optional
        Step budget (>= max_steps) of a lane that crossed e_limit while being
        confirmed; default ``max_steps``.
    """

    dt: np.ndarray
    y0: np.ndarray
    v0: np.ndarray
    e_limit: np.ndarray
    max_steps: np.ndarray
    gap: np.ndarray | float = 0.0
    e_final: np.ndarray | float = math.inf
    group: np.ndarray | None = None
    e_confirm: np.ndarray | float | None = None
    confirm_steps: np.ndarray | int | None = None

    def __post_init__(self):
        n = np.asarray(self.dt).shape[0]
        self.dt = np.ascontiguousarray(self.dt, dtype=np.float64)
        self.y0 = np.ascontiguousarray(np.broadcast_to(self.y0, (n,)), dtype=np.float64)
        self.v0 = np.ascontiguousarray(np.broadcast_to(self.v0, (n,)), dtype=np.float64)
        self.gap = np.ascontiguousarray(np.broadcast_to(self.gap, (n,)), dtype=np.float64)
        self.e_limit = np.ascontiguousarray(np.broadcast_to(self.e_limit, (n,)), dtype=np.float64)
        self.e_final = np.ascontiguousarray(np.broadcast_to(self.e_final, (n,)), dtype=np.float64)
        self.max_steps = np.ascontiguousarray(np.broadcast_to(self.max_steps, (n,)), dtype=np.int64)
        g = np.zeros(n, dtype=np.int64) if self.group is None else self.group
        self.group = np.ascontiguousarray(np.broadcast_to(g, (n,)), dtype=np.int64)
        ec = self.e_limit if self.e_confirm is None else self.e_confirm
        self.e_confirm = np.ascontiguousarray(np.broadcast_to(ec, (n,)), dtype=np.float64)
        cs = self.max_steps if self.confirm_steps is None else self.confirm_steps
        self.confirm_steps = np.ascontiguousarray(np.broadcast_to(cs, (n,)), dtype=np.int64)
        if np.any(~(self.dt > 0)) or np.any(~np.isfinite(self.dt)):
            raise HCVInputError("every lane time step must be finite and > 0")
        if np.any(self.max_steps < 1):
            raise HCVInputError("every lane needs max_steps >= 1")
        if np.any(~(self.gap >= 0)) or np.any(~np.isfinite(self.gap)):
            raise HCVInputError("every lane gap must be finite and >= 0")
        if np.any(~(self.e_confirm >= self.e_limit)):
            raise HCVInputError("every lane needs e_confirm >= e_limit")
        if np.any(self.confirm_steps < self.max_steps):
            raise HCVInputError("every lane needs confirm_steps >= max_steps")

    def __len__(self) -> int:
        return self.dt.shape[0]


@dataclass
class LaneResult:
    """Per-lane outcome of `run_lanes`.

    Attributes
    ----------
    status : ndarray of int
        Index into `STATUS_NAMES`.
    steps : ndarray of int
        Steps taken before the lane stopped.
    e_max : ndarray
        Largest E_n seen (J), including E_0.
    e_end : ndarray
        E_n at the last step taken (J); for a separated impact the rebound energy.
    hist : ndarray, shape (n_lanes, n_checkpoints)
        max_{k <= c} E_k / E_0 at each checkpoint step c; NaN if not reached.
    engine : str
        "numba" or "numpy".
    """

    status: np.ndarray
    steps: np.ndarray
    e_max: np.ndarray
    e_end: np.ndarray
    hist: np.ndarray
    engine: str

    @property
    def failed(self) -> np.ndarray:
        """True for lanes that went over an energy limit or blew up."""
        return np.isin(self.status, (_ST_OVER_LIMIT, _ST_BLOWN, _ST_END_GAIN))

    @property
    def bounded(self) -> np.ndarray:
        """True for lanes that crossed e_limit but stayed below e_confirm (not failures)."""
        return self.status == _ST_BOUNDED

    @property
    def ran(self) -> np.ndarray:
        """True for lanes that were integrated (not skipped)."""
        return self.status != _ST_SKIPPED


def run_lanes(
    pot: Potential,
    m: float,
    scene: int,
    batch: LaneBatch,
    *,
    zeta: float = 0.0,
    checkpoints=None,
    skip_after_fail: bool = False,
    engine: str = "auto",
    block: int = _BLOCK,
) -> LaneResult:
    """Run velocity Verlet on every lane of ``batch``.

    Parameters
    ----------
    pot : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Particle mass (kg).
    scene : int
        `SCENE_IMPACT` (one wall at y = 0) or `SCENE_WALLS` (walls at y = 0 and
        y = gap of each lane).
    batch : LaneBatch
        The lanes.
    zeta : float
        Damping ratio of the universal law C(q) = 2 zeta sqrt(m) U'/sqrt(2U)
        (dimensionless, >= 0); 0 for the conservative contact.
    checkpoints : array_like of int, optional
        Increasing step numbers at which max E / E_0 is recorded.
    skip_after_fail : bool
        Process lanes by increasing dt within each group and skip those at or
        above a dt that already failed (searches need only the first failure).
    engine : {"auto", "numba", "numpy"}
        "auto" uses numba for known families, and for an `Expression` when the
        batch is long enough to repay compiling its kernel; numpy otherwise.
        "numba" compiles an Expression's kernel whatever the batch.
    block : int
        Lanes the numba kernel advances in lockstep (results do not depend on it).

    Returns
    -------
    LaneResult
    """
    if scene not in (SCENE_IMPACT, SCENE_WALLS):
        raise HCVInputError(f"unknown scene code {scene!r}")
    if not (math.isfinite(zeta) and zeta >= 0):
        raise HCVInputError(f"damping ratio zeta must be finite and >= 0, got {zeta!r}")
    cps = np.ascontiguousarray(
        np.unique(np.asarray([] if checkpoints is None else checkpoints, dtype=np.int64))
    )
    if engine not in ("auto", "numba", "numpy"):
        raise HCVInputError(f"engine must be 'auto', 'numba' or 'numpy', got {engine!r}")
    terms, kern = kernel_terms(pot), _kernel
    if terms is None and (engine == "numba" or (engine == "auto" and _worth_compiling(batch))):
        kern = _expression_kernel(pot)
        if kern is not None:
            terms = (np.zeros(1, dtype=np.int64), np.zeros((1, _N_PAR)))
    if engine == "auto":
        engine = "numpy" if terms is None else "numba"
    if engine == "numba" and terms is None:
        raise HCVInputError(f"no numba kernel for {pot!r}; use engine='numpy'")
    n = len(batch)
    order = np.lexsort((batch.dt, batch.group)).astype(np.int64)
    c_damp = 2.0 * zeta * math.sqrt(m)
    q_sup = float(pot.q_sup)
    if engine == "numba":
        st = np.zeros(n, dtype=np.int64)
        steps = np.zeros(n, dtype=np.int64)
        emax = np.full(n, np.nan)
        eend = np.full(n, np.nan)
        hist = np.full((n, cps.shape[0]), np.nan)
        st[:] = _PENDING
        fail_dt = np.full(int(batch.group.max()) + 1 if n else 1, np.inf)
        fs = np.zeros((n, 6))
        istate = np.zeros((n, 4), dtype=np.int64)
        b = 0
        while b < n:  # each call returns within _CHUNK_LANE_STEPS, so Ctrl-C gets through
            b = kern(
                terms[0],
                terms[1],
                q_sup,
                float(m),
                int(scene),
                c_damp,
                batch.dt,
                batch.y0,
                batch.v0,
                batch.gap,
                batch.e_limit,
                batch.e_confirm,
                batch.confirm_steps,
                batch.e_final,
                batch.max_steps,
                batch.group,
                order,
                bool(skip_after_fail),
                cps,
                int(block),
                b,
                _CHUNK_LANE_STEPS,
                fail_dt,
                fs,
                istate,
                st,
                steps,
                emax,
                eend,
                hist,
            )
        return LaneResult(st, steps, emax, eend, hist, "numba")
    return _run_numpy(pot, float(m), scene, batch, c_damp, q_sup, cps, skip_after_fail)


# Compiled kernels of user expressions, keyed by the sympy form of (U', U):
# compiling costs a few seconds, so each distinct expression is compiled once per
# process; None records a form numba cannot compile (the numpy engine runs it).
_EXPR_KERNELS: dict = {}
# Distinct expressions kept compiled at once (each kernel holds ~1 MB of code).
_EXPR_KERNELS_MAX = 16


# Compile an expression's kernel under engine="auto" only when the numpy engine
# would take longer than the compile (~5 s, more on a loaded machine): the numpy
# engine pays ~1e-4 s per step whatever the lane count, and ~1e-6 s per lane-step.
_COMPILE_MIN_STEPS = 50_000
_COMPILE_MIN_LANE_STEPS = 10_000_000


def _worth_compiling(batch: LaneBatch) -> bool:
    """True when the batch's step budget makes the numpy engine slower than a compile."""
    if len(batch) == 0:
        return False
    budget = np.maximum(batch.max_steps, batch.confirm_steps)
    return int(budget.max()) >= _COMPILE_MIN_STEPS or float(budget.sum()) >= _COMPILE_MIN_LANE_STEPS


def _expression_kernel(pot: Potential):
    """The lane kernel with U'(q), U(q) of an `Expression` compiled in; None if not possible.

    U' and U come from the expression's sympy tree (parameters substituted),
    printed by ``sympy.lambdify`` as math-module code and compiled with
    ``numba.njit`` (numpy error model: inf/nan instead of exceptions); the
    kernel is the same function as `_kernel` with this force in place of
    `_force_energy`. No user text is evaluated: only what sympy prints from the
    parsed, whitelisted tree, as for the numpy engine.
    """
    from ..potentials.expression import Expression

    if type(pot) is not Expression:  # exact type: a subclass may change the law
        return None
    key = sp.srepr((pot.dexpr, pot.expr))
    if key in _EXPR_KERNELS:
        return _EXPR_KERNELS[key]
    try:
        qs = [x for x in (pot.expr.free_symbols | pot.dexpr.free_symbols) if x.name == "q"]
        q = qs[0] if qs else sp.Symbol("q", real=True)
        fn = numba.njit(error_model="numpy")(sp.lambdify(q, (pot.dexpr, pot.expr), modules="math"))

        @numba.njit(inline="always", error_model="numpy")
        def force_energy(x, fam, par):
            a, b = fn(x)
            return float(a), float(b)

        src = _kernel.py_func
        env = dict(src.__globals__, _force_energy=force_energy)
        kern = numba.njit(types.FunctionType(src.__code__, env, "_kernel_expression"))
        _probe(kern, pot)
    except Exception:  # noqa: BLE001 -- any compile failure: the numpy engine runs it
        kern = None
    while len(_EXPR_KERNELS) >= _EXPR_KERNELS_MAX:
        _EXPR_KERNELS.pop(next(iter(_EXPR_KERNELS)))
    _EXPR_KERNELS[key] = kern
    return kern


def _probe(kern, pot: Potential) -> None:
    """Compile ``kern`` now (one lane, one step), so that a failure shows here."""
    one = np.ones(1)
    i1 = np.ones(1, dtype=np.int64)
    st = np.full(1, _PENDING, dtype=np.int64)
    kern(
        np.zeros(1, dtype=np.int64),
        np.zeros((1, _N_PAR)),
        float(pot.q_sup),
        1.0,
        SCENE_WALLS,
        0.0,
        one * 1e-3,
        one * 0.0,
        one,
        one * 0.0,
        one * np.inf,
        one * np.inf,
        i1,
        one * np.inf,
        i1,
        i1 * 0,
        i1 * 0,
        False,
        np.zeros(0, dtype=np.int64),
        1,
        0,
        10,
        np.full(1, np.inf),
        np.zeros((1, 6)),
        np.zeros((1, 4), dtype=np.int64),
        st,
        np.zeros(1, dtype=np.int64),
        np.zeros(1),
        np.zeros(1),
        np.zeros((1, 0)),
    )


# How often (in steps) the numpy engine compacts its active lanes and applies
# skip_after_fail: compaction costs a few array copies, so not every step.
_NUMPY_COMPACT_EVERY = 32


def _numpy_force(pot, y, scene, gap, q_sup):
    """Signed elastic force, U'(q), U(q) and blown mask for positions y (numpy)."""
    if scene == SCENE_IMPACT:
        q, sgn = y, -1.0
    else:
        right = y > gap
        q = np.where(right, y - gap, -y)
        sgn = np.where(right, -1.0, 1.0)
    with np.errstate(invalid="ignore"):
        contact = q > 0
        blown = ~np.isfinite(q) | (contact & ~(q <= q_sup))
    ok = contact & ~blown
    fe = np.zeros_like(y)
    U = np.zeros_like(y)
    if np.any(ok):
        qc = q[ok]
        fe[ok] = pot._dU(qc)
        U[ok] = pot._U(qc)
    return sgn * fe, fe, U, ok, blown


def _run_numpy(pot, m, scene, batch, c_damp, q_sup, cps, skip_after_fail):
    n = len(batch)
    st = np.full(n, _ST_COMPLETED, dtype=np.int64)
    steps = np.zeros(n, dtype=np.int64)
    emax = np.full(n, np.nan)
    eend = np.full(n, np.nan)
    hist = np.full((n, cps.shape[0]), np.nan)
    idx = np.arange(n)
    h = batch.dt.copy()
    y = batch.y0.copy()
    v = batch.v0.copy()
    gap = batch.gap.copy()
    F, _, U, contact, _ = _numpy_force(pot, y, scene, gap, q_sup)
    E0 = 0.5 * m * v * v + U
    em = E0.copy()
    E = E0.copy()
    touched = contact.copy()
    lim = batch.e_limit.copy()
    econf = batch.e_confirm.copy()
    nconf = batch.confirm_steps.copy()
    tripped = np.zeros(n, dtype=bool)
    efin = batch.e_final.copy()
    nmax = batch.max_steps.copy()
    grp = batch.group.copy()
    active = np.ones(n, dtype=bool)
    fail_dt = np.full(int(grp.max()) + 1 if n else 1, np.inf)
    step = 0
    while idx.size:
        step += 1
        vh = v + 0.5 * h / m * F
        y = y + h * vh
        F, fe, U, contact, blown = _numpy_force(pot, y, scene, gap, q_sup)
        if c_damp > 0:
            with np.errstate(divide="ignore", invalid="ignore"):
                damp = np.where(contact & (U > 0), c_damp * fe / np.sqrt(2 * U), 0.0)
            F = F - damp * vh
        v = vh + 0.5 * h / m * F
        E = 0.5 * m * v * v + U
        touched |= contact
        blown |= ~np.isfinite(E)
        # Blown lanes keep the energy of their last finite step, as in the kernel.
        em = np.where(blown, em, np.maximum(em, E))
        for j in np.nonzero(cps == step)[0]:
            hist[idx, j] = em / E0
        over = ~blown & (E > lim)
        trip = over & ~tripped & (econf > lim)  # first crossing: follow on to the confirmation
        if np.any(trip):
            tripped |= trip
            lim = np.where(trip, econf, lim)
            nmax = np.where(trip, nconf, nmax)
            over = ~blown & (E > lim)
        sep = ~blown & ~over & touched & (y <= 0) if scene == SCENE_IMPACT else np.zeros_like(over)
        out_of_steps = step >= nmax
        done = blown | over | sep | out_of_steps
        code = np.where(
            blown,
            _ST_BLOWN,
            np.where(
                over,
                _ST_OVER_LIMIT,
                np.where(
                    sep,
                    _ST_SEPARATED,
                    np.where(
                        tripped,
                        _ST_BOUNDED,
                        _ST_NO_SEPARATION if scene == SCENE_IMPACT else _ST_COMPLETED,
                    ),
                ),
            ),
        )
        end_gain = ~blown & ~over & ~(tripped & out_of_steps & ~sep) & (E > efin)
        code = np.where(end_gain, _ST_END_GAIN, code)
        if np.any(done):
            d = idx[done]
            st[d] = code[done]
            steps[d] = step
            emax[d] = em[done]
            eend[d] = np.where(blown[done], np.nan, E[done])
            failed = done & (blown | over | end_gain)
            if np.any(failed):
                np.minimum.at(fail_dt, grp[failed], h[failed])
            active[done] = False
        if skip_after_fail and (np.any(done) or step % _NUMPY_COMPACT_EVERY == 0):
            late = active & (h >= fail_dt[grp])
            st[idx[late]] = _ST_SKIPPED
            active &= ~late
        if not np.all(active):
            keep = active
            idx, h, y, v, gap, F, E0, em, touched, lim, efin, nmax, grp, econf, nconf, tripped = (
                a[keep]
                for a in (
                    idx,
                    h,
                    y,
                    v,
                    gap,
                    F,
                    E0,
                    em,
                    touched,
                    lim,
                    efin,
                    nmax,
                    grp,
                    econf,
                    nconf,
                    tripped,
                )
            )
            active = np.ones(idx.size, dtype=bool)
    return LaneResult(st, steps, emax, eend, hist, "numpy")
