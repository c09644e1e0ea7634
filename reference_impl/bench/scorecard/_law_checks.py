"""Two implementation metrics of issue 40, §1: the force a code reports against the law it
declares (``force_law``), and the step-refinement study's extrapolated answer against the
declared law's exact one (``extrapolated``).

Both follow the rule of every implementation metric (`reference_impl.bench.scorecard._rules`): limit
= base + factor x the same quantity of the code's *declared* scheme run on the exact law
(`reference_impl.bench.scorecard._schemes`), the error a correct code of that scheme makes.
"""

from __future__ import annotations

import math

from reference_impl.bench.scorecard._rules import (
    Metric,
    _allowance,
    _Internal,
    _Missing,
    _need,
    _Skip,
)

__all__ = ["Extrapolated", "ForceLaw", "StepRefinementMetric"]


class StepRefinementMetric(Metric):
    """A metric read from the step-refinement study (the speed-against-error table): n/a
    for a variable-step code, whose dt is its sampling; `_study_ready` raises what the
    study's own failures mean for it."""

    def applies(self, ctx):
        base = super().applies(ctx)
        if base:
            return base
        if ctx.scheme is not None and ctx.scheme.variable:
            return "a variable-step code: its dt is its sampling, not a step to refine"
        return None

    @staticmethod
    def _study_ready(ctx, missing_baseline: str) -> None:
        """Raise when the study did not give this code's table or the declared scheme's."""
        if ctx.order_internal:
            raise _Internal(ctx.order_internal)
        if ctx.order_error:
            raise _Missing(ctx.order_error)
        if ctx.textbook_order_error:
            raise _Skip(f"{ctx.textbook_order_error}: {missing_baseline}")


class ForceLaw(Metric):
    name = key = "force_law"
    unit = " N"  # of the measured and expected forces (the error is over the peak force)
    field = "rtol"
    description = "reported force against the declared law at the reported states"
    rule = (
        "max over in-contact samples of |force - F(q, v) of the declared law| / peak "
        "|F|, every speed, <= limit"
    )

    def _evaluate(self, ctx, base, factor):
        rows = []
        for rec in ctx.speeds:
            meas, _ = _need(rec)
            got = meas.get("force_law")
            if not isinstance(got, dict):
                raise _Internal(f"v0 = {rec.v0:g} m/s: the force was not checked")
            rows.append((rec, got, got["law"], got["error"], _allowance(rec, "force")))

        def why(rec, got, want, err, lim):
            return (
                f"force {got['force']:.6g} N at q = {got['q']:.4g} m, v = {got['v']:.4g} "
                f"m/s (v0 = {rec.v0:g} m/s) but the declared law gives {want:.6g} N there: "
                f"|diff| / peak force {err:.2g} > {lim:.2g} (the force, not the step: check "
                "its units and the law declared)"
            )

        res = self._worst(ctx, rows, base, factor, why)
        # the columns carry the forces, not the dict of the worst sample
        worst = next((g for r, g, *_ in rows if r.v0 == res.at_v0), None)
        if worst is not None:
            res.measured, res.expected = worst["force"], worst["law"]
        for row, (_, g, *_rest) in zip(res.per_v0, rows, strict=True):
            row["measured"] = g["force"]
        return res


class Extrapolated(StepRefinementMetric):
    name = key = "extrapolated"
    field = "rtol"
    description = (
        "step-refinement study extrapolated to dt -> 0 against the declared law's exact answer"
    )
    rule = (
        "|X* - exact| / exact of the Richardson extrapolation of the two finest runs of the "
        "speed table (X: e, t_c, q_max), at the declared scheme's order, <= limit"
    )

    def _evaluate(self, ctx, base, factor):
        self._study_ready(ctx, "no extrapolation to compare with")
        x = ctx.extrapolated
        if x is None:
            raise _Internal("the step-refinement study was not extrapolated")
        err, allow = x["error"], x["allowance"]
        if not math.isfinite(allow):
            raise _Internal(f"the declared scheme's own extrapolation is {allow!r}")
        if math.isnan(err):
            raise _Missing("fewer than two runs of the speed-against-error table")
        lim = base + factor * allow
        ok = err <= lim
        n1, n2 = (x["steps"] + [None, None])[:2]
        return self._result(
            ctx,
            "pass" if ok else "fail",
            err,
            0.0,
            None,
            ""
            if ok
            else (
                f"the {x['quantity'].replace('_', ' ')} extrapolated to dt -> 0 from {n1} and "
                f"{n2} steps per contact (order {x['order']:.2f}) is off the declared law's "
                f"exact answer by {err:.2g} > {lim:.2g}: an error that does not shrink with "
                "the step (the law implemented is not the law declared)"
            ),
            error=err,
            limit=lim,
            at_v0=None,
            rule=self.rule,
        ).with_tolerance(self._tolerance_text(base, factor, allow))
