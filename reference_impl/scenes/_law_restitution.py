"""A damping law's strength solved from a restitution asked at one speed (issue 26, item 2).

A DEM user thinks in e. Every speed-dependent law of `reference_impl.theory.laws`
(``linear``, ``power``, ``polynomial``, ``viscoelastic``, ``hunt-crossley``) has one
strength parameter that scales C(q): ``c`` (linear, power), ``A`` (viscoelastic),
``alpha`` (hunt-crossley), and for a polynomial a factor on all its coefficients (the
given ``c`` is the shape). `law_for_restitution` finds the strength s at which the exact
restitution of the law at the asked speed v, at the asked end, equals the asked e:
the exact solution is `reference_impl.exact.general_law.solve_law_impact` (~1e-14), the
root a bracketing search on log s (e falls monotonically as the damping grows).
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.theory.laws import DampingLaw, law_C

__all__ = ["STRENGTH", "law_for_restitution", "strength_text"]

# The one strength parameter of each law ("c" of a polynomial: all coefficients scaled).
STRENGTH = {
    "linear": "c",
    "power": "c",
    "polynomial": "c",
    "viscoelastic": "A",
    "hunt-crossley": "alpha",
}
# Units of each strength (as `reference_impl.theory.laws` documents them; a power law's
# c is in N s m^-(1+exponent), its exponent filled in by `strength_text`).
_STRENGTH_UNITS = {
    "linear": "N s/m",
    "power": "N s m^-{}",
    "polynomial": "N s m^-(1+i)",
    "viscoelastic": "s",
    "hunt-crossley": "s/m",
}
# The exact restitution is good to ~1e-14 (`ERROR_SAFETY` bound of the general-law solver);
# the root is accepted when the law's e at the strength found is this close to the asked one.
_E_TOL = 1e-9
# log(strength) is searched to this absolute width: a relative 1e-13 of the strength,
# far below what moves e by _E_TOL.
_LOG_XTOL = 1e-13
# Bracketing: steps of x4 from the first guess, at most this many each way (4^40 ~ 1e24).
_GROW = 4.0
_MAX_STEPS = 40


def _with_strength(law: DampingLaw, s: float) -> DampingLaw:
    params = dict(law.params)
    if law.name == "polynomial":
        params["c"] = tuple(s * c for c in law.params["c"])
    else:
        params[STRENGTH[law.name]] = s
    return DampingLaw(law.name, params)


def _guess(potential, mass: float, v: float, unit: DampingLaw) -> float:
    """A strength of order 'critical damping': C(q_max / 2) ~ m / t_c of the elastic impact."""
    from reference_impl.exact.solve import solve_impact

    try:
        el = solve_impact(potential, mass, v, 0.0)
        q_mid = np.array([0.5 * float(el.max_penetration)])
        with np.errstate(all="ignore"):
            c1 = float(law_C(unit, potential, mass, q_mid)[0])
        s = mass / float(el.contact_time) / c1
    except Exception:  # noqa: BLE001 - only a first guess: the bracket search widens it
        return 1.0
    return s if math.isfinite(s) and s > 0 else 1.0


def law_for_restitution(
    potential, mass: float, law: DampingLaw, e: float, v: float, end: str = "overlap"
) -> tuple[DampingLaw, float]:
    """The law with its strength solved so that its exact restitution at ``v`` is ``e``.

    Parameters
    ----------
    potential : Potential
        Contact potential U(q) (J, q in m).
    mass : float
        Reduced mass (kg).
    law : DampingLaw
        The law (any strength; for ``polynomial`` its coefficients give the shape).
    e : float
        Restitution asked, 0 < e <= 1 (e = 1: strength 0).
    v : float
        Impact speed at which it is asked (m/s, > 0).
    end : {"overlap", "zero-force"}
        Where the restitution is read.

    Returns
    -------
    (DampingLaw, float)
        The solved law and its strength (``c`` in its law's units, ``A`` in s, ``alpha``
        in s/m; for ``polynomial`` the factor applied to the given coefficients).

    Raises
    ------
    HCVInputError
        One line when no strength gives ``e`` (e.g. the body stops returning first).
    """
    from reference_impl.exact.general_law import solve_law_impact

    if law.name not in STRENGTH:
        raise HCVInputError(f"damping law {law.name!r} has no strength to solve from a restitution")
    if e >= 1.0:
        return _with_strength(law, 0.0), 0.0
    # the law at strength 1 (a polynomial's given coefficients are its shape: scale 1)
    unit = law if law.name == "polynomial" else _with_strength(law, 1.0)
    if unit.is_zero():
        raise HCVInputError(
            f"damping law {law.name!r}: its coefficients are all 0, so no scale of them "
            f"gives e = {e:g}"
        )

    def f(s: float) -> float:
        sol = solve_law_impact(potential, mass, v, _with_strength(unit, s))
        got = sol.restitution if end == "overlap" else sol.restitution_zero_force
        return float(got) - e

    lo = hi = _guess(potential, mass, v, unit)
    f_lo = f_hi = f(lo)
    steps = 0
    while f_hi > 0.0:  # not damped enough: grow
        lo, f_lo = hi, f_hi
        hi *= _GROW
        f_hi = f(hi)
        steps += 1
        if steps > _MAX_STEPS:
            raise HCVInputError(
                f"damping law {law.name!r}: no strength up to {hi:.3g} gives e = {e:g} "
                f"at v = {v:g} m/s ({end} end)"
            )
    steps = 0
    while f_lo <= 0.0:  # too damped: shrink
        hi, f_hi = lo, f_lo
        lo /= _GROW
        f_lo = f(lo)
        steps += 1
        if steps > _MAX_STEPS:
            raise HCVInputError(
                f"damping law {law.name!r}: even a strength of {lo:.3g} damps below "
                f"e = {e:g} at v = {v:g} m/s ({end} end)"
            )
    from scipy.optimize import brentq

    x = brentq(lambda x: f(math.exp(x)), math.log(lo), math.log(hi), xtol=_LOG_XTOL)
    s = math.exp(x)
    miss = f(s)
    if abs(miss) > _E_TOL:
        raise HCVInputError(
            f"damping law {law.name!r}: e = {e:g} at v = {v:g} m/s ({end} end) is not "
            f"reached: the restitution jumps past it at strength {s:.6g} (the body stops "
            f"returning to q = 0 there); ask for a larger e or another law"
        )
    return _with_strength(unit, s), s


def strength_text(law: DampingLaw, calibration: dict) -> str:
    """One line saying the solved strength of a law and what it was solved for, e.g.
    ``alpha = 1.2697 s/m (e = 0.7 at 0.5 m/s, overlap end)``.

    Parameters
    ----------
    law : DampingLaw
        The solved law (its strength parameter holds the solved value).
    calibration : dict
        The scene's calibration record (``restitution``, ``restitution_speed``,
        ``restitution_end``, ``parameter``; ``scale`` for a polynomial).
    """
    key = calibration["parameter"]
    unit = _STRENGTH_UNITS[law.name]
    if law.name == "power":
        unit = unit.format(f"{1.0 + law.params['exponent']:g}")
    value = law.params[key]
    if law.name == "polynomial":
        shown = "[" + ", ".join(f"{c:.6g}" for c in value) + "]"
        how = f"the given c scaled by {calibration['scale']:.6g}; "
    else:
        shown, how = f"{value:.6g}", ""
    return (
        f"{key} = {shown} {unit} ({how}e = {calibration['restitution']:g} at "
        f"{calibration['restitution_speed']:g} m/s, {calibration['restitution_end']} end)"
    )
