"""Branch integrals split at the hand-over between a potential's terms (issue 22).

In virtual time the integrand dq/dx of `_branches` behaves like d^beta near a
singular end only while the leading term of U dominates. For a sum whose
higher terms take over inside the contact (U' = 1e-12 q^0.01 + q^20), the
hand-over lies at a virtual distance d_c = x_c / v0 from the end that can be
1e-8 of the branch or less: the integrand changes from d^0.98 to d^-0.9 there,
the fixed rules of `_branches` put the analytic end correction (which assumes
the leading law) above d_c, and the contact time was off by 6 %, with an error
estimate that did not see it.

In the overlap q the same integral has no such scale: dt = dq / x'(s) with s
the virtual time at which x(s) = sqrt(2 U(q) / m), and near the singular end
x'(s) -> v0 (1/x' = 1/v0 (1 + O(x/v0)), whatever the terms of U do). Each
branch is therefore cut where x is a fixed fraction of its peak:

* the part near x = 0 is integrated in q (tanh-sinh on [0, q_a], nodes as
  distances from q = 0; s(q) from the elementary x(s));
* the part near the peak, where x'(s) -> 0 and q would carry an inverse
  square root, stays in s (a smooth integrand: x is bounded away from 0).

Used (`needs_split`) for sums whose terms hand over deep inside the contact,
where the rules of `_branches` cannot resolve it, for 0 <= zeta <= SPLIT_ZETA_MAX.
s(q) comes from Newton on log x, which is concave in s on both branches. The
reported errors are the rules' fine-minus-coarse estimates, the first node's
share, the round-off of the sums and of the node values, and the mismatch of the
cut (q_a is known to a few ulps).
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from reference_impl.errors import UnsupportedError
from reference_impl.exact._branches import (
    _EPS,
    _NODE_ULPS,
    _PIECE,
    Branches,
    _checked,
    compiled_nodes,
    dq_dx,
    level_up,
    per_potential,
)
from reference_impl.exact._nodes import _TERM_POWER, _term_rows, _terms_eval
from reference_impl.exact._one_call import _term_ratio
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._quadrature import pairwise_ulps, rule
from reference_impl.exact._sums import ts_pairwise
from reference_impl.potentials.base import Potential

__all__ = ["SPLIT_SHARE", "SPLIT_ZETA_MAX", "higher_share", "needs_split", "split_impact"]

# Where each branch is cut, as a fraction of the virtual time from its singular
# end to the peak: x there is ~0.7 of its peak (zeta = 0), far from both ends, so
# the s-part is smooth and the q-part's 1/x' stays below ~1.5/v0.
_CUT = 0.5
# Newton steps allowed for s(q); from the tangent start each converges in ~3-5.
_NEWTON_MAX = 60
# Relative step at which s(q) is taken as converged: a few ulps.
_NEWTON_RTOL = 4.0 * _EPS


def _solve_log_concave(logF, dlogF, log_X, start):
    """d >= start with logF(d) = log_X, for logF increasing and concave and start <= d.

    Newton from the left on a concave increasing function never overshoots: the
    iterates rise monotonically to the root (quadratically once close).
    """
    d = start
    for _ in range(_NEWTON_MAX):
        with np.errstate(all="ignore"):
            step = (logF(d) - log_X) / dlogF(d)
        step = np.where(np.isfinite(step) & (step < 0), step, 0.0)
        d = d - step
        if np.all(-step <= _NEWTON_RTOL * d):
            return d
    raise UnsupportedError(
        f"split quadrature: the virtual time of a node did not converge in {_NEWTON_MAX} "
        "Newton steps; use solve_impact_mp"
    )


class _Split:
    """The pieces of one impact; ``run(level)`` gives its `Branches` at a rule level."""

    def __init__(self, pot: Potential, m: float, osc: VirtualOscillator, q_top: float):
        self.pot, self.m, self.osc, self.q_top = pot, m, osc, q_top
        self.compiled = compiled_nodes(pot)

    # -- node values -------------------------------------------------------
    def g_and_q(self, x):
        """dq/dx and q at virtual displacements x (in order along a branch)."""
        with np.errstate(all="ignore"):
            if self.compiled is not None:
                g, q = self.compiled(x, self.m, self.q_top)
            else:
                g = dq_dx(self.pot, self.m, x, self.osc.v0)
                q = None
        _checked(g, x, self.osc, self.pot)
        return g, q

    def q_of(self, x: float) -> float:
        g, q = self.g_and_q(np.array([x]))
        if q is None:
            return float(self.pot._inverse(np.array([0.5 * self.m * x * x]))[0])
        return float(q[0])

    # -- oscillator, from either end ----------------------------------------
    # x(s) = v0 exp(-zeta s) sin(wd s) / wd; on the rising branch from s = 0 and on
    # the falling one by the distance d from s_end. log x is concave in both (a
    # linear term plus log sin), which `_solve_log_concave` relies on.
    def rise_x(self, s):
        return self.osc.x(s)

    def rise_dx(self, s):
        return self.osc.dx(s)

    def rise_logx(self, s):
        o = self.osc
        return math.log(o.v0) - o.zeta * s + np.log(np.sin(o.wd * s) / o.wd)

    def rise_dlogx(self, s):
        o = self.osc
        return -o.zeta + o.wd / np.tan(o.wd * s)

    def rise_start(self, log_X, hi):
        """A lower bound of s(X): exp(-zeta s) <= 1 on the branch."""
        o = self.osc
        return np.arcsin(np.minimum(np.exp(log_X) * o.wd / o.v0, 1.0)) / o.wd

    def fall_x(self, d):
        return self.osc.x_from_end(d)

    def fall_dx(self, d):
        """-x'(s_end - d) > 0 on the falling branch, accurate for small d."""
        o = self.osc
        wd = o.wd
        return (
            o.v0
            * np.exp(-o.zeta * (o.s_end - d))
            * (np.cos(wd * d) + o.zeta * (np.sin(wd * d) / wd))
        )

    def fall_logx(self, d):
        o = self.osc
        return math.log(o.v0) - o.zeta * (o.s_end - d) + np.log(np.sin(o.wd * d) / o.wd)

    def fall_dlogx(self, d):
        o = self.osc
        return o.zeta + o.wd / np.tan(o.wd * d)

    def fall_start(self, log_X, hi):
        """A lower bound of d(X) on [0, hi]: exp(-zeta (s_end - d)) <= exp(-zeta (s_end - hi))."""
        o = self.osc
        amp = o.v0 * math.exp(-o.zeta * (o.s_end - hi)) / o.wd
        return np.arcsin(np.minimum(np.exp(log_X) / amp, 1.0)) / o.wd

    # -- pieces ----------------------------------------------------------------
    def s_piece(self, x_of, a: float, b: float, r):
        """int_a^b dq/dx(x(d)) dd for a smooth stretch (x > 0 throughout)."""
        if not b > a:
            return 0.0, 0.0
        # Pieces of at most _PIECE of virtual time: x(s) varies on a unit scale, and
        # near zeta = 1 the falling branch is ~pi / sqrt(1 - zeta^2) long.
        pieces = max(1, math.ceil((b - a) / _PIECE))
        h = (b - a) / pieces
        val = err = 0.0
        for i in range(pieces):
            g, _ = self.g_and_q(x_of(a + i * h + h * r.d))
            v, e = _sum(g, h, r)
            val, err = val + v, err + e
        return val, err

    def q_piece(self, branch: str, d_hi: float, q_lo: float, q_hi: float, r):
        """int_{q_lo}^{q_hi} dq / |x'| with d(q) in [0, d_hi] solving x(d) = sqrt(2U/m)."""
        L = q_hi - q_lo
        if not L > 0:
            return 0.0, 0.0
        logx, dlogx, start, dx = (
            getattr(self, f"{branch}_{k}") for k in ("logx", "dlogx", "start", "dx")
        )
        q = q_lo + L * r.d
        with np.errstate(all="ignore"):
            log_X = 0.5 * np.log(2.0 * self.pot._U(q) / self.m)
        d = _solve_log_concave(logx, dlogx, log_X, start(log_X, d_hi))
        with np.errstate(all="ignore"):
            h = 1.0 / dx(d)
        _checked(h, np.exp(log_X), self.osc, self.pot)
        return _sum(h, L, r)

    def run(self, level: int):
        o = self.osc
        r = rule(level, 0.0)
        sp = o.s_peak
        # Rising branch: q-part on [0, s_a], s-part on [s_a, s_peak].
        s_a = _CUT * sp
        q_a = self.q_of(float(self.rise_x(s_a)))
        up, e_up = self.s_piece(self.rise_x, s_a, sp, r)
        lo, e_lo = self.q_piece("rise", s_a, 0.0, q_a, r)
        cut = _cut_error(q_a, float(self.rise_dx(s_a)))
        rise, e_rise = up + lo, e_up + e_lo + cut
        if o.zeta == 0.0:
            return (Branches(rise, e_rise, rise, e_rise, rise, e_rise),)
        # Falling branch, by distance d from s_end: s-part on [d_b, D], q-part below d_b.
        D = o.s_end - sp
        # Cut where x is still ~linear in d (as on the rising branch): near zeta = 1
        # the fall is long and x grows like exp(zeta d), which in q would be a
        # near-singular 1/q^(n/2) over many decades; the rest is in s, in pieces.
        d_b = _CUT * min(D, sp)
        q_b = self.q_of(float(self.fall_x(d_b)))
        up, e_up = self.s_piece(self.fall_x, d_b, D, r)
        lo, e_lo = self.q_piece("fall", d_b, 0.0, q_b, r)
        cut = _cut_error(q_b, float(self.fall_dx(d_b)))
        fall, e_fall = up + lo, e_up + e_lo + cut
        # Peak to the zero-force instant 2 s_peak, i.e. d in [lz, D].
        lz = o.zero_force_stretch
        if lz >= d_b:
            mid, e_mid = self.s_piece(self.fall_x, lz, D, r)
        else:
            q_z = self.q_of(float(self.fall_x(lz))) if lz > 0 else 0.0
            lo, e_lo = self.q_piece("fall", d_b, q_z, q_b, r)
            mid, e_mid = up + lo, e_up + e_lo + cut + _cut_error(q_z, float(self.fall_dx(lz)))
        return (Branches(rise, e_rise, mid, e_mid, fall, e_fall),)


