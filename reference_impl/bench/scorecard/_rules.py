"""The rule every scorecard metric follows, and how it ends when it cannot decide.

A metric's limit is ``base + factor x allowance`` (`Metric`): ``base`` from
tolerances.toml, ``factor`` = ``[allowance] textbook_verlet``, the allowance the error
of textbook velocity Verlet with the implemented law at the same step (`_allowance`).
The verdict is read at the worst speed (`Metric._worst`). A metric that cannot decide
ends as "fail" (a run it needs failed: `_Missing`), "error" (our reference failed:
`_Internal`) or "skip" (no reference can be run for the declared law: `_Skip`).
The metrics themselves are in `reference_impl.bench.scorecard.metrics` (the delivery metrics in
`reference_impl.bench.scorecard._delivery`).
"""

from __future__ import annotations

import math

from reference_impl.bench.scorecard._records import NA, MetricResult, SceneContext, SpeedRecord

__all__ = ["Metric"]

# A measured order below this is no convergence at all: the error does not shrink with
# the step (said so, instead of "refine the step", by speed_error and by a delivery FAIL
# line's step part). Half of the lowest order a scheme declares (1), well above the
# scatter of a fit over six doublings (~0.1).
_NO_CONVERGENCE = 0.5


class Metric:
    """Base of the scorecard metrics (see the module docstring).

    Every limit is ``base + factor x allowance``: ``base`` is the metric's key in
    tolerances.toml, ``factor`` is ``[allowance] textbook_verlet`` and the
    allowance is the error textbook velocity Verlet with the implemented law makes
    on the same quantity at the same step (`SpeedRecord.textbook`), i.e. the error
    a correct code makes at the step the suite gives it. ``rule`` says in words
    what is compared with what.
    """

    name = ""
    key = ""
    field = ""
    description = ""
    rule = ""
    unit = ""  # unit of the measured and expected values ("" for ratios)
    impact_only = True
    magnitude = True  # the value is a size (>= 0) compared with the limit from below
    verdict = "implementation"  # or "delivery" (`reference_impl.bench.scorecard._records.VERDICTS`)

    # the one metric a code that reports no penetration is judged on (issue 40, §3)
    rigid_applies = False

    def applies(self, ctx: SceneContext) -> str | None:
        if self.impact_only and ctx.kind != "impact":
            return f"impact metric; scene kind is {ctx.kind}"
        if getattr(ctx, "rigid", "") and not self.rigid_applies:
            return ctx.rigid
        return None

    def _result(
        self, ctx, status, value=None, reference=None, tol=None, explanation="", **cols
    ) -> MetricResult:
        return MetricResult(
            ctx.variant,
            ctx.scene,
            self.name,
            status,
            value,
            reference,
            f"{self.field} {tol:g}" if tol is not None else "",
            explanation,
            self.description,
            verdict=self.verdict,
            **cols,
        )

    def evaluate(self, ctx: SceneContext, tol: dict) -> MetricResult:
        if ctx.skipped:
            return self._result(ctx, "skip", explanation=ctx.skipped)
        reason = self.applies(ctx)
        if reason:  # the metric does not apply to this scene: no test, not a skipped one
            return self._result(ctx, NA, explanation=f"does not apply: {reason}")
        limit = float(tol[self.key][self.field])
        factor = float(tol["allowance"]["textbook_verlet"])
        if ctx.internal:
            return self._result(ctx, "error", tol=limit, explanation=_ours(ctx.internal))
        try:
            res = self._evaluate_table(ctx, limit, factor, tol[self.key])
        except _Missing as miss:
            return self._result(ctx, "fail", tol=limit, explanation=str(miss))
        except _Internal as exc:
            return self._result(ctx, "error", tol=limit, explanation=_ours(str(exc)))
        except _Skip as exc:
            return self._result(ctx, "skip", tol=limit, explanation=str(exc))
        if (
            res.status == "pass"
            and self.magnitude
            and not (isinstance(res.error, float) and res.error >= 0)
        ):
            # every magnitude metric compares a value >= 0 with its limit; anything else
            # (negative, NaN) is a sign or measurement error and never passes
            res.status = "fail"
            res.explanation = f"{self.name} = {res.error!r} is not a magnitude >= 0"
        return res

    def _evaluate_table(self, ctx: SceneContext, base: float, factor: float, table: dict):
        """`_evaluate`, for metrics that read more of their tolerance table than ``field``."""
        return self._evaluate(ctx, base, factor)

    def _evaluate(self, ctx: SceneContext, base: float, factor: float) -> MetricResult:
        raise NotImplementedError  # pragma: no cover

    def _tolerance_text(self, base: float, factor: float, allowance: float) -> str:
        return f"{self.field} {base:g} + {factor:g} x {allowance:.2g}"

    def _worst(self, ctx, rows, base, factor, why):
        """Verdict over per-speed rows (rec, measured, expected, error, allowance).

        The row reported is the speed where error / limit is largest (the first
        failing speed decides the explanation ``why(row, limit)``).
        """
        worst = None
        for rec, got, want, err, allow in rows:
            lim = base + factor * allow
            if not math.isfinite(err):
                err = math.inf
            score = err / lim if lim > 0 else math.inf
            if worst is None or score > worst[0]:
                worst = (score, rec, got, want, err, lim, allow)
        _, rec, got, want, err, lim, allow = worst
        ok = err <= lim
        per_v0 = [
            {"v0": r.v0, "measured": g, "expected": w, "error": e, "limit": base + factor * a}
            for r, g, w, e, a in rows
        ]
        return self._result(
            ctx,
            "pass" if ok else "fail",
            err,
            0.0,
            None,
            "" if ok else why(rec, got, want, err, lim),
            error=err,
            limit=lim,
            at_v0=rec.v0,
            measured=got,
            expected=want,
            rule=self.rule,
            per_v0=per_v0,
        ).with_tolerance(self._tolerance_text(base, factor, allow))


