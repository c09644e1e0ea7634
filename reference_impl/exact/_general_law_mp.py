"""30-digit truth for `reference_impl.exact.general_law`: Taylor-series integration in analytic variables.

m q'' + C(q) q' + U'(q) = 0 with U' = sum k_i q^p_i (power laws and their sums) and
any law of `reference_impl.theory.laws`, or U' of one volumetric cap (a sphere, an
ellipsoid: U' = sum_i a_i q^p_i times y = (1 - q / (3a))^alpha, y's series by the
power recurrence, as `_taylor_cap`) with a law of C(q) or Hunt-Crossley, integrated by a Taylor method whose series are
built exactly (recurrences for products, reciprocals and powers; no numerical
differentiation) at dps + 10 digits. A Taylor method needs a right-hand side
analytic at each expansion point, which q^1.5 and q^0.25 are not at q = 0. So, as
in the float solver, three stretches:

1. entry: q = L rho^N with the smallest N <= 64 that makes every exponent of q in
   U' and C an integer multiple of 1/N; U' and C are then polynomials in rho and
   (w, t) are analytic functions of rho from rho = 0 (the variable u = sqrt(q) for
   Hertz with a constant dashpot, q^(1/4) with Tsuji's law);
2. middle: physical time, unknowns (q, w), q > 0 (q^p analytic there), until
   a step end with q <= q_max / 10 on the way out where the kinetic energy
   dominates (U' q <= m w^2 / 2);
3. exit: rho decreasing to 0, (w, t) analytic in rho.

Events (w = 0, F = U' + C w = 0 after it, dF = 0 for the peak force) are located
on each step's series by bisection; on the exit's steps the zero-force function is
F / rho^j0 formed term by term from the model (`_Model.G_low`), whose sign holds down
to rho = 0 (a series summed there is at its round-off, which hid a zero force at a
tiny overlap just before the exit). Scaled variables (q / L, w / v0,
t v0 / L, L the elastic turning point) keep every unknown O(1). The step is chosen
from the last two series coefficients so that the truncation is below 10^-(dps+8).
Cases whose body does not return are refused (not a truth case).
"""

from __future__ import annotations

import math
from fractions import Fraction

import mpmath

from reference_impl.errors import HCVInputError
from reference_impl.potentials._terms import TERM_CAP, term_rows
from reference_impl.potentials.base import Potential, SumPotential
from reference_impl.potentials.power import PowerLaw
from reference_impl.theory.laws import law_from_dict

__all__ = ["solve_law_impact_mp"]

_GUARD = 10
_N_MAX = 64
# Series order: O(K^2) work per step against steps ~ 1/tol^(1/K); 64 terms take each
# step a quarter of the radius of convergence at 1e-38.
_K = 64
_MAX_STEPS = 4000


def _common_n(exponents) -> int:
    """Smallest N <= 64 with N e an integer for every e (exponents as floats)."""
    n = 1
    for e in exponents:
        fr = Fraction(e).limit_denominator(_N_MAX)
        if abs(float(fr) - e) > 1e-12:
            raise HCVInputError(
                f"general-law truth needs exponents that are fractions with denominator <= "
                f"{_N_MAX}; got {e!r}"
            )
        n = n * fr.denominator // math.gcd(n, fr.denominator)
    if n > _N_MAX:
        raise HCVInputError(
            f"general-law truth: common denominator {n} of the exponents > {_N_MAX}"
        )
    return n


def _conv(A, B, k):
    """Coefficient k of the product of series A and B."""
    return mpmath.fsum(A[j] * B[k - j] for j in range(k + 1))


def _horner(c, h):
    acc = mpmath.mpf(0)
    for x in reversed(c):
        acc = acc * h + x
    return acc


def _deriv_series(c):
    return [c[k] * k for k in range(1, len(c))]


def _pow_rec(H, Y, k, alpha):
    """Coefficient k >= 1 of Y = H^alpha from H and Y[:k] (k H_0 Y_k =
    sum_{j=1..k} (alpha j - (k - j)) H_j Y_(k-j))."""
    return mpmath.fsum((alpha * j - (k - j)) * H[j] * Y[k - j] for j in range(1, k + 1)) / (
        k * H[0]
    )


def _cap_of(pot):
    """(Kn, alpha, a, c0) of a potential whose table is one cap row, else None."""
    rows = term_rows(pot)
    if rows is None or len(rows) != 1 or rows[0][0] != TERM_CAP:
        return None
    return rows[0][1:]