def _cut_error(q_cut: float, speed: float) -> float:
    """Time error from the cut's overlap being known to _NODE_ULPS ulps: dq / x'."""
    return _NODE_ULPS * _EPS * q_cut / speed


def _sum(f, L: float, r):
    """Value and error bound (quadrature + round-off) of int_0^L f over the rule's nodes
    (`_sums.ts_pairwise`: f is regular at 0 here, beta = 0)."""
    v, e = np.empty(1), np.empty(1)
    f = np.ascontiguousarray(f, dtype=float).reshape(1, -1)
    ulps = pairwise_ulps(r.w.size) + _NODE_ULPS
    ts_pairwise(f, np.array([float(L)]), r.w, r.w_diff, r.d[0], 0.0, ulps, v, e)
    return float(v[0]), float(e[0])


def split_impact(pot: Potential, m: float, osc: VirtualOscillator, q_top: float):
    """`Branches` of one impact by the split quadrature (zeta <= SPLIT_ZETA_MAX, else
    UnsupportedError).

    Levels from `_branches.COMPILED_LEVEL` up while the bound exceeds
    `_branches._LEVEL_UP_RTOL` (`_branches.level_up`).
    """
    if osc.zeta > SPLIT_ZETA_MAX:
        raise UnsupportedError(
            f"damping ratio zeta = {osc.zeta!r} above {SPLIT_ZETA_MAX:g} for a sum whose terms hand "
            f"over deep inside the contact ({pot!r}): the split quadrature is checked against the "
            "truth only up to there; use solve_impact_mp"
        )
    sp = _Split(pot, m, osc, q_top)
    return level_up(sp.run)[0]


