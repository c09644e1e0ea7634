"""Reference solution of one impact under any damping law of the table (issue 18).

    m q'' + C(q) q' + U'(q) = 0,   q(0) = 0,  q'(0) = v0 > 0,

for every potential family and every law of `reference_impl.theory.laws`. The universal
law keeps its exact quadrature (`reference_impl.exact.solve.solve_impact`); this module
integrates the others (method: `reference_impl.exact._general_kernel`), compiled with
numba for sums of power laws (Hooke, Hertz, power, sum: the Taylor kernel
`_general_taylor`, else GBS) and for the other families with a term table of power
and cap rows (a single cap, sphere or ellipsoid: the Taylor kernel with the cap's
factor, `_taylor_cap`; their sums and the laws it does not cover: the GBS kernel on the
table, `_general_rows`), and in plain Python for the rest (a saturating force, an expression
without a table; ~300x slower than compiled, same method).

Both ends of contact are reported (see `LawImpactSolution`), with an error bound
that the suite checks against a 30-digit truth (`reference_impl.exact._general_law_mp`).

The linear oscillator (U' = k q and a constant C: the linear law, a power or polynomial
law of degree 0, and the viscoelastic and universal laws on Hooke's spring) is solved in
closed form instead (`_linear_solution`): integrated, its return near critical damping
passes through overlaps below any float64 tolerance (q ~ exp(-pi zeta / sqrt(1 - zeta^2))
q_max, 1e-965 at zeta = 0.999999) and its zero-force instant, heavily overdamped, is
ill-conditioned in the state (issue 29).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import asdict, dataclass
from fractions import Fraction
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.exact._general_contact import creeps_for_ever as _creeps_for_ever
from reference_impl.exact._general_contact import law_arrays as _law_arrays
from reference_impl.exact._general_fields import ERROR_SAFETY
from reference_impl.exact._general_fields import FAILED as _FAILED
from reference_impl.exact._general_fields import OK as _OK
from reference_impl.exact._general_fields import form as _form
from reference_impl.exact._general_fields import solve_formed as _solve_formed
from reference_impl.exact._general_kernel import MAX_STEPS, python_solver
from reference_impl.exact._general_rows import table_arrays
from reference_impl.exact._general_taylor import TOL as TAYLOR_TOL

# the Taylor kernel under the name _law_batch and benchmarks.bench_general_taylor import
from reference_impl.exact._general_taylor import solve as _compiled_solve  # noqa: F401
from reference_impl.exact._general_taylor import theta_for
from reference_impl.exact._law_table import fast_law
from reference_impl.exact._oneshot_cache import BoundedCache, law_key, value_key
from reference_impl.exact._rtol import checked_rtol, taylor_tol
from reference_impl.exact._taylor_cap import solve_formed as _cap_formed
from reference_impl.exact._validate import _check_exponent, _validated_top
from reference_impl.potentials._checks import positive
from reference_impl.potentials.base import Potential, SumPotential
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.laws import DampingLaw, law_from_dict

__all__ = ["ERROR_SAFETY", "LawImpactSolution", "PreparedLaw", "prepare_law", "solve_law_impact"]

_EPS = np.finfo(float).eps

_SOLVERS: dict = {}


def _python_solver():
    if "python" not in _SOLVERS:
        _SOLVERS["python"] = python_solver(_generic_fc)
    return _SOLVERS["python"]


def _generic_fc(q, full, pot, _unused, cs, es, sc):
    """(U, U', U'', C, C') of any Potential at a float q (plain Python path)."""
    arr = np.array([q])
    with np.errstate(all="ignore"):
        U = float(pot._U(arr)[0])
        dU = float(pot._dU(arr)[0])
        d2U = float(pot._d2U(arr)[0])
    C = 0.0
    dC = 0.0
    for c, e in zip(cs, es, strict=False):
        if e == 0.0:
            C += c
        else:
            C += c * q**e
            with np.errstate(all="ignore"):  # C' is infinite at q = 0 for e < 1: a sign only
                dC += c * e * np.float64(q) ** (e - 1.0)
    alpha, A, zf = sc[1], sc[2], sc[3]
    if alpha:
        C += alpha * dU
        dC += alpha * d2U
    if A:
        C += A * d2U
        # U''' only steers the search for the peak force (dF/dt = 0), whose value is
        # insensitive to its location to first order: a central difference suffices.
        hq = 1e-6 * q if q > 0 else 1e-12
        with np.errstate(all="ignore"):
            d3 = (pot._d2U(np.array([q + hq]))[0] - pot._d2U(np.array([max(q - hq, 0.0)]))[0]) / (
                q + hq - max(q - hq, 0.0)
            )
        dC += A * float(d3)
    if zf:
        if U > 0:
            r = math.sqrt(2.0 * U)
            C += zf * dU / r
            dC += zf * (d2U / r - dU * dU / r**3)
        else:  # q = 0: the limit of U'/sqrt(2U), from U ~ c q^n
            n = float(pot.leading_exponent)
            c = pot.leading_coefficient
            C += zf * (math.sqrt(2 * c) if n == 2 and c else 0.0 if n > 2 else math.inf)
    return U, dU, d2U, C, dC


@dataclass(frozen=True)
class LawImpactSolution:
    """One impact under a general damping law (SI units).

    Attributes
    ----------
    v0 : float
        Approach speed at contact onset (m/s).
    m : float
        Mass (kg; the reduced mass for two bodies).
    law : dict
        The damping law as a ``[damping]`` table.
    max_penetration : float
        Largest overlap q_max (m).
    max_force : float
        Elastic force U'(q_max) at maximum penetration (N).
    peak_force : float
        Peak total contact force max_t (U'(q) + C(q) q') (N), including the
        value C(0) v0 just after contact.
    time_of_max_penetration : float
        Time of q_max (s).
    contact_time : float
        Time to the end at q = 0 ("overlap" end) (s); inf when the body never returns.
    restitution : float
        -q'/v0 at q = 0 (overlap end); 0 when it never returns.
    contact_time_zero_force : float
        Time to the first instant after q_max where U' + C q' = 0 ("zero-force" end,
        the end of a code that clips tension) (s); equals `contact_time` when the
        force never vanishes before q = 0.
    restitution_zero_force : float
        -q'/v0 at that instant.
    returns_to_q0 : bool
        False when the body creeps back along the slow manifold of an overdamped
        law and never reaches q = 0 (see `reference_impl.exact._general_kernel`);
        only where that creep provably never ends (`_creeps_for_ever`).
    error_time : float
        Bound on the absolute error of the contact times and of the time of q_max (s).
    error_restitution : float
        Bound on the absolute error of both restitutions.
    n_steps : int
        Integration steps taken (0 for the linear oscillator, solved in closed form).
    """

    v0: float
    m: float
    law: dict
    max_penetration: float
    max_force: float
    peak_force: float
    time_of_max_penetration: float
    contact_time: float
    restitution: float
    contact_time_zero_force: float
    restitution_zero_force: float
    returns_to_q0: bool
    error_time: float
    error_restitution: float
    n_steps: int

    def to_dict(self) -> dict:
        """The scalar results as a plain dict (for JSON)."""
        return asdict(self)


# (ks, ps) or None per potential object (immutable after construction): a one-shot call
# with a new law each time still finds its potential's terms (1.6 us of ~60, issue 38).
_TERMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _power_terms(pot: Potential):
    """(ks, ps) when U' is a sum of power laws, else None (kept per potential object;
    computed each call for one that is not weak-referenceable)."""
    try:
        return _TERMS[pot]
    except KeyError:
        pass
    except TypeError:
        return _new_power_terms(pot)
    got = _TERMS[pot] = _new_power_terms(pot)
    return got


def _new_power_terms(pot: Potential):
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    if all(type(t) is PowerLaw for t in terms):
        return (
            np.array([t.k for t in terms], float),
            np.array([t.p for t in terms], float),
        )
    return None


def _linear_ratio(pot: Potential, law: DampingLaw, m: float):
    """(k, zeta^2) of a linear oscillator m q'' + c q' + k q = 0, else None.

    zeta^2 = c^2 / (4 m k) is formed exactly in rationals from the floats given (k a sum of
    Hooke terms, c the sum of the constant terms and A k or 2 zeta sqrt(m k)), so 1 - zeta^2
    is correctly rounded however close to critical damping (the float difference loses
    -log10(1 - zeta) digits: 6 at zeta = 0.999999, 1e-10 of the contact time).
    """
    # plain Python checks first: this runs before every solve (~1 us when it is not linear)
    springs = pot.terms if isinstance(pot, SumPotential) else (pot,)
    if law.alpha or not all(type(t) is PowerLaw and t.p == 1.0 for t in springs):
        return None
    terms = law.terms()
    if any(e != 0.0 for _, e in terms):
        return None
    k = sum((Fraction(float(t.k)) for t in springs), Fraction(0))
    if law.zeta:
        return float(k), Fraction(law.zeta) ** 2
    c = sum((Fraction(cj) for cj, _ in terms), Fraction(0)) + Fraction(law.A) * k
    return float(k), c * c / (4 * Fraction(m) * k)


def _linear_solution(v0: float, m: float, k: float, z2: Fraction, law: DampingLaw):
    """Closed form of m q'' + c q' + k q = 0, q(0) = 0, q'(0) = v0 (`LawImpactSolution`).

    In s = omega t (omega = sqrt(k/m)), x = omega q solves x'' + 2 zeta x' + x = 0 as in
    `reference_impl.exact._oscillator` (the same cancellation-free forms, without its
    limit on s_end: nothing is integrated here). Peak of x at s_p = atan2(wd, zeta)/wd,
    1 or log1p(zeta - 1 + r)/r, where x = v0 exp(-zeta s_p); zero force (x'' = 0) at
    2 s_p, where -x'/v0 = exp(-2 zeta s_p); return (underdamped only) at pi/wd with
    e = exp(-pi zeta/wd). The total force F = m omega (2 zeta x' + x) is stationary where
    the third derivative of x vanishes, at wd s = 3 phi - j pi (phi = atan2(wd, zeta));
    for zeta >= 1 it falls from F(0) = c v0.
    """
    z = math.sqrt(float(z2))
    om = math.sqrt(k) / math.sqrt(m)
    mo = math.sqrt(m) * math.sqrt(k)  # m omega, kg/s
    peak = 2.0 * z * mo * v0  # F(0) = c v0
    if z2 < 1:
        wd = math.sqrt(float(1 - z2))
        phi = math.atan2(wd, z)
        s_p = phi / wd
        s_end = math.pi / wd
        for j in range(3):
            th = 3.0 * phi - j * math.pi
            if 0.0 < th < math.pi:
                ez = v0 * math.exp(-z * th / wd)
                sw = math.sin(th) / wd
                peak = max(peak, mo * (2.0 * z * ez * (math.cos(th) - z * sw) + ez * sw))
    elif z2 == 1:
        s_p, s_end = 1.0, math.inf
    else:
        r = math.sqrt(float(z2 - 1))
        s_p = math.log1p(float(z2 - 1) / (z + 1.0) + r) / r  # zeta - 1 = r^2 / (zeta + 1)
        s_end = math.inf
    returns = math.isfinite(s_end)
    q_max = v0 * math.exp(-z * s_p) / om
    t_zf = 2.0 * s_p / om
    t_end = s_end / om
    # A few dozen correctly rounded operations (sqrt, atan2, log1p, exp: <= 1 ulp each) on
    # arguments that are themselves within a few ulps; exp(-a) carries a's relative error
    # times a, and a exp(-a) <= 1/e: 64 ulps of the largest time, and 64 ulps absolute of
    # the restitutions, bound both.
    err_t = 64.0 * _EPS * (t_end if returns else t_zf)
    return LawImpactSolution(
        v0=v0,
        m=m,
        law=law.to_dict(),
        max_penetration=q_max,
        max_force=k * q_max,
        peak_force=peak,
        time_of_max_penetration=s_p / om,
        contact_time=t_end,
        restitution=math.exp(-z * s_end) if returns else 0.0,
        contact_time_zero_force=t_zf,
        restitution_zero_force=math.exp(-2.0 * z * s_p),
        returns_to_q0=returns,
        error_time=err_t,
        error_restitution=64.0 * _EPS,
        n_steps=0,
    )


def _refuse_lost_return(pot: Potential, law: DampingLaw, m: float, v0: float) -> None:
    """Refuse a no-return that stopped on the overlap (_NO_RETURN_Q) where the body returns.

    The stop assumes a creep that never ends (`_creeps_for_ever`); where the tail returns
    instead, its overlap fell out of float64 reach first (a near-critical tail:
    q ~ exp(-pi zeta0 / sqrt(1 - zeta0^2)) q_max).
    """
    never, why = _creeps_for_ever(law, m, pot)
    if never:
        return
    raise UnsupportedError(
        f"solve_law_impact: the body returns (law {law.to_dict()}: {why}) but its overlap "
        f"falls below 1e-10 of q_max first, out of the integrator's reach (v0 = {v0!r} m/s)"
    )


def solve_law_impact(
    potential: Potential, m: float, v0: float, law, rtol: float | None = None
) -> LawImpactSolution:
    """Solve one impact with the damping law ``law`` (a `DampingLaw` or a table).

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Mass in kg (reduced mass), > 0.
    v0 : float
        Approach speed in m/s, > 0.
    law : DampingLaw or dict
        E.g. ``{"law": "hunt-crossley", "alpha": 0.2}`` (see `reference_impl.theory.laws`).
        The universal law is accepted too (integrated like the others; the exact
        quadrature is `solve_impact`).
    rtol : float, optional
        Relative error bound asked (0 < rtol <= 0.1); None: full accuracy, bit for bit.
        The Taylor kernel then takes longer steps (`reference_impl.exact._rtol`); the
        other paths stay at full accuracy. ``error_time`` is reported either way.

    Returns
    -------
    LawImpactSolution

    Raises
    ------
    HCVInputError
        Invalid numbers or law, a potential violating the paper's assumptions, or
        (`UnsupportedError`) an integration that did not finish within its step budget,
        or a body that returns only after its overlap fell below 1e-10 of q_max (a
        near-critical tail of a nonlinear spring), out of the integrator's reach.
    """
    return _solve_planned(_plan(potential, m, law, rtol), v0)


class _LawPlan(NamedTuple):
    """What an impact's solution needs of (potential, m, law) and not of v0: checked once.

    A NamedTuple, not a frozen dataclass: the one-shot `solve_law_impact` builds one per
    call, and a frozen dataclass's __init__ costs microseconds of that call."""

    potential: Potential
    m: float
    law: DampingLaw
    table: dict
    cs: np.ndarray
    es: np.ndarray
    sc: np.ndarray
    lin: tuple | None  # (k, zeta^2) of the linear oscillator, solved in closed form
    pk: tuple | None  # (ks, ps) of a sum of power laws, for the compiled kernels
    tab: tuple | None  # (rows, lim) of another term table, for the compiled GBS kernel
    inv: tuple | None = None  # (n, k, 1/n) of a single `PowerLaw`: its inverse inline (`_top`)


# Plans of the one-shot calls, per (potential object, m, law, rtol) (`_oneshot_cache`).
_PLANS = BoundedCache()


def _plan(potential, m, law, rtol=None) -> _LawPlan:
    """The plan of (potential, m, law, rtol), kept per exact value of the four: a one-shot
    `solve_law_impact` in a loop of speeds plans once (~1/3 of its time, issue 38). The
    potential is keyed by identity (potentials are immutable after construction, as
    `_validate._validated_top` assumes) and held by its plan, so its id is not reused while
    the entry lives; an input without an exact key is planned each call."""
    lk, mk, rk = law_key(law), value_key(m), value_key(rtol)
    if lk is None or mk is None or rk is None:
        return _new_plan(potential, m, law, rtol)
    key = (id(potential), mk, lk, rk)
    got = _PLANS.get(key)
    if got is not None and got.potential is potential:
        return got
    got = _new_plan(potential, m, law, rtol)
    _PLANS.put(key, got)
    return got


def _new_plan(potential, m, law, rtol=None) -> _LawPlan:
    # (a PowerLaw first: the abstract class's isinstance is ~1/30 of planning a new law)
    if type(potential) is not PowerLaw and not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    law = fast_law(law) or law_from_dict(law)
    m = positive("m", m, "solve_law_impact")
    rtol = checked_rtol(rtol, "solve_law_impact")
    _check_exponent(potential)
    # For an rtol, the Taylor kernel's truncation per step and its step fraction theta go
    # after the scalars it reads (`_general_taylor.SC_TOL`); without them it runs at full
    # accuracy, bit for bit.
    cs, es, sc = _law_arrays(law, m, potential, () if rtol is None else _taylor_scalars(rtol))
    lin = _linear_ratio(potential, law, m)
    pk = _power_terms(potential) if lin is None else None
    tab = table_arrays(potential) if lin is None and pk is None else None
    inv = _inline_inverse(potential)
    return _LawPlan(potential, m, law, law.to_dict(), cs, es, sc, lin, pk, tab, inv)


def _inline_inverse(potential):
    """(n, k, 1/n) of a `PowerLaw` itself (not a subclass, which may change its inverse),
    else None: `_top` then forms its turning point inline."""
    if type(potential) is not PowerLaw:
        return None
    n = potential.leading_exponent
    return n, potential.k, 1.0 / n


def _top(plan: _LawPlan, E: float) -> float:
    """`_validate._validated_top` of ``E`` (m), bit for bit, for every potential.

    For a `PowerLaw` it is ``PowerLaw._inverse`` of ``[E]`` without its layers (~3 us of a
    ~20 us prepared call, issue 38): the same float operations, (n E) / k in floats (each
    correctly rounded, as numpy's elementwise multiply and divide) and then numpy's ``**``
    on a one-element array, which is not Python's pow (numpy's vectorised power differs
    from libm's in the last bit for ~5 % of arguments on AVX-512 machines) and for 1/n =
    0.5 is numpy's sqrt. Nothing is left to check there: U' = k q^p > 0 (``check_monotone``
    is empty) and U is unbounded; a turning point that is not a positive float (overflow,
    underflow) goes the checked way, which refuses it in its one line.
    """
    inv = plan.inv
    if inv is None:
        return _validated_top(plan.potential, E)
    q = float((np.array([inv[0] * E / inv[1]]) ** inv[2])[0])
    if 0.0 < q < math.inf:
        return q
    return _validated_top(plan.potential, E)


@lru_cache(maxsize=64)
def _taylor_scalars(rtol: float) -> tuple[float, float]:
    """(truncation per step, step fraction theta) of the Taylor kernel for ``rtol`` (a
    checked float): the same numbers each call, kept (theta's fixed point is ~1.6 us)."""
    tol = taylor_tol(rtol, TAYLOR_TOL)
    return tol, theta_for(tol)


def _solve_planned(plan: _LawPlan, v0) -> LawImpactSolution:
    potential, m, law = plan.potential, plan.m, plan.law
    v0 = positive("v0", v0, "solve_law_impact")
    E = 0.5 * m * v0 * v0
    if not (math.isfinite(E) and E > 0):
        raise HCVInputError(f"kinetic energy m v0^2 / 2 = {E!r} J is not a positive float64")
    qE = _top(plan, E)
    if plan.lin is not None:
        return _linear_solution(v0, m, plan.lin[0], plan.lin[1], law)
    cs, es, sc = plan.cs, plan.es, plan.sc
    # The fields from the kernel's row (`_general_fields.form`), in the Taylor kernel's own
    # compiled call where it runs
    if plan.pk is not None:
        f = _solve_formed(v0, qE, plan.pk[0], plan.pk[1], cs, es, sc)
    elif plan.tab is not None:
        # a single cap row: the Taylor kernel (`_taylor_cap`, honours rtol); any other
        # table, or a case it hands over: the GBS kernel compiled on it (full accuracy)
        f = _cap_formed(v0, qE, plan.tab[0], plan.tab[1], cs, es, sc)
    else:
        f = _form(_python_solver()(v0, qE, potential, None, cs, es, sc), v0, qE)
    if f[0] != _OK:
        if f[0] == _FAILED:
            raise UnsupportedError(
                f"solve_law_impact: integration did not finish within {MAX_STEPS} steps "
                f"(law {law.to_dict()}, v0 = {v0!r} m/s); please report this case"
            )
        _refuse_lost_return(potential, law, m, v0)  # returns where the creep never ends
    # The frozen dataclass's __init__ sets these fields one by one through
    # object.__setattr__ (~2 us of a ~20 us call); it has no __post_init__, so filling the
    # new instance's __dict__ gives the same object (`test_general_law_fast`).
    sol = _NEW(LawImpactSolution)
    sol.__dict__.update(
        v0=v0,
        m=m,
        law=dict(plan.table),
        max_penetration=f[1],
        max_force=f[2],
        peak_force=f[3],
        time_of_max_penetration=f[4],
        contact_time=f[5],
        restitution=f[6],
        contact_time_zero_force=f[7],
        restitution_zero_force=f[8],
        returns_to_q0=f[9],
        error_time=f[10],
        error_restitution=f[11],
        n_steps=f[12],
    )
    return sol


_NEW = object.__new__


class PreparedLaw:
    """`solve_law_impact` for one (potential, m, law) and many speeds.

    The checks and the planning that do not depend on v0 (the law's table, the potential's
    exponent, the coefficient arrays of the compiled kernel, the closed-form linear case)
    are done once, here; each call solves one impact, with the same result, bit for bit,
    as ``solve_law_impact(potential, m, v0, law)``. The potential must not be changed
    after it is prepared.

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Mass in kg (reduced mass), > 0.
    law : DampingLaw or dict
        As for `solve_law_impact`.
    rtol : float, optional
        As for `solve_law_impact` (None: full accuracy).
    """

    __slots__ = ("_plan",)

    def __init__(self, potential: Potential, m: float, law, rtol: float | None = None):
        self._plan = _plan(potential, m, law, rtol)

    def __call__(self, v0: float) -> LawImpactSolution:
        """The impact at approach speed ``v0`` (m/s, > 0)."""
        return _solve_planned(self._plan, v0)

    def __repr__(self) -> str:
        p = self._plan
        return f"PreparedLaw({p.potential!r}, m={p.m!r}, law={p.table!r})"


def prepare_law(potential: Potential, m: float, law, *, rtol: float | None = None) -> PreparedLaw:
    """A solver of `solve_law_impact` for repeated speeds of one (potential, m, law).

    See `PreparedLaw`; invalid input is refused here, in one line, as by `solve_law_impact`;
    ``rtol`` as there.
    """
    return PreparedLaw(potential, m, law, rtol)