class _Model:
    """Scaled model: F(Q) = sum a_i Q^p_i (times y = (1 - beta Q)^alpha for a cap),
    C(Q) = sum of the law's terms (see module)."""

    def __init__(self, pot, m, v0, law, L, N):
        mm, vv = mpmath.mpf(m), mpmath.mpf(v0)
        self.N = N
        self.cap = _cap_of(pot)
        if self.cap is not None:
            # U' = Kn V^alpha S, V = c0 a L^2 Q^2 (1 - beta Q), S = c0 L Q (2a - L Q),
            # beta = L / (3a): F = B Q^(2 alpha + 1) (2a - L Q) y, y = (1 - beta Q)^alpha
            Kn, al, a, c0 = (mpmath.mpf(x) for x in self.cap)
            B = Kn * (c0 * a * L * L) ** al * c0 * L * L / (mm * vv * vv)
            self.F = [(2 * a * B, 2 * float(self.cap[1]) + 1), (-L * B, 2 * float(self.cap[1]) + 2)]
            self.beta, self.alpha = L / (3 * a), al
        else:
            terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
            self.F = [
                (mpmath.mpf(t.k) * L ** (mpmath.mpf(t.p) + 1) / (mm * vv * vv), t.p) for t in terms
            ]
        self.C = [(mpmath.mpf(c) * L ** (mpmath.mpf(e) + 1) / (mm * vv), e) for c, e in law.terms()]
        self.hc = mpmath.mpf(law.alpha) * vv
        if law.A:
            self.C += [(mpmath.mpf(law.A) * vv / L * a * p, p - 1) for a, p in self.F]
        if law.zeta:
            a, p = self.F[0]
            self.C.append(
                (2 * mpmath.mpf(law.zeta) * mpmath.sqrt(a * (mpmath.mpf(p) + 1) / 2), (p - 1) / 2)
            )

        self._low = None  # `G_low`'s terms, formed on its first call

    def exps(self):
        return sorted({p for _, p in self.F} | {e for _, e in self.C})

    def FC_k(self, P, k, Qs=None, work=None):
        """Coefficient k of F and C given power series P[e] (each up to order k); for a cap
        also the series Qs of Q (up to order k) and ``work`` (its lists, kept across k)."""
        Fk = mpmath.fsum(a * P[p][k] for a, p in self.F)
        if self.cap is not None:
            Fk = self._cap_k(Fk, [-self.beta * x for x in Qs], k, work)
        Ck = mpmath.fsum(c * P[e][k] for c, e in self.C)
        if self.hc:
            Ck += self.hc * Fk
        return Fk, Ck

    def _cap_k(self, Fk, bq, k, work):
        """Coefficient k of (polynomial part, coefficient Fk) x y, y = (1 + bq)^alpha with
        bq the series of -beta Q (or -beta rho^N); ``work`` = [poly part, H, Y]."""
        Fp, H, Y = work
        Fp.append(Fk)
        H.append(1 + bq[0] if k == 0 else bq[k])
        Y.append(H[0] ** self.alpha if k == 0 else _pow_rec(H, Y, k, self.alpha))
        return _conv(Fp, Y, k)

    def G_low(self, r, V):
        """G / rho^j0 at rho = r >= 0 with speed V: sum_d (F_d y + C_d V) rho^(d - j0) over
        the degrees d in rho of F and C (q = L rho^N), j0 the lowest.

        Term by term, so that it keeps its sign at rho = 0 exactly (the exit: F_j0 + C_j0 V),
        where the series G of an exit step sums O(1) coefficients to a value at the working
        precision's round-off (~1e-45), which outweighs the force of a tiny overlap (C = c0 +
        c1 q with c0 = 3.6e-291: G(0) = c0 V ~ -1e-290) and can hide a zero-force end just
        before the exit (found: q = 1.9e-8 L, 5e-10 s before it on k q^3)."""
        if self._low is None:  # F and C by degree in rho, from the lowest
            terms = {}
            for a, p in self.F:
                d = int(round(self.N * p))
                f, c = terms.get(d, (0, 0))
                terms[d] = (f + a, c)
            for c_, e in self.C:
                d = int(round(self.N * e))
                f, c = terms.get(d, (0, 0))
                terms[d] = (f, c + c_)
            j0 = min(d for d, (f, c) in terms.items() if f != 0 or c != 0)
            self._low = [(d - j0, f, c) for d, (f, c) in sorted(terms.items())]
        y = (1 - self.beta * r**self.N) ** self.alpha if self.cap is not None else 1
        # C's Hunt-Crossley part hc F y: G = F y (1 + hc V) + C V
        return mpmath.fsum((f * y * (1 + self.hc * V) + c * V) * r**e for e, f, c in self._low)

    def FC_at(self, Q):
        F = mpmath.fsum(a * Q ** mpmath.mpf(p) for a, p in self.F)
        if self.cap is not None:
            F *= (1 - self.beta * Q) ** self.alpha
        C = mpmath.fsum(c * (Q ** mpmath.mpf(e) if e else 1) for c, e in self.C)
        return F, C + self.hc * F


