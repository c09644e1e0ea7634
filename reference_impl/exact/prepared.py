"""Repeated impacts of one potential and mass: `prepare(potential, m)` (issue 27, goal 2).

`solve_impact` checks its potential and mass, plans its path and assembles its
result in Python around ~5-15 us of compiled work, on every call. A prepared
solver does the checks and the planning once (the compiled entry, its constants
packed in arrays); each call then makes one compiled call (`_prepared_kernel`):

* a power law (the Gauss-Jacobi path of `_branches`): `power_call`, the oscillator,
  the branch sums (`_gj_sums`, the same compiled loop), the peak and the bound and
  range checks of `solve_impact`;
* the other compiled families: `family_call`, the oscillator, the family's
  Gauss-Jacobi kernel of `_one_call` (the first call `solve_impact`'s `fused`
  strategy makes) and, when it refuses, the first tanh-sinh rung of the fused
  strategy, the restitutions, the conditioning charge (`_one_call.conditioning_at`,
  the function `solve_impact` calls), the sums and the bound and range checks, in that
  one compiled call. When that rung would be climbed past (or anything else refuses),
  the fused kernel (`_one_call.fused_impact`: the whole tanh-sinh ladder) runs as in
  `solve_impact`. Per speed, the validated turning point and the split decision are kept.

The result is built from a dict (`ImpactSolution._fast`); its oscillator is kept as
(wd, s_peak, s_end) and built on first use (`ImpactSolution.__getattr__`), with the
attributes `VirtualOscillator(v0, zeta)` has. Every call returns exactly what
`solve_impact(potential, m, v0, zeta)` returns, bit for bit (the same operations in
the same order; held by verification/test_exact_prepared.py over every family).
Whatever the fast paths do not cover (zeta >= 0.9, the split and general paths, a
bound or range refusal, bad input) is passed to `solve_impact` itself, which solves
it or raises its one-line error.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact._branches import _GJ_ZETA_MAX, per_potential
from reference_impl.exact._one_call import _OK, _is_cap, _plan, curvature, fused_impact
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._power_kernel import power_constants
from reference_impl.exact._prepared_kernel import family_call, family_constants, power_call
from reference_impl.exact._route import prepare_other, route
from reference_impl.exact._rtol import checked_rtol, power_rungs
from reference_impl.exact._split import _INFO, _split_info, needs_split
from reference_impl.exact._strategies import turning_point
from reference_impl.exact._validate import _TOPS_KEPT, _check_exponent, _validated_top
from reference_impl.exact.solve import (
    _TINY,
    RTOL_STATED,
    ImpactSolution,
    _charged,
    _conditioning_at,
    solve_impact,
)
from reference_impl.potentials._checks import is_real_number, positive
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

__all__ = ["PreparedAt", "PreparedImpact", "prepare"]

_INF = math.inf


class PreparedImpact:
    """`solve_impact` for one potential and mass, checked and planned once (`prepare`).

    Calling it with (v0, zeta) returns `solve_impact(potential, m, v0, zeta)`.
    """

    __slots__ = (
        "potential",
        "m",
        "_c",
        "_u",
        "_W",
        "_e_checked",
        "_plan",
        "_split",
        "_family",
        "_args",
        "_tops",
        "_rtol",
    )

    def __init__(self, potential: Potential, m: float, rtol: float | None = None):
        if not isinstance(potential, Potential):
            raise HCVInputError(f"potential must be a Potential, got {potential!r}")
        self.potential = potential
        self.m = positive("m", m, "prepare")
        self._rtol = checked_rtol(rtol, "prepare")
        _check_exponent(potential)
        self._c = self._u = self._W = self._family = self._args = None
        # Per speed: (its validated turning point, whether the split path takes it), as
        # `_validated_top` and `needs_split` answer them (both are functions of the speed
        # alone for one potential and mass), bounded as `_validate._TOPS_KEPT`.
        self._tops = {}
        # Largest energy whose turning point this power law has had validated.
        self._e_checked = 0.0
        # The other compiled families: their plan of `_one_call` (None: no compiled form),
        # and whether a sum's terms can hand over inside a contact (`_split`).
        self._plan = None if type(potential) is PowerLaw else _plan(potential)
        self._split = per_potential(_INFO, _split_info, potential) is not None
        if type(potential) is PowerLaw:
            # With rtol, the first rule pair `solve_impact` tries for it (`_rtol`), kept
            # when its bounds are within rtol; a refusal goes to solve_impact, which climbs.
            rungs = () if self._rtol is None else power_rungs(self._rtol)
            if rungs:
                consts, stated = (
                    power_constants(potential, self.m, rungs[0], self._rtol),
                    self._rtol,
                )
            else:
                consts, stated = power_constants(potential, self.m), RTOL_STATED
            if consts is not None:
                c_m, b_hi, b_lo, self._u, self._W, *rest = consts
                self._c = np.array([c_m, b_hi, b_lo, *rest, stated, _TINY])
        elif self._plan is not None and not (
            self._rtol is not None and _is_cap(self._plan.kernel.P)
        ):
            # (A cap with rtol runs `_fused`, which takes its Gauss-Jacobi pair at rtol as
            # `solve_impact` does; the compiled call knows only full accuracy.)
            self._family = family_call(self._plan)
            if self._family is not None:
                # A 1-tuple: the compiled call's arguments after (v0, zeta, q_top).
                self._args = (family_constants(self.m, self._plan, RTOL_STATED, _TINY),)

    def __repr__(self) -> str:
        if self._rtol is not None:
            return f"prepare({self.potential!r}, {self.m!r}, rtol={self._rtol!r})"
        return f"prepare({self.potential!r}, {self.m!r})"

    def __call__(self, v0: float, zeta: float = 0.0) -> ImpactSolution:
        """The impact at speed v0 (m/s) and damping ratio zeta, as `solve_impact`."""
        pot, m = self.potential, self.m
        if type(v0) is not float or type(zeta) is not float:
            if not (is_real_number(v0) and is_real_number(zeta)):
                return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
            # numpy scalars and ints as `solve_impact`'s checks take them (float(value)).
            try:
                v0, zeta = float(v0), float(zeta)
            except OverflowError:
                return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        if not (0.0 < v0 < _INF and 0.0 <= zeta < _GJ_ZETA_MAX):
            return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        E = 0.5 * m * v0 * v0
        if not (E >= _TINY and E < _INF):
            return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        if self._c is not None:
            # A power law: its kernel does not use q_top, and an energy at most one
            # already validated passes `_validated_top` unchanged (no error, no new entry).
            if E > self._e_checked:
                _validated_top(pot, E)  # raises as solve_impact would
                self._e_checked = E
            out = power_call(v0, zeta, self._c, self._u, self._W)
            if out[12] != 1.0:  # a check refused: solve_impact raises it (or solves otherwise)
                return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
            return _solution(v0, m, zeta, pot, out)
        got = self._tops.get(v0)
        if got is None:
            q_top = _validated_top(pot, E)  # raises as solve_impact would
            off = self._plan is None or (
                self._split and needs_split(pot, lambda: turning_point(pot, m, v0, q_top), q_top)
            )
            if len(self._tops) >= _TOPS_KEPT:
                # The oldest entry (another thread may have popped it already).
                self._tops.pop(next(iter(self._tops), None), None)
            got = self._tops[v0] = (q_top, off)
        q_top, off = got
        if off:
            return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        if self._family is not None:
            out = self._family(v0, zeta, q_top, *self._args)
            ok = out[12]
            if ok == 1.0:
                return _solution(v0, m, zeta, pot, out)
            if ok != 0.0:  # a bound or range check refused: solve_impact raises it
                return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        return self._fused(v0, zeta, q_top)

    def _family_result(self, v0: float, zeta: float, v: tuple) -> ImpactSolution:
        """`solve_impact`'s result from the Python ladder's branches (`_fused`; what the
        family kernel does itself after its rules; conditioning charged as by
        `solve._charge_conditioning`; any bound or range refusal goes to `solve_impact`,
        which raises it)."""
        pot, m = self.potential, self.m
        (
            _,
            rise,
            e_rise,
            mid,
            e_mid,
            fall,
            e_fall,
            q_max,
            f_max,
            wd,
            sp,
            s_end,
            rest,
            rest_zf,
            d2,
        ) = v
        cond = _conditioning_at(m, v0, zeta, sp, d2, f_max)
        if cond > 0.0:
            rise, e_rise, mid, e_mid, fall, e_fall = _charged(
                cond, rise, e_rise, mid, e_mid, fall, e_fall
            )
        t, e, t_zf, e_zf = rise + fall, e_rise + e_fall, rise + mid, e_rise + e_mid
        # `_check_bound` (both times are finite below zeta = 1) and `_check_normal`.
        stated = RTOL_STATED if self._rtol is None else max(self._rtol, RTOL_STATED)
        if not (
            e <= stated * t
            and e_zf <= stated * t_zf
            and t < _INF
            and t_zf < _INF
            and q_max >= _TINY
            and f_max >= _TINY
            and t >= _TINY
        ):
            return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        return _solution(
            v0, m, zeta, pot, (q_max, f_max, t, rest, t_zf, rest_zf, e, e_zf, rise, wd, sp, s_end)
        )

    def _fused(self, v0: float, zeta: float, q_top: float) -> ImpactSolution:
        """The fused kernel of `_one_call` (Gauss-Jacobi refused or absent: the tanh-sinh
        ladder), as `solve_impact`'s `fused` strategy, then `_family_result`."""
        pot, m = self.potential, self.m
        osc = VirtualOscillator(v0, zeta)
        fast = fused_impact(pot, m, osc, q_top, self._rtol)
        if fast is None:
            return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        br, q_max, f_max = fast
        d2 = curvature(pot, q_max)  # what `solve._conditioning` charges from
        if d2 is None:  # no compiled evaluator: solve_impact's numpy U''
            return solve_impact(pot, m, v0, zeta, rtol=self._rtol)
        return self._family_result(
            v0,
            zeta,
            (
                _OK,
                *br,
                q_max,
                f_max,
                osc.wd,
                osc.s_peak,
                osc.s_end,
                math.exp(-math.pi * zeta / osc.wd),
                osc.restitution_zero_force if zeta > 0 else 1.0,
                d2,
            ),
        )


