"""The delivery metrics: does the user get what the scene asks (issue 26)?

``restitution_asked``, ``contact_time_asked`` and ``peak_force_asked`` compare what a
code delivers with what the scene asks (its own law solved exactly) under a fixed
tolerance, never scaled by the step, and split each error into a signed model part
(the declared law's exact answer against the asked one) and a signed step part (the
code against the declared law's exact answer). The scorecard's list of metrics, and
the implementation metrics, are `reference_impl.bench.scorecard.metrics`.
"""

from __future__ import annotations

import math

from reference_impl.bench.scorecard._records import SpeedRecord
from reference_impl.bench.scorecard._rules import _NO_CONVERGENCE, Metric, _Internal, _need

__all__ = ["ContactTimeAsked", "PeakForceAsked", "RestitutionAsked"]


class _Delivered(Metric):
    """What the scene asks against what the code delivers, worst speed (a delivery metric).

    The limit is the tolerance itself (``rtol`` of the metric's table): fixed and
    user-facing, never scaled by the step, because the user's question "do I get what
    I asked for" does not change with the step. The error |measured - asked| / asked is
    split at every speed into a signed model part (declared - asked) / asked (the exact
    answer of the law the code declares: step-free, fixed by recalibrating) and a signed
    step part (measured - declared) / asked (the discretisation: fixed by refining the
    step): error = |model + step|.
    """

    verdict = "delivery"
    field = "rtol"
    quantity = ""  # key of `SpeedRecord.asked` and of the exact reference
    measured_key = ""  # key of the measured dict
    label = ""
    # what tension clipping does to this quantity, said in a FAIL line when the declared
    # law clips and the scene asks the overlap end ("" where clipping changes nothing)
    clip_note = ""

    @property
    def rule(self):
        return (
            f"|{self.label} - asked| / asked, every speed, <= rtol (fixed: never scaled by "
            "the step); error = |model + step|, signed parts: model = (declared law's exact - "
            "asked) / asked, step = (measured - declared law's exact) / asked"
        )

    def _keys(self, rec: SpeedRecord) -> tuple[str, str]:
        """(measured key, exact key) at this speed."""
        return self.measured_key, self.quantity

    def _evaluate_table(self, ctx, base, factor, table):
        # an absolute floor (``atol``, same unit as the quantity) where the table has one:
        # the limit on the relative error at a speed is max(rtol, atol / asked)
        return self._evaluate(ctx, base, factor, float(table.get("atol", 0.0)))

    def _evaluate(self, ctx, base, factor, atol: float = 0.0):
        rows = []
        for rec in ctx.speeds:
            mkey, xkey = self._keys(rec)
            meas, _ = _need(rec, mkey, exact=False)
            asked = (rec.asked or {}).get(self.quantity)
            if not isinstance(asked, float) or not math.isfinite(asked) or asked <= 0:
                raise _Internal(f"v0 = {rec.v0:g} m/s: no asked {self.label} ({asked!r})")
            got = meas[mkey]
            declared = (rec.exact or {}).get(xkey, math.nan)
            if not isinstance(declared, float):
                declared = math.nan
            rows.append(
                {
                    "rec": rec,
                    "v0": rec.v0,
                    "measured": got,
                    "expected": asked,
                    "declared": declared,
                    "error": abs(got - asked) / asked,
                    # signed, so that model + step = (measured - asked) / asked exactly (up to
                    # round-off) and |model + step| = error: opposite signs say the step
                    # compensates the model
                    "model_error": (declared - asked) / asked,
                    "step_error": (got - declared) / asked,
                    "limit": max(base, atol / asked),
                }
            )

        def score(r):
            return r["error"] / r["limit"] if math.isfinite(r["error"]) else math.inf

        worst = max(rows, key=score)
        err = worst["error"] if math.isfinite(worst["error"]) else math.inf
        lim = worst["limit"]
        ok = err <= lim
        model, step = (
            (worst[k] if math.isfinite(worst[k]) else None) for k in ("model_error", "step_error")
        )
        res = self._result(
            ctx,
            "pass" if ok else "fail",
            err,
            worst["expected"],
            base,
            "" if ok else self._why(worst, lim, ctx.order),
            error=err,
            limit=lim,
            at_v0=worst["v0"],
            measured=worst["measured"],
            expected=worst["expected"],
            rule=self.rule,
            model_error=model,
            step_error=step,
            per_v0=[{k: v for k, v in r.items() if k != "rec"} for r in rows],
        )
        if atol:
            # the limit applied at the worst speed, on the relative error: max(rtol, atol /
            # asked) (JSON ``limit``)
            res.with_tolerance(f"{self.field} {base:g}, atol {atol:g}: limit {lim:.3g}")
        return res

    def _why(self, r, lim, order=None) -> str:
        """The FAIL line: measured against asked, the model and step parts with their
        remedies (``order``: the speed table's measured order, None when not run), and what
        tension clipping does to this quantity."""
        u = self.unit
        split = (
            "; " + _split_advice(r, lim, u, order)
            if math.isfinite(r["declared"])
            else "; no exact answer of the declared law to split the error"
        )
        law, asked = r["rec"].law, r["rec"].asked or {}
        clipped = law is not None and law.clips_tension and asked.get("end") != "zero-force"
        clip = f"; the code clips tension: {self.clip_note}" if clipped and self.clip_note else ""
        return (
            f"{self.label} {r['measured']:.6g}{u} at v0 = {r['v0']:g} m/s but "
            f"{r['expected']:.6g}{u} was asked: error {r['error']:.3g} > {lim:.3g}{split}{clip}"
        )


