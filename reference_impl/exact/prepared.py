"""Repeated impacts of one potential and mass: `prepare(potential, m)` (issue 27, goal 2).

`solve_impact` checks its potential and mass, plans its path and assembles its
result in Python around ~5-10 us of compiled work, on every call. A prepared
solver does the checks and the planning once; each call then

* for a power law (the Gauss-Jacobi path of `_branches`), makes one compiled call
  (`_power_kernel.power_impact`) that computes the oscillator, the branch sums (`_gj_sums`,
  the same compiled loop), the peak and the checks of `solve_impact`, and builds
  the `ImpactSolution` from its output;
* for the other compiled families, calls the fused kernel of `_one_call` directly
  (the same call `solve_impact` makes), without re-checking the potential.

Every call returns exactly what `solve_impact(potential, m, v0, zeta)` returns,
bit for bit (the same operations in the same order; held by a test over every
family). Whatever the fast path does not cover (zeta >= 0.9, the split and
tanh-sinh paths, a bound or range refusal, bad input) is passed to `solve_impact`
itself, which solves it or raises its one-line error.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact._branches import _GJ_ZETA_MAX, per_potential
from reference_impl.exact._one_call import _OK, _OUT, _params, _plan, _result, fused_impact
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._power_kernel import OUT_SIZE, power_constants, power_impact
from reference_impl.exact._split import _INFO, _split_info, needs_split
from reference_impl.exact._strategies import turning_point
from reference_impl.exact._validate import _check_exponent, _validated_top
from reference_impl.exact.solve import (
    _TINY,
    RTOL_STATED,
    ImpactSolution,
    _charge_conditioning,
    _check_bound,
    solve_impact,
)
from reference_impl.potentials._checks import is_real_number, positive
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

__all__ = ["PreparedImpact", "prepare"]

_INF = math.inf


class PreparedImpact:
    """`solve_impact` for one potential and mass, checked and planned once (`prepare`).

    Calling it with (v0, zeta) returns `solve_impact(potential, m, v0, zeta)`.
    """

    __slots__ = ("potential", "m", "_power", "_out", "_plan", "_split")

    def __init__(self, potential: Potential, m: float):
        if not isinstance(potential, Potential):
            raise HCVInputError(f"potential must be a Potential, got {potential!r}")
        self.potential = potential
        self.m = positive("m", m, "prepare")
        _check_exponent(potential)
        self._power = None
        self._out = np.empty(OUT_SIZE)
        # The other compiled families: their plan of `_one_call` (None: no compiled form),
        # and whether a sum's terms can hand over inside a contact (`_split`).
        self._plan = None if type(potential) is PowerLaw else _plan(potential)
        self._split = per_potential(_INFO, _split_info, potential) is not None
        if type(potential) is PowerLaw:
            self._power = power_constants(potential, self.m)

    def __repr__(self) -> str:
        return f"prepare({self.potential!r}, {self.m!r})"

    def __call__(self, v0: float, zeta: float = 0.0) -> ImpactSolution:
        """The impact at speed v0 (m/s) and damping ratio zeta, as `solve_impact`."""
        pot, m = self.potential, self.m
        if (type(v0) is not float or type(zeta) is not float) and (
            is_real_number(v0) and is_real_number(zeta)
        ):
            # numpy scalars and ints as `solve_impact`'s checks take them (float(value)).
            try:
                v0, zeta = float(v0), float(zeta)
            except OverflowError:
                return solve_impact(pot, m, v0, zeta)
        if not (
            type(v0) is float
            and type(zeta) is float
            and 0.0 < v0 < _INF
            and 0.0 <= zeta < _GJ_ZETA_MAX
        ):
            return solve_impact(pot, m, v0, zeta)
        E = 0.5 * m * v0 * v0
        if not (E >= _TINY and E < _INF):
            return solve_impact(pot, m, v0, zeta)
        q_top = _validated_top(pot, E)
        if self._power is not None:
            out = self._out
            power_impact(v0, zeta, *self._power, RTOL_STATED, _TINY, out)
            if out[13] != 1.0:
                return solve_impact(pot, m, v0, zeta)
            (
                rise,
                e_rise,
                mid,
                e_mid,
                fall,
                e_fall,
                q_max,
                f_max,
                rest,
                rest_zf,
                wd,
                sp,
                s_end,
                _,
            ) = out.tolist()
            osc = object.__new__(VirtualOscillator)
            osc.__dict__.update(
                v0=v0, zeta=zeta, wd=wd, r=0.0, s_peak=sp, s_end=s_end, s_zero_force=2.0 * sp
            )
            return ImpactSolution._fast(
                v0=v0,
                m=m,
                zeta=zeta,
                max_penetration=q_max,
                max_force=f_max,
                contact_time=rise + fall,
                restitution=rest,
                contact_time_zero_force=rise + mid,
                restitution_zero_force=rest_zf,
                quadrature_error=e_rise + e_fall,
                quadrature_error_zero_force=e_rise + e_mid,
                potential=pot,
                _osc=osc,
                _t_peak=rise,
            )
        if self._plan is None or (
            self._split and needs_split(pot, lambda: turning_point(pot, m, v0, q_top), q_top)
        ):
            return solve_impact(pot, m, v0, zeta)
        osc = VirtualOscillator(v0, zeta)
        plan = self._plan
        fast = None
        if plan.gj is not None:
            # Gauss-Jacobi first, as `fused_impact`; on a refusal it runs the whole ladder.
            k = plan.kernel
            out = np.empty(_OUT)
            plan.gauss_jacobi(_params(osc, m, q_top, k), k.P, *plan.gj, out)
            if out[8] == _OK:
                fast = _result(out)
        if fast is None:
            fast = fused_impact(pot, m, osc, q_top)
        if fast is None:
            return solve_impact(pot, m, v0, zeta)
        br, q_max, max_force = fast
        br = _charge_conditioning(br, pot, m, osc, q_max, max_force)
        _check_bound(br, pot, m, v0, zeta)
        if not (q_max >= _TINY and max_force >= _TINY and br.rise + br.fall >= _TINY):
            return solve_impact(pot, m, v0, zeta)
        return ImpactSolution._fast(
            v0=v0,
            m=m,
            zeta=zeta,
            max_penetration=q_max,
            max_force=max_force,
            contact_time=br.rise + br.fall,
            restitution=math.exp(-math.pi * zeta / osc.wd),
            contact_time_zero_force=br.rise + br.mid,
            restitution_zero_force=osc.restitution_zero_force if zeta > 0 else 1.0,
            quadrature_error=br.err_rise + br.err_fall,
            quadrature_error_zero_force=br.err_rise + br.err_mid,
            potential=pot,
            _osc=osc,
            _t_peak=br.rise,
        )


def prepare(potential: Potential, m: float) -> PreparedImpact:
    """A solver of many impacts of ``potential`` and mass ``m``: ``prepare(pot, m)(v0, zeta)``
    equals ``solve_impact(pot, m, v0, zeta)`` bit for bit, with the potential checked and
    the path planned once (see the module docstring).

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    m : float
        Mass (kg), > 0.

    Returns
    -------
    PreparedImpact

    Raises
    ------
    HCVInputError
        As `solve_impact` for the potential and the mass, at once.
    """
    return PreparedImpact(potential, m)
