"""Closed forms of Theorem 1's integrals for power laws: independent references.

For U = k q^n / n (n = p + 1) the substitution q = q_max y^(1/n) turns the action
and period integrals into Euler's Beta integrals, so J, T, the contact duration
and dJ/dE are Beta functions, in float64 or at any mpmath precision. Each
quantity is written out separately (not derived from another) because the suite
uses them to test the relations between T, t_c and dJ/dE.
"""

from __future__ import annotations

import math

import mpmath
from scipy.special import beta as _beta

from reference_impl.potentials.power import PowerLaw
from reference_impl.theory._action_common import (
    _GUARD_DPS,
    _check_dps,
    _check_positive,
    _check_powerlaw,
)

__all__ = [
    "powerlaw_action_closed",
    "powerlaw_contact_duration_closed",
    "powerlaw_dJ_dE_closed",
    "powerlaw_period_closed",
]


def _powerlaw_parts(pot: PowerLaw, E, mp: bool):
    """(q_max, B(1/n, 1/2)/n, B(1/n, 3/2)/n, sqrt(E)) in float64 or at the current mp precision."""
    if mp:
        n = mpmath.mpf(pot.p) + 1
        E = mpmath.mpf(E)
        q_max = (n * E / pot.k) ** (1 / n)
        return (
            q_max,
            mpmath.beta(1 / n, mpmath.mpf(1) / 2) / n,
            mpmath.beta(1 / n, mpmath.mpf(3) / 2) / n,
            mpmath.sqrt(E),
        )
    n = pot.p + 1.0
    E = float(E)
    q_max = (n * E / pot.k) ** (1.0 / n)
    return q_max, float(_beta(1.0 / n, 0.5)) / n, float(_beta(1.0 / n, 1.5)) / n, math.sqrt(E)


def _closed(pot, m, E, mp, dps, build):
    _check_powerlaw(pot)
    _check_positive("mass m", m, "kg")
    _check_positive("energy E", E, "J")
    if mp:
        _check_dps(dps)
        with mpmath.workdps(dps + _GUARD_DPS):
            return build(mpmath.mpf(m), *_powerlaw_parts(pot, E, True), mpmath.sqrt, mpmath.pi)
    return build(float(m), *_powerlaw_parts(pot, E, False), math.sqrt, math.pi)


def powerlaw_action_closed(pot: PowerLaw, m, E, mp: bool = False, dps: int = 50):
    """Closed-form J(E) = sqrt(2m)/pi q_max sqrt(E) B(1/n, 3/2)/n for U = k q^n/n.

    Parameters
    ----------
    pot : PowerLaw
        U = k q^(p+1)/(p+1); n = p + 1.
    m : float
        Mass in kg (> 0).
    E : float
        Energy in J (> 0).
    mp : bool
        Evaluate with mpmath at ``dps`` digits instead of float64.
    dps : int
        Decimal digits when ``mp``.

    Returns
    -------
    float or mpmath.mpf
        J in J s.
    """
    return _closed(
        pot,
        m,
        E,
        mp,
        dps,
        lambda m, qm, b_half, b_3half, sE, sqrt, pi: sqrt(2 * m) / pi * qm * sE * b_3half,
    )


def powerlaw_period_closed(pot: PowerLaw, m, E, mp: bool = False, dps: int = 50):
    """Closed-form paper's period T = 4 sqrt(m/2) q_max/sqrt(E) B(1/n, 1/2)/n (s).

    Parameters as in `powerlaw_action_closed`.
    """
    return _closed(
        pot,
        m,
        E,
        mp,
        dps,
        lambda m, qm, b_half, b_3half, sE, sqrt, pi: 4 * sqrt(m / 2) * qm / sE * b_half,
    )


def powerlaw_contact_duration_closed(pot: PowerLaw, m, E, mp: bool = False, dps: int = 50):
    """Closed-form contact duration t_c = 2 sqrt(m/2) q_max/sqrt(E) B(1/n, 1/2)/n (s).

    Parameters as in `powerlaw_action_closed`.
    """
    return _closed(
        pot,
        m,
        E,
        mp,
        dps,
        lambda m, qm, b_half, b_3half, sE, sqrt, pi: 2 * sqrt(m / 2) * qm / sE * b_half,
    )


def powerlaw_dJ_dE_closed(pot: PowerLaw, m, E, mp: bool = False, dps: int = 50):
    """Closed-form dJ/dE = sqrt(2m)/(2 pi) q_max/sqrt(E) B(1/n, 1/2)/n (s).

    Parameters as in `powerlaw_action_closed`.
    """
    return _closed(
        pot,
        m,
        E,
        mp,
        dps,
        lambda m, qm, b_half, b_3half, sE, sqrt, pi: sqrt(2 * m) / (2 * pi) * qm / sE * b_half,
    )