# Share of U(q_top) carried by terms above the leading exponent beyond which the
# hand-over between terms lies inside the contact and the split quadrature is used
# (when the Gauss-Jacobi rules did not accept the impact). Below it the higher
# terms change dq/dx by less than this fraction, smoothly near the peak, which the
# rules of `_branches` resolve (measured on the issue-22 scan, see the tests).
SPLIT_SHARE = 1e-3
# ... and only when the hand-over lies deep in the contact: the higher terms still
# carry that share where x = _SPLIT_RHO v0 (U = _SPLIT_RHO^2 E). The unsplit rules of
# `_branches` resolve a hand-over near the peak, and a deep one that is smooth
# (log-rate kappa = 2 (n_max - n_lead) / n_lead of the term ratio in log x at most
# _SMOOTH_KAPPA) as long as it lies above their first node (virtual distance ~1e-16
# of the branch; _TAIL_RHO leaves a margin), where the analytic end correction
# assumes the leading law. Measured on the issue-22 scan and 150 random sums with
# the split disabled: every hand-over at x >= 0.06 v0 and every deep one with
# kappa <= 2.7 above 1e-12 was within 1e-13 and its bound; sharper or deeper ones
# were off (up to 7 %) or refused.
_SPLIT_RHO = 0.05
# Largest damping ratio of the split path: checked against solve_impact_mp at
# zeta = 0.1-0.95 (errors <= 7e-16, within the bounds); nearer 1 the falling branch
# grows long (pi / sqrt(1 - zeta^2)) and it was not checked, so it is refused.
SPLIT_ZETA_MAX = 0.95
_SMOOTH_KAPPA = 2.0
_TAIL_RHO = 1e-12
_ROWS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _rows_of(pot: Potential):
    rows = _term_rows(pot)
    return None if rows is None else np.array(rows, dtype=float)


