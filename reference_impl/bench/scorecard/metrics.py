"""Scorecard metrics: what is measured on a trajectory, the exact references, and the rules.

Each metric is a named object (as pytest-benchmark's regression checks are):
a ``name``, the ``key`` of its table in the tolerances file and the tolerance
``field`` it reads, a one-line ``description``, ``applies(ctx)`` (a reason to
skip, or None) and ``evaluate(ctx, tol) -> MetricResult`` with pass / fail and,
on failure, a one-line explanation naming the worst speed.

Two verdicts (issue 26; ``Metric.verdict``): the *delivery* metrics
(``restitution_asked``, ``contact_time_asked``, ``peak_force_asked``, in
`reference_impl.bench.scorecard._delivery`) compare the code with what the scene asks (its own
law solved exactly) under a fixed tolerance, and split each error into a model part
and a step part; every other metric is an *implementation* metric, defined here.

References: every implementation metric compares the code with the
exact solution of the law the code *implements* (`ImplementedLaw`): the
harmonic-map solver `reference_impl.solve_impact` when that law is the
universal one (any Tsuji-type q^((p-1)/2) damping of a power law is), else the
damped ODE by DOP853 at rtol 1e-12 (`reference_impl.integrators.ivp`). A code
that clips tensile force ends its contact when the total force vanishes; its
references are taken at that end (restitution_zero_force), then free flight to
q = 0.

The rule every metric follows (limit = base + factor x allowance, read at the worst
speed) is `reference_impl.bench.scorecard._rules.Metric`; the records they read
(`SpeedRecord`, `SceneContext`) and write (`MetricResult`) are in
`reference_impl.bench.scorecard._records`, importable from here.
"""

from __future__ import annotations

import math

import numpy as np

from reference_impl.bench.measure import check_conventions, exact_reference, measure
from reference_impl.bench.scorecard._delivery import (
    ContactTimeAsked,
    PeakForceAsked,
    RestitutionAsked,
)
from reference_impl.bench.scorecard._law_checks import (
    Extrapolated,
    ForceLaw,
    StepRefinementMetric,
)
from reference_impl.bench.scorecard._records import MetricResult, SceneContext, SpeedRecord
from reference_impl.bench.scorecard._rules import (
    _NO_CONVERGENCE,
    Metric,
    _allowance,
    _Internal,
    _Missing,
    _need,
    _Skip,
)

__all__ = [
    "METRICS",
    "MetricResult",
    "SceneContext",
    "SpeedRecord",
    "check_conventions",
    "exact_reference",
    "measure",
    "metric_names",
]


# ----------------------------------------------------------------------------
# metrics
# ----------------------------------------------------------------------------
class _RelativeToExact(Metric):
    """|measured - exact| / exact of one quantity, worst speed."""

    quantity = ""
    field = "rtol"

    @property
    def rule(self):
        return f"|{self.quantity} - exact| / exact of the implemented law, every speed, <= limit"

    def _evaluate(self, ctx, base, factor):
        rows = []
        for rec in ctx.speeds:
            if self.quantity != "max_penetration" and _never_returns(rec):
                rows.append(self._no_return_row(rec))
                continue
            meas, ex = _need(rec, self.quantity)
            ref = ex.get(self.quantity, math.nan)
            got = meas[self.quantity]
            err = abs(got - ref) / abs(ref) if ref else math.inf
            rows.append((rec, got, ref, err, _allowance(rec, self.quantity)))

        def why(rec, got, ref, err, lim):
            law = rec.law.description if rec.law is not None else ""
            return (
                f"{self.quantity.replace('_', ' ')} {got:.7g}{self.unit} at v0 = "
                f"{rec.v0:g} m/s, exact {ref:.7g}{self.unit} for the implemented law "
                f"({law}): error {err:.3g} > {lim:.3g}"
            )

        return self._worst(ctx, rows, base, factor, why)

    def _no_return_row(self, rec):
        """The row of a speed where the implemented law never returns to q = 0.

        Its exact answer is no rebound (e = 0, contact time inf): a run that did not
        separate within its step budget agrees (error 0); one that separated fails
        (error inf: no relative error to a value that does not exist). No step allowance.
        """
        meas = rec.measured or {}
        ref = rec.exact[self.quantity]
        if meas.get("separated"):
            return (rec, float(meas.get(self.quantity, math.nan)), ref, math.inf, 0.0)
        return (rec, ref, ref, 0.0, 0.0)