def _solution(v0, m, zeta, pot, out):
    """The `ImpactSolution` of a prepared call's floats, in the order both compiled calls
    (`power_call`, `family_call`) return them: q_max, f_max, t, rest, t_zf, rest_zf, e,
    e_zf, t_peak, wd, s_peak, s_end (then their status, not read here). The oscillator is
    built from (wd, s_peak, s_end) on first use."""
    q_max, f_max, t, rest, t_zf, rest_zf, e, e_zf, t_peak, wd, sp, s_end = out[:12]
    osc_of = (wd, sp, s_end)
    return ImpactSolution._fast(
        {
            "v0": v0,
            "m": m,
            "zeta": zeta,
            "max_penetration": q_max,
            "max_force": f_max,
            "contact_time": t,
            "restitution": rest,
            "contact_time_zero_force": t_zf,
            "restitution_zero_force": rest_zf,
            "quadrature_error": e,
            "quadrature_error_zero_force": e_zf,
            "potential": pot,
            "_osc_of": osc_of,
            "_t_peak": t_peak,
        }
    )


def prepare(potential: Potential, m: float, *, law=None, rtol: float | None = None):
    """A solver of many impacts of ``potential`` and mass ``m``: ``prepare(pot, m)(v0, zeta)``
    equals ``solve_impact(pot, m, v0, zeta)`` bit for bit, with the potential checked and
    the path planned once (see the module docstring); ``prepare(pot, m, law=L)(v0)``
    equals ``solve_impact(pot, m, v0, law=L)`` (the strategy chosen once, `_route`).

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Mass (kg), > 0.
    law : DampingLaw or dict, optional
        A registered damping law; the solver then takes the speed alone.
    rtol : float, optional
        Relative error bound asked of each time, as `solve_impact`'s (None: full
        accuracy); each call then equals ``solve_impact(..., rtol=rtol)`` bit for bit.

    Returns
    -------
    PreparedImpact, or with ``law`` a callable ``(v0) -> solution``
        `PreparedImpact` (or `PreparedAt` for a law the harmonic map solves), or the
        prepared solver of the law's strategy (`reference_impl.exact.general_law.PreparedLaw`).

    Raises
    ------
    HCVInputError
        As `solve_impact` for the potential, the mass and the law, at once.
    """
    if law is None:
        return PreparedImpact(potential, m, rtol)
    r = route(law, 0.0)
    if r.kind == "harmonic map":
        return PreparedAt(PreparedImpact(potential, m, rtol), r.zeta)
    return prepare_other(r, potential, m, checked_rtol(rtol, "prepare"))


class PreparedAt:
    """A `PreparedImpact` at one damping ratio: ``(v0) -> solve_impact(pot, m, v0, zeta)``."""

    __slots__ = ("_prepared", "zeta")

    def __init__(self, prepared: PreparedImpact, zeta: float):
        self._prepared = prepared
        self.zeta = zeta

    def __call__(self, v0: float) -> ImpactSolution:
        """The impact at approach speed ``v0`` (m/s, > 0)."""
        return self._prepared(v0, self.zeta)

    def __repr__(self) -> str:
        p = self._prepared
        return (
            f"prepare({p.potential!r}, {p.m!r}, law={{'law': 'universal', 'zeta': {self.zeta!r}}})"
        )
