"""Repeated impacts of one potential and mass: `prepare(potential, m)` (issue 27, goal 2).

`solve_impact` checks its potential and mass, plans its path and assembles its
result in Python around ~5-10 us of compiled work, on every call. A prepared
solver does the checks and the planning once; each call then

* for a power law (the Gauss-Jacobi path of `_branches`), makes one compiled call
  (`_power_impact`) that computes the oscillator, the branch sums (`_gj_sums`,
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

import numba
import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.exact._branches import (
    _EPS,
    _GJ_BETA_MIN,
    _GJ_RTOL,
    _GJ_SIZES,
    _GJ_ZETA_MAX,
    _NODE_ULPS,
    _SUM_ULPS_PER_NODE,
    _exponent_splits,
    _fill_rows,
    _gj_sums,
    _jacobi_pair,
    _pow_split,
    per_potential,
)
from reference_impl.exact._one_call import _OK, _OUT, _params, _plan, _result, fused_impact
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._split import _INFO, _split_info, needs_split
from reference_impl.exact._strategies import turning_point
from reference_impl.exact._validate import _check_exponent, _validated_top
from reference_impl.exact.solve import (
    _TINY,
    RTOL_STATED,
    ImpactSolution,
    _check_bound,
    _conditioning,
    solve_impact,
)
from reference_impl.potentials._checks import is_real_number, positive
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

__all__ = ["PreparedImpact", "prepare"]

_INF = math.inf
# Output of `_power_impact`: the six Branches fields, q_max, U'(q_max), restitution,
# restitution at zero force, wd, s_peak, s_end, ok (1.0) or not (0.0).
_P_OUT = 14


@numba.njit(cache=True, error_model="numpy")
def _power_impact(v0, zeta, c_m, b_hi, b_lo, u, W, beta, round_rel, q_scale, two_n, k, p, out):
    """One power-law impact by Gauss-Jacobi, as `solve_impact` computes it (pragma: compiled).

    The oscillator (`VirtualOscillator`), the branch rows (`_fill_rows`), the scale
    c v0^beta (`power_law_scale`: c_m = (m/k) (n m / 2k)^(-p/n)), the sums
    (`_gj_sums`), their agreement test and bounds (`_gauss_jacobi_power_law`), the
    peak (`_strategies.peak`), the bound and range checks (`solve._check_bound`,
    `_check_normal`): out[13] = 0 when any of them refuses.
    """  # pragma: no cover - compiled
    out[13] = 0.0
    wd = math.sqrt((1.0 - zeta) * (1.0 + zeta))
    sp = math.atan2(wd, zeta) / wd
    s_end = math.pi / wd
    lz = 2.0 * math.atan2(zeta, wd) / wd if zeta > 0.0 else 0.0
    rows = np.empty((3, 5))
    nr = _fill_rows(zeta, sp, s_end, lz, rows)
    for i in range(nr):
        if not rows[i, 4] > 0.0:
            return
    c_pl = c_m * (v0**b_hi * math.exp(b_lo * math.log(v0)))
    sums = _gj_sums(rows[:nr], u, W, zeta, wd, beta, c_pl)
    err = np.empty(nr)
    for i in range(nr):
        coarse, fine = sums[i, 0], sums[i, 1]
        err[i] = abs(fine - coarse) + round_rel * fine
        if not abs(fine - coarse) <= _GJ_RTOL * abs(fine):
            return
    rise, e_rise = sums[0, 1], err[0]
    if zeta == 0.0:
        mid, e_mid, fall, e_fall = rise, e_rise, rise, e_rise
    else:
        fall, e_fall = sums[1, 1], err[1]
        mid, e_mid = fall - sums[2, 1], e_fall + err[2]
    x_peak = v0 * math.exp(-zeta * sp)
    q_max = q_scale * x_peak**two_n
    f_max = k * q_max**p
    for t, e in ((rise + fall, e_rise + e_fall), (rise + mid, e_rise + e_mid)):
        if math.isfinite(t) and not e <= RTOL_STATED * t:
            return
    if not (q_max >= _TINY and f_max >= _TINY and rise + fall >= _TINY):
        return
    out[0], out[1], out[2], out[3], out[4], out[5] = rise, e_rise, mid, e_mid, fall, e_fall
    out[6], out[7] = q_max, f_max
    out[8] = math.exp(-math.pi * zeta / wd)
    out[9] = math.exp(-2.0 * zeta * sp) if zeta > 0.0 else 1.0
    out[10], out[11], out[12] = wd, sp, s_end
    out[13] = 1.0


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
        self._out = np.empty(_P_OUT)
        # The other compiled families: their plan of `_one_call` (None: no compiled form),
        # and whether a sum's terms can hand over inside a contact (`_split`).
        self._plan = None if type(potential) is PowerLaw else _plan(potential)
        self._split = per_potential(_INFO, _split_info, potential) is not None
        n = potential.leading_exponent
        beta = 2.0 / n - 1.0
        if type(potential) is PowerLaw and beta >= _GJ_BETA_MIN:
            k, m_ = potential.k, self.m
            a_hi, a_lo, b_hi, b_lo = _exponent_splits(potential.p, n)
            c_m = (m_ / k) * _pow_split(0.5 * n * m_ / k, a_hi, a_lo)
            u, W = _jacobi_pair(beta)
            round_rel = (_SUM_ULPS_PER_NODE * _GJ_SIZES[1] + _NODE_ULPS) * _EPS
            q_scale = (0.5 * n * m_ / k) ** (1.0 / n)
            self._power = (c_m, b_hi, b_lo, u, W, beta, round_rel, q_scale, 2.0 / n, k, potential.p)

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
            _power_impact(v0, zeta, *self._power, out)
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
        cond = _conditioning(pot, m, osc, q_max, max_force)
        if cond > 0.0:
            br = br._replace(
                err_rise=br.err_rise + cond * br.rise,
                err_mid=br.err_mid + cond * br.mid,
                err_fall=br.err_fall + cond * br.fall,
            )
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