class _Missing(Exception):
    """A run this metric needs failed or did not produce the quantity."""


class _Internal(Exception):
    """The suite's own reference failed for this metric (not the code under test)."""


class _Skip(Exception):
    """The reference this metric needs cannot be run for the declared law: a skip, with why."""


def _ours(text: str) -> str:
    return f"internal error of the reference (ours, not the code's): {text}"


def _need(rec: SpeedRecord, *keys: str, exact: bool = True) -> tuple[dict, dict]:
    if rec.error:
        raise _Missing(f"run failed at v0 = {rec.v0:g} m/s: {rec.error}")
    if exact and rec.internal:
        raise _Internal(f"v0 = {rec.v0:g} m/s: {rec.internal}")
    meas = rec.measured or {}
    for k in keys:
        if not isinstance(meas.get(k), float) or not math.isfinite(meas[k]):
            why = meas.get("reason", f"no {k} measured")
            raise _Missing(f"no {k.replace('_', ' ')} at v0 = {rec.v0:g} m/s: {why}")
    if exact and rec.exact is None:
        raise _Missing(f"no exact reference at v0 = {rec.v0:g} m/s")
    return meas, rec.exact or {}


def _allowance(rec: SpeedRecord, quantity: str) -> float:
    """Textbook Verlet's error of ``quantity`` at this speed and step (never a default)."""
    if rec.internal:
        raise _Internal(f"v0 = {rec.v0:g} m/s: {rec.internal}")
    tb = rec.textbook
    if tb is None:
        raise _Internal(f"v0 = {rec.v0:g} m/s: textbook Verlet was not run")
    if "internal" in tb:
        raise _Internal(f"v0 = {rec.v0:g} m/s: {tb['internal']}")
    if "error" in tb:
        raise _Skip(
            f"{tb['error']}: the error a correct code makes at this step is unknown, "
            "so no tolerance can be derived"
        )
    return float(tb[quantity])