def _never_returns(rec) -> bool:
    """The law the code implements never brings the body back to q = 0 (overdamped)."""
    ok = not (rec.error or rec.internal) and rec.exact is not None
    return ok and not math.isfinite(rec.exact["contact_time"])


class RestitutionExact(_RelativeToExact):
    name = key = "restitution_exact"
    quantity = "restitution"
    description = "restitution against the exact value of the law the code implements"


class MaxPenetration(_RelativeToExact):
    name = key = "max_penetration"
    quantity = "max_penetration"
    unit = " m"
    description = "maximum overlap against the exact solution"


class ContactTime(_RelativeToExact):
    name = key = "contact_time"
    quantity = "contact_time"
    unit = " s"
    description = "contact duration (overlap back to 0) against the exact solution"


class RestitutionSpread(Metric):
    name = key = "restitution_v0_spread"
    field = "rtol"
    description = "dependence of the restitution on the impact speed (Theorem 3: none)"
    rule = "(max e - min e) / mean e over the scene's speeds <= limit (Theorem 3: 0)"

    def applies(self, ctx):
        base = super().applies(ctx)
        if base:
            return base
        if len(ctx.speeds) < 2:
            return "needs at least two impact speeds"
        if ctx.speed_dependent:
            return (
                f"the scene's {ctx.speed_dependent!r} damping law has a speed-dependent "
                "restitution (Theorem 3 holds for the universal law); restitution_exact "
                "checks e at each speed"
            )
        return None

    def _evaluate(self, ctx, base, factor):
        es = []
        allow = 0.0
        for rec in ctx.speeds:
            meas, ex = _need(rec, "restitution", exact=False)
            es.append((meas["restitution"], rec.v0, ex.get("restitution", math.nan)))
            if rec.exact is not None:
                # each speed's error may differ in sign: the spread of a correct code is
                # at most twice its largest relative error
                allow = max(allow, 2.0 * _allowance(rec, "restitution"))
        vals = np.array([e for e, _, _ in es])
        if np.any(vals < 0):  # a restitution is a magnitude: a negative one is a sign error
            bad = es[int(np.argmin(vals))]
            raise _Missing(
                f"restitution {bad[0]:.5g} < 0 at v0 = {bad[1]:g} m/s (wrong sign of the velocity?)"
            )
        spread = float((vals.max() - vals.min()) / abs(vals.mean())) if vals.mean() else math.inf
        exact_vals = np.array([x for _, _, x in es])
        ref = (
            float((exact_vals.max() - exact_vals.min()) / abs(exact_vals.mean()))
            if np.all(np.isfinite(exact_vals)) and exact_vals.mean()
            else math.nan
        )
        lim = base + factor * allow
        lo, hi = es[int(np.argmin(vals))], es[int(np.argmax(vals))]
        ok = spread <= lim
        return self._result(
            ctx,
            "pass" if ok else "fail",
            spread,
            ref,
            None,
            ""
            if ok
            else (
                f"e = {lo[0]:.5g} at v0 = {lo[1]:g} m/s but {hi[0]:.5g} at {hi[1]:g} "
                f"m/s: spread {spread:.2g} > {lim:.2g} (the implemented law's exact "
                f"spread is {ref:.2g})"
            ),
            error=spread,
            limit=lim,
            at_v0=None,
            measured=spread,
            expected=0.0,
            rule=self.rule,
        ).with_tolerance(self._tolerance_text(base, factor, allow))


class EnergyBalance(Metric):
    name = key = "energy_balance"
    field = "atol"
    description = "energy out / energy in of an elastic impact (should be 1)"
    rule = "|E_out / E_in - 1| of an elastic impact, every speed, <= limit"

    def applies(self, ctx):
        base = super().applies(ctx)
        return base or ("damped scene" if ctx.damped else None)

    def _evaluate(self, ctx, base, factor):
        rows = []
        for rec in ctx.speeds:
            meas, _ = _need(rec, "energy_ratio", exact=False)
            err = abs(meas["energy_ratio"] - 1.0)
            allow = _allowance(rec, "energy_ratio") if rec.exact is not None else 0.0
            rows.append((rec, meas["energy_ratio"], 1.0, err, allow))

        def why(rec, got, want, err, lim):
            return (
                f"E_out / E_in = {got:.8g} at v0 = {rec.v0:g} m/s for an elastic "
                f"impact: |1 - ratio| = {err:.2g} > {lim:.2g}"
            )

        return self._worst(ctx, rows, base, factor, why)