def _mid_series(model, Q0, V0, K):
    """Series of Q, V and G = F + C V in t about a point with Q0 > 0."""
    exps = model.exps()
    P = {e: [Q0 ** mpmath.mpf(e) if e else mpmath.mpf(1)] for e in exps}
    Q, V, Fs, Cs, G = [Q0], [V0], [], [], []
    work = ([], [], [])
    for k in range(K):
        Fk, Ck = model.FC_k(P, k, Q, work)
        Fs.append(Fk)
        Cs.append(Ck)
        CVk = _conv(Cs, V, k)
        G.append(Fk + CVk)
        Q.append(V[k] / (k + 1))
        V.append(-(CVk + Fk) / (k + 1))
        n = k + 1
        for e in exps:
            if e == 0:
                P[e].append(mpmath.mpf(0))
                continue
            ee = mpmath.mpf(e)
            P[e].append(
                mpmath.fsum(((ee + 1) * j - n) * Q[j] * P[e][n - j] for j in range(1, n + 1))
                / (n * Q0)
            )
    return Q, V, G


def _rho_series(model, rc, sign, V0, S0, K):
    """Series in h of V, S (scaled time) and G = F + C V along rho = rc + sign h."""
    N = model.N

    def pow_series(n):
        # (rc + sign h)^n, n a non-negative integer: exact binomial series
        return [
            mpmath.binomial(n, k) * rc ** (n - k) * (sign**k) if k <= n else mpmath.mpf(0)
            for k in range(K + 1)
        ]

    Fser = [mpmath.mpf(0)] * (K + 1)
    for a, p in model.F:
        ps = pow_series(int(round(N * p)))
        Fser = [x + a * y for x, y in zip(Fser, ps, strict=False)]
    if model.cap is not None:  # times y = (1 - beta rho^N)^alpha
        bq = [-model.beta * x for x in pow_series(N)]
        work = ([], [], [])
        Fser = [model._cap_k(Fser[k], bq, k, work) for k in range(K + 1)]
    Cser = [mpmath.mpf(0)] * (K + 1)
    for c, e in model.C:
        ps = pow_series(int(round(N * e)))
        Cser = [x + c * y for x, y in zip(Cser, ps, strict=False)]
    if model.hc:
        Cser = [x + model.hc * y for x, y in zip(Cser, Fser, strict=False)]
    D = [sign * N * x for x in pow_series(N - 1)]  # dQ/dh
    V, S, R, G, H, J, DR = [V0], [S0], [], [], [], [], []
    for k in range(K):
        # reciprocal R = 1 / V: R_k = -(sum_{j>=1} V_j R_{k-j}) / V_0
        R.append(1 / V0 if k == 0 else -mpmath.fsum(V[j] * R[k - j] for j in range(1, k + 1)) / V0)
        G.append(Fser[k] + _conv(Cser, V, k))
        H.append(_conv(G, D, k))
        J.append(_conv(H, R, k))
        DR.append(_conv(D, R, k))
        V.append(-J[k] / (k + 1))
        S.append(DR[k] / (k + 1))
    return V, S, G


def _step(series_list, tol, h_max):
    """Step from a root-test radius of the last 16 coefficients of each series.

    r = min_k |c_k|^(-1/k) over k = K-15..K estimates the radius of convergence
    (the last one or two coefficients alone underestimate the tail when they
    decay unevenly: measured 1.7e-13 error with Tsuji's q^(1/4) at K = 48); the
    step h = r tol^(1/K) / 2 makes the truncation (h/r)^K <= tol 2^-K.
    """
    K = len(series_list[0]) - 1
    r = mpmath.inf
    for c in series_list:
        for k in range(K - 15, K + 1):
            if c[k] != 0:
                r = min(r, abs(c[k]) ** (-mpmath.mpf(1) / k))
    return min(mpmath.mpf(h_max), r * tol ** (mpmath.mpf(1) / K) / 2)


