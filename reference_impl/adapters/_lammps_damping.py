"""LAMMPS's damping models in the suite's terms: prefactors, their inverses, a calibration.

The arithmetic behind the table of `reference_impl.adapters.lammps` (its module
docstring), needing no LAMMPS: tsuji's alpha(e) of the loaded version
(`tsuji_alpha`) and the e whose alpha gives a damping ratio (`tsuji_input`), the
linear damping ratio of coeff_restitution's e (`zeta_linear`), LAMMPS's eta_n0 and
the constant c of C = c q^a for velocity, mass_velocity and viscoelastic
(`constant_from_eta_n0`, `eta_n0_from_constant`), and the c whose damped ODE gives an
asked restitution (`calibrate_constant`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from reference_impl.adapters._asked import invert_decreasing
from reference_impl.adapters.base import PowerDamping
from reference_impl.errors import HCVInputError
from reference_impl.integrators.ivp import integrate_impact
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.damping import zeta_from_restitution

__all__ = [
    "calibrate_constant",
    "constant_from_eta_n0",
    "eta_n0_from_constant",
    "tsuji_alpha",
    "tsuji_input",
    "zeta_linear",
]

# LAMMPS version (YYYYMMDD) from which tsuji's alpha carries the sqrt(2) factor.
_TSUJI_SQRT2_SINCE = 20260902
# Calibration of a constant damping: IVP tolerance and relative root tolerance.
_CALIB_RTOL = 1e-10
_CALIB_XRTOL = 1e-10
# c of each calibration done in this process, by (k, p, m, e, v_ref, exponent, end):
# the variants and scenes of one run that ask the same calibrate it once.
_CALIBRATIONS: dict[tuple, float] = {}


def tsuji_alpha(e: float, version: int) -> float:
    """LAMMPS's tsuji prefactor alpha(e) (Marshall 2009, eq. 53; x sqrt(2) since 2Sep2026)."""
    a = (
        1.2728
        - 4.2783 * e
        + 11.087 * e**2
        - 22.348 * e**3
        + 27.467 * e**4
        - 18.022 * e**5
        + 4.8218 * e**6
    )
    return a * math.sqrt(2.0) if version >= _TSUJI_SQRT2_SINCE else a


def tsuji_input(zeta: float, p: float, version: int) -> float:
    """LAMMPS's tsuji ``e`` whose alpha(e) / sqrt(2 (p + 1)) is the damping ratio zeta.

    alpha decreases on [0, 1] (from 1.2728 to 3e-4, x sqrt(2) since 2Sep2026): a zeta
    outside its range gets the nearest end (e = 1 for no damping, as LAMMPS's own
    e = 1 does), whose law the adapter declares.
    """
    if not zeta:
        return 1.0
    scale = math.sqrt(2.0 * (p + 1.0))
    return invert_decreasing(lambda x: tsuji_alpha(x, version) / scale, zeta, 0.0, 1.0)


def zeta_linear(e: float) -> float:
    """Damping ratio zeta_l of a linear spring-dashpot whose restitution is e (0 < e < 1)."""
    le = math.log(e)
    return -le / math.sqrt(math.pi**2 + le * le)


def constant_from_eta_n0(model: str, eta_n0: float, m: float, r_eff: float) -> float:
    """Damping constant c of C = c q^a for a given LAMMPS eta_n0."""
    if model == "velocity":
        return eta_n0
    if model == "mass_velocity":
        return eta_n0 * m
    return eta_n0 * m * math.sqrt(r_eff)  # viscoelastic: eta_n0 m_eff sqrt(R_eff delta)


def eta_n0_from_constant(model: str, c: float, m: float, r_eff: float) -> float:
    """LAMMPS's eta_n0 for a damping constant c (inverse of `constant_from_eta_n0`)."""
    if model == "velocity":
        return c
    if model == "mass_velocity":
        return c / m
    return c / (m * math.sqrt(r_eff))


def calibrate_constant(
    pot: PowerLaw, m: float, e: float, v_ref: float, exponent: float, end: str = "overlap"
) -> float:
    """c such that C = c q^exponent gives restitution e at v_ref at ``end`` (damped ODE,
    DOP853): "overlap" (q back to 0) or "zero-force" (the total force first 0)."""

    key = (pot.k, pot.p, m, e, v_ref, exponent, end)
    if key in _CALIBRATIONS:
        return _CALIBRATIONS[key]
    q_max = pot.turning_point(0.5 * m * v_ref * v_ref)
    # First guess: the universal law's C at half the turning point, as a c q^exponent.
    q_h = 0.5 * q_max
    u, du = (float(f(np.array([q_h]))[0]) for f in (pot._U, pot._dU))
    guess = 2.0 * zeta_from_restitution(e, end=end) * math.sqrt(m) * du / math.sqrt(2.0 * u)
    guess /= q_h**exponent

    def gap(log_c: float) -> float:
        damp = PowerDamping(math.exp(log_c), exponent)
        res = integrate_impact(pot, m, v_ref, C=damp, rtol=_CALIB_RTOL)
        got = res.restitution_zero_force if end == "zero-force" else res.restitution
        got = got if res.returned and math.isfinite(got) else 0.0
        return got - e

    lo = hi = math.log(guess)
    g_lo = g_hi = gap(lo)
    for _ in range(40):  # widen by factors of 2 until the root is bracketed
        if g_lo < 0:
            lo -= math.log(2.0)
            g_lo = gap(lo)
        if g_hi > 0:
            hi += math.log(2.0)
            g_hi = gap(hi)
        if g_lo >= 0 >= g_hi:
            break
    else:  # pragma: no cover - e in (0, 1) is always reachable
        raise HCVInputError(f"cannot calibrate a q^{exponent:g} damping to e = {e:g}")
    root = brentq(gap, lo, hi, xtol=_CALIB_XRTOL, rtol=_CALIB_XRTOL)
    _CALIBRATIONS[key] = math.exp(root)
    return _CALIBRATIONS[key]