class AttractiveForce(Metric):
    name = key = "attractive_force"
    field = "atol"
    description = (
        "peak attractive (tensile) total force near the end of contact, / peak "
        "force, against the implemented law sampled at the code's instants"
    )
    rule = (
        "|tensile peak / peak force - the same of the exact law sampled at the code's "
        "instants (ends of contact aligned)|, every speed, <= limit"
    )

    def _evaluate(self, ctx, base, factor):
        rows = []
        for rec in ctx.speeds:
            if _never_returns(rec):
                raise _Skip(
                    f"at v0 = {rec.v0:g} m/s the implemented law never returns to q = 0 "
                    "(overdamped): no end of contact to align the tensile peak at"
                )
            meas, ex = _need(rec, "tensile")
            ref = ex.get("tensile_sampled", math.nan)
            err = abs(meas["tensile"] - ref) if math.isfinite(ref) else math.inf
            rows.append((rec, meas["tensile"], ref, err, _allowance(rec, "tensile")))

        def why(rec, got, ref, err, lim):
            clip = rec.law is not None and rec.law.clips_tension
            cont = (rec.exact or {}).get("tensile", math.nan)
            return (
                f"tensile force peaks at {got:.3g} of the peak force at v0 = "
                f"{rec.v0:g} m/s, the implemented law "
                f"{'(tension clipped) ' if clip else ''}gives {ref:.3g} at the same "
                f"instants ({cont:.3g} continuous): |diff| {err:.2g} > {lim:.2g}"
            )

        return self._worst(ctx, rows, base, factor, why)


class DtCrit(Metric):
    name = key = "dt_crit"
    field = "min_ratio"
    magnitude = False  # a ratio compared from above (inf when stable throughout)
    description = (
        "critical step measured on the code, in units of Delta t_safe (section 6), "
        "against textbook Verlet with the same law"
    )
    rule = "code's Delta t_crit / textbook Verlet's (same law), worst speed, >= min_ratio"

    def _evaluate(self, ctx, base, factor):
        worst = None
        for rec in ctx.speeds:
            d = rec.dt_crit
            if rec.internal or (d is not None and d.get("internal")):
                raise _Internal(f"v0 = {rec.v0:g} m/s: {rec.internal or d['internal']}")
            if d is None:
                raise _Missing(
                    f"no critical-step search at v0 = {rec.v0:g} m/s"
                    + (f": {rec.error}" if rec.error else "")
                )
            if d.get("error"):
                raise _Missing(f"critical-step search at v0 = {rec.v0:g} m/s: {d['error']}")
            if "verlet_ratio" not in d:  # no baseline: never compare with a made-up one
                raise _Skip(
                    f"v0 = {rec.v0:g} m/s: "
                    f"{d.get('verlet_error', 'textbook Verlet was not run')}: no baseline "
                    "to compare the critical step with"
                )
            ref = d["verlet_ratio"]
            rel = (
                d["ratio"] / ref if math.isfinite(ref) else (1.0 if math.isinf(d["ratio"]) else 0.0)
            )
            if worst is None or rel < worst[0]:
                worst = (rel, rec, d, ref)
        rel, rec, d, ref = worst
        ok = rel >= base
        return self._result(
            ctx,
            "pass" if ok else "fail",
            d["ratio"],
            ref,
            base,
            ""
            if ok
            else (
                f"unstable at dt = {d['dt_crit']:.4g} s = {d['ratio']:.3g} dt_safe "
                f"(v0 = {rec.v0:g} m/s: {d.get('reason') or 'energy gain'}), "
                f"{_baseline(d)} with the same law holds to {ref:.3g} dt_safe: "
                f"{rel:.3g} < {base:g}"
            ),
            error=None,  # a ratio, not an error: its own column
            ratio=rel,
            limit=base,
            at_v0=rec.v0,
            measured=d["ratio"],
            expected=ref,
            rule=self.rule,
        )


