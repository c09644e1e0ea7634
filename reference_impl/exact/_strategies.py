"""How `solve_impact` integrates one impact: an ordered tuple of strategies (issue 27, goal 7).

Each strategy is a function ``plan(job) -> Answer | None`` with one contract:

1. ``job`` is a `Job`: the potential, mass, speed, `VirtualOscillator`, the validated
   turning point q_top (every overlap of the impact lies in (0, q_top]), the
   requested tanh-sinh level (None: the solver's choice) and the requested accuracy
   ``rtol`` (None: full; `_rtol`, read by `power_law` and, for a single cap, `fused`).
2. It returns None when it does not apply to the job, or when it refuses it (e.g. its
   two rule sizes disagree), and has then changed nothing.
3. Otherwise it returns an `Answer`: the `Branches` (three times and bounds on their
   errors from quadrature and round-off), q_max and U'(q_max). The conditioning of the
   turning point, the bound check and the result are `solve_impact`'s, the same for all.
4. `solve_impact` tries `STRATEGIES` in order and takes the first answer; the last,
   `general`, answers every job (or raises its own one-line error).

The order is the solver's preference: a power law's Gauss-Jacobi rule in one compiled
call, the split quadrature (Gauss-Jacobi first) where a
sum's terms hand over inside the contact, else the fused compiled kernel of `_one_call`,
else the general path of `_branches` (tanh-sinh level by level, the overdamped tail).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reference_impl.exact._branches import (
    _GJ_ZETA_MAX,
    Branches,
    branch_integrals,
    compiled_nodes,
)
from reference_impl.exact._one_call import fused_impact, gauss_jacobi_impact
from reference_impl.exact._oscillator import VirtualOscillator
from reference_impl.exact._power_kernel import OUT_SIZE, power_constants, power_impact
from reference_impl.exact._rtol import power_rungs
from reference_impl.exact._split import needs_split, split_impact
from reference_impl.exact._validate import _validated_top
from reference_impl.potentials.base import Potential
from reference_impl.potentials.power import PowerLaw

__all__ = ["Answer", "Job", "STRATEGIES", "choose"]


class Answer(NamedTuple):
    """What a strategy returns: the branch times and bounds, q_max (m) and U'(q_max) (N)."""

    branches: Branches
    max_penetration: float
    max_force: float


class Job:
    """One impact to integrate (item 1 of the contract); ``split`` is decided on first use.

    ``q_top`` None: this energy lies at or below one validated for the potential already
    (`_validate._validated_below`), and its own turning point is computed on first use
    (`_validate._validated_top`, the same value): a power law's Gauss-Jacobi strategy
    never reads it, and its numeric inverse was ~3.3 of a one-shot call's ~14 us (issue 38).
    """

    __slots__ = ("potential", "m", "v0", "osc", "_q_top", "level", "rtol", "_split")

    def __init__(self, potential, m, v0, osc: VirtualOscillator, q_top, level, rtol=None):
        self.potential, self.m, self.v0, self.osc = potential, m, v0, osc
        self._q_top, self.level, self.rtol = q_top, level, rtol
        self._split = None

    @property
    def q_top(self) -> float:
        """The validated turning point of this impact's energy m v0^2 / 2 (m)."""
        if self._q_top is None:
            # The energy as `solve_impact` forms it (the same bits).
            self._q_top = _validated_top(self.potential, 0.5 * self.m * self.v0 * self.v0)
        return self._q_top

    @property
    def own_rules(self) -> bool:
        """True when the solver picks the rules (no level given) for a non-power-law."""
        return self.level is None and type(self.potential) is not PowerLaw

    @property
    def split(self) -> bool:
        """Terms hand over inside this (underdamped) contact (`_split.needs_split`)."""
        if self._split is None:
            pot, m, v0, q_top = self.potential, self.m, self.v0, self.q_top
            self._split = self.osc.zeta < 1.0 and needs_split(
                pot, lambda: turning_point(pot, m, v0, q_top), q_top
            )
        return self._split


def turning_point(pot: Potential, m: float, v0: float, q_top: float) -> float:
    """q with U(q) = m v0^2 / 2 (compiled inverse inside (0, q_top] when available)."""
    compiled = compiled_nodes(pot)
    if compiled is not None:
        return float(compiled(np.array([v0]), m, q_top)[1][0])
    return float(pot._inverse(np.array([0.5 * m * v0 * v0]))[0])


