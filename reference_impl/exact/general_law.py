"""Reference solution of one impact under any damping law of the table (issue 18).

    m q'' + C(q) q' + U'(q) = 0,   q(0) = 0,  q'(0) = v0 > 0,

for every potential family and every law of `reference_impl.theory.laws`. The universal
law keeps its exact quadrature (`reference_impl.exact.solve.solve_impact`); this module
integrates the others (method: `reference_impl.exact._general_kernel`), compiled with
numba for sums of power laws (Hooke, Hertz, power, sum) and in plain Python for
the other families (sphere, ellipsoid, expression; ~100x slower, same method).

Both ends of contact are reported (see `LawImpactSolution`), with an error bound
that the suite checks against a 30-digit truth (`reference_impl.exact._general_law_mp`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.exact._general_kernel import MAX_STEPS, OUT_FIELDS, python_solver
from reference_impl.exact._general_kernel import solve as _compiled_solve
from reference_impl.exact._validate import _check_exponent, _validated_top
from reference_impl.potentials._checks import positive
from reference_impl.potentials.base import Potential, SumPotential
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.laws import DampingLaw, law_from_dict

__all__ = ["LawImpactSolution", "solve_law_impact", "ERROR_SAFETY"]

# The bound reported is this multiple of the summed local error estimates (each the
# difference of the order-16 and order-14 extrapolants, itself an over-estimate of the
# order-16 error taken), plus round-off: a few hundred operations per step at 1 ulp.
ERROR_SAFETY = 10.0
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
        law and never reaches q = 0 (see `reference_impl.exact._general_kernel`).
    error_time : float
        Bound on the absolute error of the contact times and of the time of q_max (s).
    error_restitution : float
        Bound on the absolute error of both restitutions.
    n_steps : int
        Integration steps taken.
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


def _power_terms(pot: Potential):
    """(ks, ps) when U' is a sum of power laws, else None."""
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    if all(type(t) is PowerLaw for t in terms):
        return (
            np.array([t.k for t in terms], float),
            np.array([t.p for t in terms], float),
        )
    return None


def _law_arrays(law: DampingLaw, m: float, pot: Potential):
    terms = law.terms()
    cs = np.array([c for c, _ in terms], float)
    es = np.array([e for _, e in terms], float)
    zf = 2.0 * law.zeta * math.sqrt(m)
    n = float(pot.leading_exponent)
    # Leading exponent a of C ~ q^a at contact: a creeping return takes int C / U' dq,
    # finite only for a > n - 2 (see _general_kernel).
    leads = [e for c, e in terms if c > 0]
    if law.alpha:
        leads.append(n - 1.0)
    if law.A:
        leads.append(n - 2.0)
    if law.zeta:
        leads.append(n / 2.0 - 1.0)
    creeps = 1.0 if leads and min(leads) <= n - 2.0 + 1e-12 else 0.0
    # C q' outweighs U' as q -> 0 (a < n - 1): the force pulls just before q = 0.
    pulls = 1.0 if leads and min(leads) < n - 1.0 - 1e-12 else 0.0
    sc = np.array([m, law.alpha, law.A, zf, creeps, pulls], float)
    if law.A and n < 2.0:
        raise HCVInputError(
            f"damping law 'viscoelastic' needs U'' finite at contact (leading exponent n >= 2, "
            f"force exponent p >= 1); got n = {n:.6g}, where C = A U'' is infinite at q = 0"
        )
    return cs, es, sc


def solve_law_impact(potential: Potential, m: float, v0: float, law) -> LawImpactSolution:
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

    Returns
    -------
    LawImpactSolution

    Raises
    ------
    HCVInputError
        Invalid numbers or law, a potential violating the paper's assumptions, or
        an integration that did not finish within its step budget.
    """
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    law = law_from_dict(law)
    m = positive("m", m, "solve_law_impact")
    v0 = positive("v0", v0, "solve_law_impact")
    E = 0.5 * m * v0 * v0
    if not (math.isfinite(E) and E > 0):
        raise HCVInputError(f"kinetic energy m v0^2 / 2 = {E!r} J is not a positive float64")

    _check_exponent(potential)
    qE = _validated_top(potential, E)
    cs, es, sc = _law_arrays(law, m, potential)
    pk = _power_terms(potential)
    if pk is not None:
        out = _compiled_solve(v0, qE, pk[0], pk[1], cs, es, sc)
    else:
        out = _python_solver()(v0, qE, potential, None, cs, es, sc)
    r = dict(zip(OUT_FIELDS, out.tolist(), strict=False))
    if r["status"] != 0.0 or not math.isfinite(r["q_max"]):
        raise UnsupportedError(
            f"solve_law_impact: integration did not finish within {MAX_STEPS} steps "
            f"(law {law.to_dict()}, v0 = {v0!r} m/s); please report this case"
        )
    returns = r["returns"] == 1.0
    nst = int(r["n_steps"])
    t_scale = qE / v0
    t_end = r["t_end"] if returns else math.inf
    err_t = ERROR_SAFETY * r["err_t"] * t_scale + 100 * nst * _EPS * (
        t_end if returns else r["t_zf"] if math.isfinite(r["t_zf"]) else t_scale
    )
    err_w = ERROR_SAFETY * r["err_w"] + 100 * nst * _EPS
    return LawImpactSolution(
        v0=v0,
        m=m,
        law=law.to_dict(),
        max_penetration=r["q_max"],
        max_force=r["max_force"],
        peak_force=r["peak_force"],
        time_of_max_penetration=r["t_peak"],
        contact_time=t_end,
        restitution=-r["w_end"] / v0 if returns else 0.0,
        contact_time_zero_force=r["t_zf"],
        restitution_zero_force=-r["w_zf"] / v0,
        returns_to_q0=returns,
        error_time=err_t,
        error_restitution=err_w,
        n_steps=nst,
    )
