"""What a damping law does at contact, for the general-law solver (`general_law`).

Read once per (potential, m, law) by its plan: the arrays the compiled kernels take
(`law_arrays`: the law's terms, and the scalars ``sc`` with the creep and pull flags) and
whether a return along the slow manifold near q = 0 ever ends (`creeps_for_ever`, its
verdict alone `creep_verdict`: the plan of a one-shot call asks it for every new law, a refusal
formats the phrase). Split from `general_law` (issue 38), unchanged in every number.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential
from reference_impl.theory.laws import DampingLaw

__all__ = ["creep_verdict", "creeps_for_ever", "law_arrays"]


def creeps_for_ever(law: DampingLaw, m: float, pot: Potential):
    """Whether a return along the slow manifold near q = 0 never reaches it, and why.

    With U ~ c q^n and C ~ c_a q^a at contact (a the smallest exponent among the law's
    terms), the slow manifold is q' = -U'/C ~ q^(n-1-a). Inertia m q'' ~ q^(2n-3-2a) stays
    negligible against U' ~ q^(n-1) as q -> 0 only for a <= (n-2)/2; then the time to q = 0,
    int C/U' dq, diverges (a <= n - 2): the body never returns. For a > (n-2)/2 (every law
    with n < 2, C(0) = 0 on Hooke's spring, the viscoelastic law for n > 2) inertia takes
    over near q = 0 and the body returns, however late (viscoelastic A = 30 s on Hertz with
    k = m = v0 = 1: e = 2.8e-8 after 499.7 s). At a = (n-2)/2 the tail is the universal
    law's, a virtual oscillator with zeta0 = c_a / (2 sqrt(m) n sqrt(c/2)): no return iff
    zeta0 >= 1.

    Returns
    -------
    (bool or None, str)
        True (never returns), False (returns), None (c unknown at a = (n-2)/2), and a
        phrase naming the tail for a refusal.
    """
    never, a, n, z0 = creep_verdict(law, m, pot)
    if a is None:
        return False, "undamped at contact"
    if z0 is None:
        if never:
            return True, f"C ~ q^{a:g} at contact, U ~ q^{n:g}"
        return False, f"C ~ q^{a:g} at contact, U ~ q^{n:g}: inertia takes over near q = 0"
    if never is None:
        return None, "tail of unknown damping ratio"
    return never, f"underdamped at contact, damping ratio {z0:.6g}"


def creep_verdict(law: DampingLaw, m: float, pot: Potential):
    """The verdict of `creeps_for_ever` without its phrase (formatted only for a refusal:
    the plan of every one-shot call asks for the verdict alone).

    Returns
    -------
    (bool or None, float or None, float, float or None)
        The verdict; a, the exponent of C at contact (None: undamped there); n; zeta0
        where a = (n-2)/2, else None.
    """
    return _verdict(law.decomposition(), m, float(pot.leading_exponent), pot.leading_coefficient)


def _verdict(d, m: float, n: float, c):
    """`creep_verdict` of the decomposition ``d`` on U ~ c q^n (c None: unknown)."""
    cc = math.nan if c is None else float(c)
    leads: dict = {}
    for cj, e in d.terms:
        if cj > 0:
            key = round(float(e), 9)
            leads[key] = leads.get(key, 0.0) + cj
    if d.alpha:
        key = round(n - 1.0, 9)
        leads[key] = leads.get(key, 0.0) + d.alpha * n * cc
    if d.A:
        key = round(n - 2.0, 9)
        leads[key] = leads.get(key, 0.0) + d.A * n * (n - 1.0) * cc
    if d.zeta:
        key = round(n / 2.0 - 1.0, 9)
        leads[key] = leads.get(key, 0.0) + 2.0 * d.zeta * math.sqrt(m) * n * math.sqrt(cc / 2.0)
    if not leads:
        return False, None, n, None
    a = min(leads)
    edge = (n - 2.0) / 2.0
    if a < edge - 1e-9:
        return True, a, n, None
    if a > edge + 1e-9:
        return False, a, n, None
    z0 = leads[a] / (2.0 * math.sqrt(m) * n * math.sqrt(cc / 2.0))
    if not math.isfinite(z0):
        return None, a, n, z0
    return z0 >= 1.0, a, n, z0


def law_arrays(law: DampingLaw, m: float, pot: Potential, extra: tuple = ()):
    """(cs, es, sc) of the compiled kernels; ``extra`` is appended to ``sc`` (the Taylor
    kernel's truncation and step fraction for an ``rtol``, `_general_taylor.SC_TOL`)."""
    d = law.decomposition()
    terms = d.terms
    cs = np.array([c for c, _ in terms], float)
    es = np.array([e for _, e in terms], float)
    zf = 2.0 * d.zeta * math.sqrt(m)
    n = float(pot.leading_exponent)
    # Leading exponent a of C ~ q^a at contact.
    leads = [e for c, e in terms if c > 0]
    if d.alpha:
        leads.append(n - 1.0)
    if d.A:
        leads.append(n - 2.0)
    if d.zeta:
        leads.append(n / 2.0 - 1.0)
    # The creep test of _general_kernel may stop a return only where the creep never ends
    # (`creeps_for_ever`; where c is unknown, a <= n - 2: int C / U' dq diverges).
    never = _verdict(d, m, n, pot.leading_coefficient)[0]
    if never is None:
        never = bool(leads) and min(leads) <= n - 2.0 + 1e-12
    creeps = 1.0 if never else 0.0
    # C q' outweighs U' as q -> 0 (a < n - 1): the force pulls just before q = 0.
    pulls = 1.0 if leads and min(leads) < n - 1.0 - 1e-12 else 0.0
    # The law says the force never vanishes before q = 0 (Hunt-Crossley: F = U' (1 + alpha
    # q'), _general_kernel): no zero-force event is searched.
    nopull = 1.0 if d.never_pulls else 0.0
    sc = np.array([m, d.alpha, d.A, zf, creeps, pulls, nopull, *extra], float)
    if d.A and n < 2.0:
        raise HCVInputError(
            f"damping law {law.name!r} needs U'' finite at contact (leading exponent n >= 2, "
            f"force exponent p >= 1); got n = {n:.6g}, where C = A U'' is infinite at q = 0"
        )
    return cs, es, sc