def _root(poly, lo, hi):
    """Root of a series (or a function of h) with a sign change on [lo, hi], by bisection
    to the working precision.

    (A secant-type `findroot` fails its residual test on the tiny force values near the
    exit, e.g. C = c q, where F = q (k sqrt(q) + c w) and the end point is a root too.)
    """
    g = poly if callable(poly) else (lambda x: _horner(poly, x))
    glo = g(lo)
    for _ in range(mpmath.mp.prec + 4):
        mid = (lo + hi) / 2
        if mid in (lo, hi):
            break
        gm = g(mid)
        if gm == 0:
            return mid
        if (gm > 0) == (glo > 0):
            lo, glo = mid, gm
        else:
            hi = mid
    return (lo + hi) / 2


def _first_crossing(poly, h):
    """Bracket of the first + to - sign change of a series (or a function of h) on [0, h]
    (32 samples), or None."""
    ev = poly if callable(poly) else (lambda x: _horner(poly, x))
    xs = [h * j / 32 for j in range(33)]
    prev = ev(xs[0])
    for j in range(1, 33):
        g = ev(xs[j])
        if prev > 0 and g < 0:
            return xs[j - 1], xs[j]
        if g > 0:
            prev = g
    return None


def _exit_force(model, r, Vs):
    """G / rho^j0 along an exit step from rho = r (`_Model.G_low`), as a function of the
    step's variable x: rho = r - x, 0 exactly at the end of the last step (x = h = r)."""
    return lambda x: model.G_low(r - x, _horner(Vs, x))


def _maxima(Gc, h, best):
    """Largest value of the series Gc on [0, h] at interior stationary points (or best)."""
    dG = _deriv_series(Gc)
    xs = [h * j / 16 for j in range(17)]
    vals = [_horner(dG, x) for x in xs]
    for j in range(16):
        if vals[j] > 0 and vals[j + 1] <= 0:
            x = _root(dG, xs[j], xs[j + 1]) if vals[j + 1] < 0 else xs[j + 1]
            best = max(best, _horner(Gc, x))
    return best