def _baseline(d: dict) -> str:
    """The scheme a critical step is compared with, in words."""
    name = d.get("baseline_scheme", "velocity-verlet")
    return "textbook Verlet" if name == "velocity-verlet" else f"the declared scheme ({name})"


class SpeedError(StepRefinementMetric):
    name = key = "speed_error"
    field = "order_slack"
    magnitude = False  # an order, compared from above
    description = (
        "convergence order of the error against dt (speed-against-error table, middle speed)"
    )
    rule = (
        "order of the largest relative error (e, t_c, q_max) against dt >= "
        "min(the declared scheme's order on the same table, its declared order) - order_slack"
    )

    def _evaluate(self, ctx, base, factor):
        self._study_ready(ctx, "no order to compare with")
        if ctx.textbook_order is None:
            raise _Internal("the declared scheme's order was not measured")
        if ctx.order is None or not math.isfinite(ctx.order) and not ctx.order > 0:
            raise _Missing("too few converging points in the speed-against-error table")
        declared = ctx.scheme.order if ctx.scheme is not None else 2.0
        name = ctx.scheme.name if ctx.scheme is not None else "velocity-verlet"
        want = min(ctx.textbook_order, declared)
        lim = want - base
        ok = ctx.order >= lim
        if ok:
            why = ""
        elif ctx.order < _NO_CONVERGENCE:
            why = (
                f"does not converge: the largest relative error falls like "
                f"dt^{ctx.order:.2f} (it does not shrink with the step; the declared "
                f"scheme {name} falls like dt^{ctx.textbook_order:.2f} on the same table)"
            )
        else:
            why = (
                f"the largest relative error falls like dt^{ctx.order:.2f}, the declared "
                f"scheme {name} (order {declared:g}) like dt^{ctx.textbook_order:.2f} on "
                f"the same table: order {ctx.order:.2f} < {lim:.2f}"
            )
        return self._result(
            ctx,
            "pass" if ok else "fail",
            ctx.order,
            want,
            None,
            why,
            error=None,  # an order, not an error: its own column
            order=ctx.order,
            limit=lim,
            at_v0=None,
            measured=ctx.order,
            expected=want,
            rule=self.rule,
        ).with_tolerance(f"order >= {want:.2f} - {base:g}")


class EnergyDrift(Metric):
    name = key = "energy_drift"
    field = "atol"
    description = "two-walls, elastic: largest |E_n / E_0 - 1| over many impacts"
    rule = "max |E_n / E_0 - 1| over the two-walls run <= limit"
    impact_only = False

    def applies(self, ctx):
        if ctx.kind != "two-walls":
            return "sustained (two-walls) metric"
        if ctx.damped:
            return "damped scene"
        return None

    def _evaluate(self, ctx, base, factor):
        s = ctx.sustained
        if s is None:
            raise _Missing("no sustained run")
        if s.get("error"):
            raise _Missing(f"run failed: {s['error']}")
        drift, allow = s["drift"], s["textbook_drift"]
        lim = base + factor * allow
        ok = drift <= lim
        return self._result(
            ctx,
            "pass" if ok else "fail",
            drift,
            0.0,
            None,
            ""
            if ok
            else (
                f"energy drifts by {drift:.3g} of E_0 over {s['steps']} steps "
                f"({s['impacts']} impacts) > {lim:.2g} (textbook Verlet: {allow:.2g})"
            ),
            error=drift,
            limit=lim,
            at_v0=None,
            measured=drift,
            expected=0.0,
            rule=self.rule,
        ).with_tolerance(self._tolerance_text(base, factor, allow))


METRICS: tuple[Metric, ...] = (
    RestitutionAsked(),
    ContactTimeAsked(),
    PeakForceAsked(),
    RestitutionExact(),
    RestitutionSpread(),
    MaxPenetration(),
    ContactTime(),
    EnergyBalance(),
    AttractiveForce(),
    ForceLaw(),
    DtCrit(),
    SpeedError(),
    Extrapolated(),
    EnergyDrift(),
)


def metric_names(verdict: str | None = None) -> list[str]:
    """Names of the scorecard metrics, in scorecard order (of one verdict if given)."""
    return [m.name for m in METRICS if verdict is None or m.verdict == verdict]
