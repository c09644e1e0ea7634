"""A damping law's strength solved from a restitution asked at one speed (issues 26, 37).

A DEM user thinks in e. Every registered law with a strength (`LawFamily.strength`,
`reference_impl.theory.laws`) has one parameter that scales C: ``c`` (linear, power),
``A`` (viscoelastic), ``alpha`` (hunt-crossley), and for a shape-scaled law (polynomial)
a factor on all its coefficients (the given ``c`` is the shape). `law_for_restitution`
finds the strength s at which the exact restitution of the law at the asked speed v, at
the asked end, equals the asked e: for a law the harmonic map solves (universal) in
closed form (Theorem 3: e does not depend on v), else through the exact solution
`reference_impl.exact.api.solve` (~1e-14) and a bracketing search on log s (e falls
monotonically as the damping grows). This is the one solve-to-restitution of a law.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.theory.laws import LAWS, DampingLaw, law_C, law_family

__all__ = ["law_for_restitution", "speed_dependent_laws", "strength_text"]


def speed_dependent_laws() -> tuple[str, ...]:
    """The registered laws whose strength a restitution asked at a speed solves (every law
    with a strength but those of the harmonic map, whose e does not depend on the speed)."""
    return tuple(n for n, f in LAWS.items() if f.strength is not None and f.route != "harmonic map")


# The exact restitution is good to ~1e-14 (`ERROR_SAFETY` bound of the general-law solver);
# the root is accepted when the law's e at the strength found is this close to the asked one.
_E_TOL = 1e-9
# log(strength) is searched to this absolute width: a relative 1e-13 of the strength,
# far below what moves e by _E_TOL.
_LOG_XTOL = 1e-13
# Bracketing: steps of x4 from the first guess, at most this many each way (4^40 ~ 1e24).
_GROW = 4.0
_MAX_STEPS = 40


def _guess(potential, mass: float, v: float, unit: DampingLaw) -> float:
    """A strength of order 'critical damping': C(q_max / 2) ~ m / t_c of the elastic impact."""
    from reference_impl.exact.api import solve

    try:
        el = solve(potential, mass, v, 0.0)
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
        The law (any strength; for a shape-scaled law, e.g. ``polynomial``, its
        coefficients give the shape).
    e : float
        Restitution asked, 0 < e <= 1 (e = 1: strength 0).
    v : float
        Impact speed at which it is asked (m/s, > 0).
    end : {"overlap", "zero-force"}
        Where the restitution is read.

    Returns
    -------
    (DampingLaw, float)
        The solved law and its strength (in its unit, `LawFamily.strength_unit`; for a
        shape-scaled law the factor applied to the given coefficients).

    Raises
    ------
    HCVInputError
        One line when no strength gives ``e`` (e.g. the body stops returning first).
    """
    from reference_impl.exact.api import solve

    fam = law_family(law.name)
    if fam.strength is None:
        raise HCVInputError(f"damping law {law.name!r} has no strength to solve from a restitution")
    if e >= 1.0:
        return law.with_strength(0.0), 0.0
    if fam.route == "harmonic map":
        # Theorem 3: the restitution does not depend on v; its zeta in closed form
        from reference_impl.theory.damping import zeta_from_restitution

        z = zeta_from_restitution(e, end=end)
        return law.with_strength(z), z
    # the law at strength 1 (a shape-scaled law's given coefficients are its shape: scale 1)
    unit = law if fam.shape_scaled else law.with_strength(1.0)
    if unit.is_zero():
        raise HCVInputError(
            f"damping law {law.name!r}: its coefficients are all 0, so no scale of them "
            f"gives e = {e:g}"
        )

    def f(s: float) -> float:
        sol = solve(potential, mass, v, law=unit.with_strength(s))
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
    return unit.with_strength(s), s


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
    fam = law.family
    unit = fam.strength_unit(law.params)
    value = law.params[key]
    if fam.shape_scaled:
        shown = "[" + ", ".join(f"{c:.6g}" for c in value) + "]"
        how = f"the given c scaled by {calibration['scale']:.6g}; "
    else:
        shown, how = f"{value:.6g}", ""
    return (
        f"{key} = {shown} {unit} ({how}e = {calibration['restitution']:g} at "
        f"{calibration['restitution_speed']:g} m/s, {calibration['restitution_end']} end)"
    )
