"""The generic route: one impact under any damping law C(q, q') (issue 37, item 1).

    m q'' + C(q, q') q' + U'(q) = 0,   q(0) = 0,  q'(0) = v0 > 0,

for a registered law whose C is not of the general-law solver's form (a law with route
"generic", `reference_impl.theory.laws.LawFamily.C`, e.g. C nonlinear in q'). Plain
Python, no compiled kernel: scipy's DOP853 (order 8) in the scaled variables
x = q / q_E, y = q' / v0, tau = t v0 / q_E, with events at q' = 0 (maximum penetration),
U' + C q' = 0 after it (the zero-force end) and q = 0 (the end), run twice, at
`RTOL_FINE` and at `RTOL_COARSE`. The fine run is reported; its error bound is
`ERROR_SAFETY` times the difference of the two runs (the coarse run's error, an
estimate of the fine one's from above: DOP853 is of order 8, so a tolerance 1e2 times
smaller leaves an error ~1e2 times smaller) plus round-off. It is an estimate, not a
proof: the suite checks it against a closed form and the general-law solver
(`verification/test_laws_registry.py`). ~1000x slower than the general-law solver
(Hunt-Crossley on Hertz: ~160 ms against ~0.2 ms, 43 steps); the error ~1e-12 (4e-12 on
that e), its estimated bound ~1e-8 (3e-8 there; the general-law solver's: ~1e-14).
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError, UnsupportedError
from reference_impl.exact._validate import _check_exponent, _validated_top
from reference_impl.potentials._checks import positive
from reference_impl.potentials.base import Potential
from reference_impl.theory.laws import DampingLaw, law_from_dict

__all__ = [
    "ERROR_SAFETY",
    "PreparedGeneric",
    "RTOL_COARSE",
    "RTOL_FINE",
    "solve_generic_batch",
    "solve_generic_law",
]

# Relative tolerances of the two DOP853 runs (absolute ones: the same, on the scaled
# variables of order 1). 1e-12 is near the floor where DOP853's step control still gains
# (round-off of ~100 operations a step, ~1e-14 a step over hundreds of steps).
RTOL_FINE = 1e-12
RTOL_COARSE = 1e-10
# The bound is this multiple of the two runs' difference: the difference is the coarse
# run's error (the fine one's is ~1e2 times smaller), and 10 covers a difference that
# happens to be small where the errors do not cancel the same way at every output.
ERROR_SAFETY = 10.0
# Round-off of the reported values, in units of eps of the value: the sums of a few
# hundred steps of ~100 operations, each within an ulp.
_ROUND_ULPS = 1e3
# Longest contact followed, in units of the elastic time q_E / v0: a return later than
# this is refused as unsupported (this route cannot prove a creep never ends).
_TAU_MAX = 1e4
_EPS = float(np.finfo(float).eps)


def _run(pot, m: float, v0: float, qE: float, fam, params: dict, rtol: float) -> dict:
    """One DOP853 run; the instants and states of the events (scaled, then SI)."""
    from scipy.integrate import solve_ivp

    ts = qE / v0  # s per unit tau

    def force(x, y):
        q = np.array([max(x, 0.0) * qE])
        w = np.array([y * v0])
        C = float(np.asarray(fam.C(params, pot, m, q, w))[0])
        return float(pot._dU(q)[0]), C

    def rhs(_tau, s):
        dU, C = force(s[0], s[1])
        # dy/dtau = (q_E / v0^2) w' = -(q_E / (m v0^2)) (U' + C w)
        return [s[1], -qE / (m * v0 * v0) * (dU + C * s[1] * v0)]

    def peak(_tau, s):
        return s[1]

    peak.direction = -1.0

    def zero_force(_tau, s):
        dU, C = force(s[0], s[1])
        return dU + C * s[1] * v0

    zero_force.direction = -1.0

    def end(_tau, s):
        return s[0]

    end.terminal = True
    end.direction = -1.0
    sol = solve_ivp(
        rhs,
        (0.0, _TAU_MAX),
        [0.0, 1.0],
        method="DOP853",
        rtol=rtol,
        atol=rtol,
        events=(peak, zero_force, end),
        dense_output=True,
    )
    if sol.status == -1:
        raise UnsupportedError(f"generic law route: DOP853 failed ({sol.message}) at v0 = {v0!r}")
    t_pk = sol.t_events[0]
    if not len(t_pk):
        raise UnsupportedError(
            f"generic law route: no maximum penetration within {_TAU_MAX:g} elastic times "
            f"(v0 = {v0!r} m/s)"
        )
    tp, xp = float(t_pk[0]), float(sol.y_events[0][0][0])
    returns = len(sol.t_events[2]) > 0
    if not returns:
        raise UnsupportedError(
            f"generic law route: the body has not returned to q = 0 within {_TAU_MAX:g} "
            f"elastic times q_E / v0 = {_TAU_MAX * ts:.6g} s (v0 = {v0!r} m/s); this route "
            "cannot tell a late return from none"
        )
    t_end, y_end = float(sol.t_events[2][0]), float(sol.y_events[2][0][1])
    zf = [(t, y[1]) for t, y in zip(sol.t_events[1], sol.y_events[1], strict=True) if t > tp]
    t_zf, y_zf = zf[0] if zf else (t_end, y_end)
    # Peak of the total force U' + C q': sampled on the dense output (an estimate; its
    # first sample is the value C(0, v0) v0 just after contact).
    grid = np.linspace(0.0, t_end, 2001)
    states = sol.sol(grid)
    f_peak = max(
        (lambda f: f[0] + f[1] * y * v0)(force(x, y)) for x, y in zip(*states, strict=True)
    )
    return {
        "t_peak": tp * ts,
        "q_max": xp * qE,
        "t_end": t_end * ts,
        "e": -y_end,
        "t_zf": t_zf * ts,
        "e_zf": -float(y_zf),
        "peak_force": f_peak,
        "n_steps": int(sol.t.size - 1),
    }


def _checked(potential, m, v0, law) -> tuple[Potential, float, float, float, DampingLaw]:
    if not isinstance(potential, Potential):
        raise HCVInputError(f"potential must be a Potential, got {potential!r}")
    law = law_from_dict(law)
    m = positive("m", m, "solve_generic_law")
    v0 = positive("v0", v0, "solve_generic_law")
    _check_exponent(potential)
    E = 0.5 * m * v0 * v0
    if not (math.isfinite(E) and E > 0):
        raise HCVInputError(f"kinetic energy m v0^2 / 2 = {E!r} J is not a positive float64")
    return potential, m, v0, _validated_top(potential, E), law


def solve_generic_law(potential: Potential, m: float, v0: float, law):
    """Solve one impact under any registered law by the generic route (module docstring).

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Mass in kg (reduced mass), > 0.
    v0 : float
        Approach speed in m/s, > 0.
    law : DampingLaw or dict
        A registered law; its ``C(q, q')`` is integrated (any route's law is accepted).

    Returns
    -------
    reference_impl.exact.general_law.LawImpactSolution
        ``error_time`` (s) and ``error_restitution`` are the estimated bounds above.

    Raises
    ------
    HCVInputError
        Invalid numbers or law, a potential violating the paper's assumptions.
    UnsupportedError
        No return within `_TAU_MAX` elastic times, or the integrator failed.
    """
    from reference_impl.exact.general_law import LawImpactSolution

    pot, m, v0, qE, law = _checked(potential, m, v0, law)
    fam = law.family
    fine = _run(pot, m, v0, qE, fam, law.params, RTOL_FINE)
    coarse = _run(pot, m, v0, qE, fam, law.params, RTOL_COARSE)

    def bound(*keys) -> float:
        return max(
            ERROR_SAFETY * abs(fine[k] - coarse[k]) + _ROUND_ULPS * _EPS * abs(fine[k])
            for k in keys
        )

    return LawImpactSolution(
        v0=v0,
        m=m,
        law=law.to_dict(),
        max_penetration=fine["q_max"],
        max_force=float(pot._dU(np.array([fine["q_max"]]))[0]),
        peak_force=fine["peak_force"],
        time_of_max_penetration=fine["t_peak"],
        contact_time=fine["t_end"],
        restitution=fine["e"],
        contact_time_zero_force=fine["t_zf"],
        restitution_zero_force=fine["e_zf"],
        returns_to_q0=True,
        error_time=bound("t_end", "t_zf", "t_peak"),
        error_restitution=bound("e", "e_zf"),
        n_steps=fine["n_steps"],
    )


class PreparedGeneric:
    """`solve_generic_law` for one (potential, m, law) and many speeds, checked once."""

    __slots__ = ("_law", "_m", "_potential")

    def __init__(self, potential: Potential, m: float, law):
        if not isinstance(potential, Potential):
            raise HCVInputError(f"potential must be a Potential, got {potential!r}")
        self._potential = potential
        self._m = positive("m", m, "prepare")
        self._law = law_from_dict(law)
        _check_exponent(potential)

    def __call__(self, v0: float):
        """The impact at approach speed ``v0`` (m/s, > 0)."""
        return solve_generic_law(self._potential, self._m, v0, self._law)

    def __repr__(self) -> str:
        return f"prepare({self._potential!r}, {self._m!r}, law={self._law.to_dict()!r})"


def solve_generic_batch(potential, m: float, v0s, law, batch_max: int) -> dict[str, np.ndarray]:
    """Every speed of ``v0s`` by `solve_generic_law`, one after another: arrays of the
    fields of `reference_impl.exact._law_batch.LAW_FIELDS`, of the shape of ``v0s``."""
    from reference_impl.exact._law_batch import LAW_FIELDS
    from reference_impl.potentials._checks import real_array

    v = real_array("v0s", v0s, "solve_impacts")
    if v.size > batch_max:
        raise HCVInputError(f"{v.size} impacts requested, more than BATCH_MAX = {batch_max}")
    solver = PreparedGeneric(potential, m, law)
    out = {k: np.empty(v.shape) for k in LAW_FIELDS}
    for i in np.ndindex(v.shape):
        sol = solver(float(v[i]))
        for k in LAW_FIELDS:
            out[k][i] = float(getattr(sol, k))
    return out