def _split_advice(r: dict, lim: float, unit: str, order: float | None = None) -> str:
    """The model and step parts, each with its remedy only where it matters: "recalibrate"
    when the model part alone exceeds half the limit (a model part of 0 needs no
    recalibration: issue 40, §4), "refine the step" likewise for the step part, unless
    the speed table measured that the code's error does not shrink with the step (order
    ``order`` < `_NO_CONVERGENCE`): refining then removes nothing, and the line says the
    code does not converge to the law it declares (issue 40, §4)."""
    model, step = r["model_error"], r["step_error"]
    m = f"model {model:+.2g} (the declared law's exact answer is {r['declared']:.6g}{unit}"
    m += ": recalibrate)" if abs(model) > 0.5 * lim else ")"
    s = f"step {step:+.2g}"
    if abs(step) > 0.5 * lim:
        if order is not None and math.isfinite(order) and order < _NO_CONVERGENCE:
            s += (
                f" (does not converge: the speed table's error falls like dt^{order:.2f}, so "
                "refining the step will not remove it; check the law the code integrates "
                "against the one it declares)"
            )
        else:
            s += " (refine the step)"
    return f"{m}, {s}"


class RestitutionAsked(_Delivered):
    name = key = "restitution_asked"
    rigid_applies = True  # the one metric a rigid, impulse-based contact is judged on
    quantity = "restitution"
    measured_key = "restitution"
    label = "restitution"
    description = "restitution at the asked end against the value the scene asks"

    @property
    def rule(self):
        return (
            "|restitution - asked| / asked, every speed, <= max(rtol, atol / asked) (fixed: "
            "never scaled by the step; atol: the absolute floor of small e); error = "
            "|model + step|, signed parts: model = (declared law's exact - asked) / asked, "
            "step = (measured - declared law's exact) / asked"
        )

    clip_note = "its contact ends at the zero-force end, where the body leaves faster than at q = 0"

    def _why(self, r, lim, order=None) -> str:
        """The asked e at the asked speed first, then this speed's own target (a law whose
        e depends on the speed was asked e at one speed: issue 40, §3)."""
        asked = r["rec"].asked or {}
        speed, e = asked.get("scene_speed"), asked.get("scene_restitution")
        text = super()._why(r, lim, order)
        if speed is None or e is None or speed == r["v0"]:
            return text
        return (
            f"e = {e:.6g} asked at {speed:g} m/s (the scene's law gives {r['expected']:.6g} "
            f"at v0 = {r['v0']:g} m/s): {text}"
        )

    def _keys(self, rec):
        if (rec.asked or {}).get("end") == "zero-force":
            return "restitution_zero_force", "restitution_zero_force"
        return "restitution", "restitution"


class ContactTimeAsked(_Delivered):
    name = key = "contact_time_asked"
    quantity = "contact_time"
    measured_key = "contact_time"
    label = "contact time"
    unit = " s"
    description = "contact duration against the scene's own law solved exactly"
    clip_note = "its contact ends at the zero-force end, then the body flies freely back to q = 0"

    def applies(self, ctx):
        base = super().applies(ctx)
        if base:
            return base
        for rec in ctx.speeds:
            asked = (rec.asked or {}).get("contact_time")
            if isinstance(asked, float) and math.isinf(asked):
                return (
                    f"the scene's law never returns to q = 0 at v0 = {rec.v0:g} m/s "
                    "(overdamped): no contact time is asked"
                )
        return None


class PeakForceAsked(_Delivered):
    name = key = "peak_force_asked"
    quantity = "peak_force"
    measured_key = "max_force"
    label = "peak force"
    unit = " N"
    description = "peak total contact force against the scene's own law solved exactly"
    # clip_note stays "": clipping acts after the peak (the force is positive up to it)