def needs_split(pot: Potential, q_of_energy, q_top: float) -> bool:
    """True when a sum's higher terms take over from the leading one where only the
    split quadrature resolves it (see SPLIT_SHARE, _SPLIT_RHO, _SMOOTH_KAPPA).

    ``q_of_energy()`` gives the undamped turning point of the impact (called only
    when needed) and ``q_top`` >= it the validated bracket: the decision depends on
    this impact alone, never on which energies were validated before (the cached
    bracket), so batch and single calls agree.
    """
    info = per_potential(_INFO, _split_info, pot)
    if info is None:
        return False
    # The decision is increasing in the overlap (each share is): a False at q_top,
    # which bounds the turning point from above, is the answer at the turning point
    # too, and the turning point is computed only when q_top says True. The largest
    # overlap found False is kept (info[3]), so repeated impacts skip the shares.
    if q_top <= info[3][0]:
        return False
    if not _decide(info, q_top):
        info[3][0] = max(info[3][0], q_top)
        return False
    return _decide(info, q_of_energy())


def _decide(info, q: float) -> bool:
    share, n_max, kappa, _ = info
    if share(q) <= SPLIT_SHARE:
        return False
    # Every exponent is <= n_max, so U(q r^(2/n_max)) >= r^2 U(q): the true overlap of
    # the energy r^2 U(q) is no larger, and the share (increasing in q) is over-estimated
    # there (conservative: it errs toward the split).
    if share(q * _SPLIT_RHO ** (2.0 / n_max)) <= SPLIT_SHARE:
        return False
    if kappa > _SMOOTH_KAPPA:
        return True
    return share(q * _TAIL_RHO ** (2.0 / n_max)) > SPLIT_SHARE


_INFO: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _split_info(pot: Potential):
    """(share(q), n_max, kappa, [largest q decided False]) of a sum with more than one
    exponent, else None.

    share(q) is `higher_share`, by one compiled call for the table form."""
    n = float(pot.leading_exponent)
    P = _rows_of(pot)
    if P is not None:
        exps = [
            P[i, 2] if P[i, 0] == _TERM_POWER else 2.0 * (P[i, 2] + 1.0) for i in range(P.shape[0])
        ]
        if max(exps) == n:
            return None

        def share(q, P=P, n=n):
            r = _term_ratio(P, n, q)
            return r / (1.0 + r)

    else:
        terms = getattr(pot, "terms", None)
        if terms is None:
            return None
        exps = [t.leading_exponent for t in terms]

        def share(q, pot=pot):
            return higher_share(pot, q)

    n_max = float(max(exps))
    if n_max == n:
        return None
    return share, n_max, 2.0 * (n_max - n) / n, [0.0]


def higher_share(pot: Potential, q: float) -> float:
    """Fraction of U(q) from terms whose exponent exceeds the leading one (0 when the
    potential is not a sum of terms with known exponents)."""
    n = pot.leading_exponent
    P = per_potential(_ROWS, _rows_of, pot)
    if P is not None and P.shape[0] > 1:
        lead = rest = 0.0
        for i in range(P.shape[0]):
            ni = P[i, 2] if P[i, 0] == _TERM_POWER else 2.0 * (P[i, 2] + 1.0)
            u = _terms_eval(q, P[i : i + 1])[0]
            if ni == n:
                lead += u
            else:
                rest += u
        total = lead + rest
        return rest / total if total > 0 else 0.0
    terms = getattr(pot, "terms", None)
    if terms is None:
        return 0.0
    qa = np.array([q])
    u = [float(t._U(qa)[0]) for t in terms]
    rest = sum(ui for ui, t in zip(u, terms, strict=True) if t.leading_exponent != n)
    total = sum(u)
    return rest / total if total > 0 else 0.0