def peak(pot: Potential, m: float, osc: VirtualOscillator, q_top: float) -> tuple[float, float]:
    """q_max and U'(q_max): x(s_peak) = v0 exp(-zeta s_peak) (S(s_peak) = 1, see _oscillator)."""
    x_peak = osc.v0 * math.exp(-osc.zeta * osc.s_peak)
    if type(pot) is PowerLaw:
        n = pot.leading_exponent
        # Factored so that no intermediate leaves the normal range before the root
        # (0.5 n m x^2 / k underflows for m = 1e-300 even when q_max is a normal number).
        q_max = (0.5 * n * m / pot.k) ** (1.0 / n) * x_peak ** (2.0 / n)
        return q_max, pot.k * q_max**pot.p
    compiled = compiled_nodes(pot)
    if compiled is not None:
        g_pk, q_pk = compiled(np.array([x_peak]), m, q_top)
        return float(q_pk[0]), m * x_peak / float(g_pk[0])
    q_max = float(pot._inverse(np.array([0.5 * m * x_peak**2]))[0])
    return q_max, float(pot._dU(np.array([q_max]))[0])


def power_law(job: Job) -> Answer | None:
    """A power law by Gauss-Jacobi in one compiled call (`_power_kernel`), whatever the
    tanh-sinh level asked (the level is that of `general`'s rules, used when this refuses);
    with ``job.rtol``, the smaller pairs that reach it first (`_rtol`)."""
    pot, osc = job.potential, job.osc
    if type(pot) is not PowerLaw or osc.zeta >= _GJ_ZETA_MAX:
        return None
    out = np.empty(OUT_SIZE)
    if job.rtol is not None:
        # Smaller rule pairs first (`_rtol.power_rungs`), each kept only when every bound
        # is within rtol of its time; then the full-accuracy pair below.
        for sizes in power_rungs(job.rtol):
            consts = power_constants(pot, job.m, sizes, job.rtol)
            if consts is None:
                break
            power_impact(job.v0, osc.zeta, *consts, job.rtol, 0.0, out)
            if out[13] == 1.0:
                v = out.tolist()
                return Answer(Branches(*v[:6]), v[6], v[7])
    consts = power_constants(pot, job.m)
    if consts is None:
        return None
    # inf and 0: no bound or range refusal here; solve_impact checks (and names) them.
    power_impact(job.v0, osc.zeta, *consts, math.inf, 0.0, out)
    if out[13] != 1.0:
        return None
    v = out.tolist()
    return Answer(Branches(*v[:6]), v[6], v[7])


def split_gauss_jacobi(job: Job) -> Answer | None:
    """Terms hand over inside the contact: Gauss-Jacobi in t = d^(1/b) when its two rule
    sizes agree (`_one_call.gauss_jacobi_impact`)."""
    if not (job.own_rules and job.split):
        return None
    fast = gauss_jacobi_impact(job.potential, job.m, job.osc, job.q_top)
    return None if fast is None else Answer(*fast)


def split_quadrature(job: Job) -> Answer | None:
    """Terms hand over inside the contact: the quadrature split at the hand-over (`_split`)."""
    if not (job.own_rules and job.split):
        return None
    br = split_impact(job.potential, job.m, job.osc, job.q_top)
    return Answer(br, *peak(job.potential, job.m, job.osc, job.q_top))


def fused(job: Job) -> Answer | None:
    """A compiled family in one compiled call (`_one_call.fused_impact`; with ``job.rtol``,
    a single cap's Gauss-Jacobi pair that meets it)."""
    if not job.own_rules or job.split:
        return None
    fast = fused_impact(job.potential, job.m, job.osc, job.q_top, job.rtol)
    return None if fast is None else Answer(*fast)


def general(job: Job) -> Answer:
    """Every other impact: `_branches.branch_integrals` and the peak."""
    pot, m, osc, q_top = job.potential, job.m, job.osc, job.q_top
    br = branch_integrals(pot, m, osc, job.level, q_top)
    return Answer(br, *peak(pot, m, osc, q_top))


STRATEGIES = (power_law, split_gauss_jacobi, split_quadrature, fused, general)


def choose(job: Job) -> tuple[str, Answer]:
    """The first strategy's answer (item 4 of the contract), with the strategy's name."""
    for plan in STRATEGIES:
        answer = plan(job)
        if answer is not None:
            return plan.__name__, answer
    raise AssertionError("the last strategy answers every job")  # pragma: no cover