def solve_law_impact_mp(
    pot: Potential, m, v0, law, *, dps: int = 30, zero_force_only: bool = False
) -> dict:
    """High-precision reference for one impact under a damping law (power-law potentials).

    Parameters
    ----------
    pot : PowerLaw, SumPotential of PowerLaw, or a potential of one cap row
        U'(q) = sum k_i q^p_i, or a sphere's or ellipsoid's cap (`potentials.volumetric`;
        not with the viscoelastic or the universal law).
    m, v0 : float
        Mass (kg) and approach speed (m/s).
    law : DampingLaw or dict
        Any law of the table; ``universal`` for a single power law only.
    dps : int
        Decimal digits.
    zero_force_only : bool
        Stop at the zero-force end and return only time_of_max_penetration,
        max_penetration, contact_time_zero_force and restitution_zero_force: a truth for
        the bodies that never return (heavy damping), whose zero-force end is still reached.

    Returns
    -------
    dict of mpmath.mpf
        contact_time, restitution (q = 0 end), contact_time_zero_force,
        restitution_zero_force, max_penetration, max_force, peak_force,
        time_of_max_penetration.
    """
    law = law_from_dict(law)
    # Hunt-Crossley: F = U' (1 + alpha w) with 1 + alpha w > 0 until q = 0 (it decays like
    # exp(-(alpha/m) int U' dt), ~1e-70 at alpha v0 = 160), so the two ends coincide; a
    # search would find the working precision's round-off instead.
    search_zf = not law.decomposition().never_pulls
    cap = _cap_of(pot)
    terms = pot.terms if isinstance(pot, SumPotential) else (pot,)
    if cap is not None:
        if law.A or law.zeta:
            raise HCVInputError(
                "general-law truth on a cap: laws of C(q) and Hunt-Crossley only "
                f"(got {law.name!r})"
            )
        ps = [2 * float(cap[1]) + 1, 2 * float(cap[1]) + 2]
    elif not all(type(t) is PowerLaw for t in terms):
        raise HCVInputError(
            "general-law truth: power-law potentials (and sums of them) or one cap only"
        )
    else:
        ps = [t.p for t in terms]
    if law.zeta and len(terms) != 1:
        raise HCVInputError("general-law truth: the universal law for a single power law only")
    ex = list(ps) + [e for _, e in law.terms()]
    if law.A:
        ex += [p - 1 for p in ps]
    if law.zeta:
        ex += [(ps[0] - 1) / 2]
    N = _common_n(ex)
    Lf = pot.turning_point(0.5 * m * v0 * v0)
    with mpmath.workdps(dps + _GUARD):
        L = mpmath.mpf(Lf)
        model = _Model(pot, m, v0, law, L, N)
        tol = mpmath.mpf(10) ** (-(dps + 8))
        K = _K
        one = mpmath.mpf(1)
        # C(0) v0 (scaled: C(0) * 1), the force just after contact
        peak = mpmath.fsum(c for c, e in model.C if e == 0)
        nsteps = 0

        # ---- entry: rho from 0 to rho1 -------------------------------------------
        Q1 = mpmath.mpf("0.1")
        while True:
            r1 = Q1 ** (one / N)
            r, V, S = mpmath.mpf(0), one, mpmath.mpf(0)
            ok = True
            while r < r1:
                Vs, Ss, Gs = _rho_series(model, r, 1, V, S, K)
                h = _step([Vs, Ss], tol, r1 - r)
                peak = _maxima(Gs, h, peak)
                V, S, r = _horner(Vs, h), _horner(Ss, h), r + h
                nsteps += 1
                if V < mpmath.mpf("0.5"):
                    ok = False
                    break
            if ok:
                break
            Q1 /= 4
            if Q1 < mpmath.mpf("1e-8"):
                raise HCVInputError(
                    "general-law truth: the damping stops the body at contact onset"
                )
        # ---- middle ---------------------------------------------------------------
        t, Q = S, Q1
        s_max = Qm = t_zf = V_zf = None
        while True:
            nsteps += 1
            if nsteps > _MAX_STEPS:
                raise HCVInputError(
                    "general-law truth: the body does not return (not a truth case)"
                )
            Qs, Vs, Gs = _mid_series(model, Q, V, K)
            h = _step([Qs, Vs], tol, mpmath.mpf(1))
            # q^p is analytic through q = 0 for integer p (Hooke): the radius does not stop
            # the step there, so keep the step end at q > 0 explicitly.
            while _horner(Qs, h) <= 0:
                h /= 2
            peak = _maxima(Gs, h, peak)
            Qn, Vn = _horner(Qs, h), _horner(Vs, h)
            Fend = _horner(Gs, h)
            if s_max is None and Vn < 0:
                x = _root(Vs, 0, h)
                s_max, Qm = t + x, _horner(Qs, x)
            if search_zf and s_max is not None and t_zf is None and Fend <= 0:
                br = _first_crossing(Gs, h) or (0, h)
                x = _root(Gs, *br)
                t_zf, V_zf = t + x, _horner(Vs, x)
                if zero_force_only:
                    tau = L / mpmath.mpf(v0)
                    return {
                        "time_of_max_penetration": +(s_max * tau),
                        "max_penetration": +(Qm * L),
                        "contact_time_zero_force": +(t_zf * tau),
                        "restitution_zero_force": +(-V_zf),
                    }
            t, Q, V = t + h, Qn, Vn
            if s_max is not None and V < 0:
                F, _ = model.FC_at(Q)
                if Q <= Qm / 10 and F * Q <= V * V / 2:
                    break
        # ---- exit: rho from Q^(1/N) down to 0 ----------------------------------------
        r = Q ** (one / N)
        S = t
        while r > 0:
            nsteps += 1
            Vs, Ss, Gs = _rho_series(model, r, -1, V, S, K)
            h = _step([Vs, Ss], tol, r)
            if h >= r * (1 - mpmath.mpf(10) ** (-dps - 5)):
                h = r
            peak = _maxima(Gs, h, peak)
            if search_zf and t_zf is None:
                # the zero-force function G / rho^j0 from the model term by term (`G_low`),
                # not the series Gs: its sign holds down to rho = 0 exactly, the last step's end
                gz = _exit_force(model, r, Vs)
                br = _first_crossing(gz, h) if gz(0) > 0 else None
                if br is not None:
                    x = _root(gz, *br)
                    t_zf, V_zf = _horner(Ss, x), _horner(Vs, x)
            V, S, r = _horner(Vs, h), _horner(Ss, h), r - h
        if t_zf is None:  # the force never pulls: the two ends coincide
            t_zf, V_zf = S, V
        scale_F = mpmath.mpf(m) * mpmath.mpf(v0) ** 2 / L
        tau = L / mpmath.mpf(v0)
        out = {
            "contact_time": S * tau,
            "restitution": -V,
            "contact_time_zero_force": t_zf * tau,
            "restitution_zero_force": -V_zf,
            "max_penetration": Qm * L,
            "max_force": model.FC_at(Qm)[0] * scale_F,
            "peak_force": peak * scale_F,
            "time_of_max_penetration": s_max * tau,
            "n_steps": nsteps,
        }
        return {k_: (+v if isinstance(v, mpmath.mpf) else v) for k_, v in out.items()}
