"""Scorecard metrics: what is measured on a trajectory, the exact references, and the rules.

Each metric is a named object (as pytest-benchmark's regression checks are):
a ``name``, the ``key`` of its table in the tolerances file and the tolerance
``field`` it reads, a one-line ``description``, ``applies(ctx)`` (a reason to
skip, or None) and ``evaluate(ctx, tol) -> MetricResult`` with pass / fail and,
on failure, a one-line explanation naming the worst speed.

References: every metric but ``restitution_asked`` compares the code with the
exact solution of the law the code *implements* (`ImplementedLaw`): the
harmonic-map solver `reference_impl.solve_impact` when that law is the
universal one (any Tsuji-type q^((p-1)/2) damping of a power law is), else the
damped ODE by DOP853 at rtol 1e-12 (`reference_impl.integrators.ivp`). A code
that clips tensile force ends its contact when the total force vanishes; its
references are taken at that end (restitution_zero_force), then free flight to
q = 0.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from reference_impl.adapters.base import ImplementedLaw
from reference_impl.bench.measure import check_conventions, exact_reference, measure

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


@dataclass
class MetricResult:
    """Outcome of one metric for one adapter variant and one scene."""

    variant: str
    scene: str
    metric: str
    status: str  # "pass" | "fail" | "skip" | "error" (our reference failed, not the code)
    value: float | None = None
    reference: float | None = None
    tolerance: str = ""
    explanation: str = ""
    description: str = ""

    def to_dict(self) -> dict:
        d = asdict(self)
        for k in ("value", "reference"):
            v = d[k]
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None if math.isnan(v) else ("inf" if v > 0 else "-inf")
        return d


@dataclass
class SpeedRecord:
    """Everything measured at one impact speed of one scene."""

    v0: float
    dt: float = math.nan
    asked_e: float = 1.0
    law: ImplementedLaw | None = None
    exact: dict | None = None
    measured: dict | None = None
    error: str = ""
    stderr: str = ""
    seconds: float = 0.0
    dt_crit: dict | None = None
    internal: str = ""  # the suite's own reference failed at this speed

    def to_dict(self) -> dict:
        return {
            "v0": self.v0,
            "dt": self.dt,
            "asked_restitution": self.asked_e,
            "implemented_law": self.law.to_json() if self.law is not None else None,
            "exact": self.exact,
            "measured": self.measured,
            "error": self.error,
            "internal_error": self.internal,
            "stderr": self.stderr,
            "seconds": self.seconds,
            "dt_crit": self.dt_crit,
        }


@dataclass
class SceneContext:
    """One adapter variant on one scene: the per-speed records and the speed table."""

    variant: str
    scene: str
    kind: str
    damped: bool
    skipped: str = ""
    speeds: list[SpeedRecord] = field(default_factory=list)
    speed_rows: list[dict] = field(default_factory=list)
    order: float | None = None
    order_error: str = ""
    sustained: dict | None = None
    internal: str = ""  # the suite's own reference failed on this scene
    order_internal: str = ""  # ... on the speed table only


# ----------------------------------------------------------------------------
# metrics
# ----------------------------------------------------------------------------
class Metric:
    """Base of the scorecard metrics (see the module docstring)."""

    name = ""
    key = ""
    field = ""
    description = ""
    impact_only = True
    magnitude = True  # the value is a size (>= 0) compared with the limit from below

    def applies(self, ctx: SceneContext) -> str | None:
        if self.impact_only and ctx.kind != "impact":
            return f"impact metric; scene kind is {ctx.kind}"
        return None

    def _result(self, ctx, status, value=None, reference=None, tol=None, explanation=""):
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
        )

    def evaluate(self, ctx: SceneContext, tol: dict) -> MetricResult:
        if ctx.skipped:
            return self._result(ctx, "skip", explanation=ctx.skipped)
        reason = self.applies(ctx)
        if reason:
            return self._result(ctx, "skip", explanation=reason)
        limit = float(tol[self.key][self.field])
        if ctx.internal:
            return self._result(ctx, "error", tol=limit, explanation=_ours(ctx.internal))
        try:
            res = self._evaluate(ctx, limit)
        except _Missing as miss:
            return self._result(ctx, "fail", tol=limit, explanation=str(miss))
        except _Internal as exc:
            return self._result(ctx, "error", tol=limit, explanation=_ours(str(exc)))
        if (
            res.status == "pass"
            and self.magnitude
            and not (isinstance(res.value, float) and res.value >= 0)
        ):
            # every magnitude metric compares a value >= 0 with its limit; anything else
            # (negative, NaN) is a sign or measurement error and never passes
            return self._result(
                ctx,
                "fail",
                res.value,
                res.reference,
                limit,
                f"{self.name} = {res.value!r} is not a magnitude >= 0",
            )
        return res

    def _evaluate(self, ctx: SceneContext, limit: float) -> MetricResult:  # pragma: no cover
        raise NotImplementedError


class _Missing(Exception):
    """A run this metric needs failed or did not produce the quantity."""


class _Internal(Exception):
    """The suite's own reference failed for this metric (not the code under test)."""


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


class _RelativeToExact(Metric):
    """|measured - exact| / exact of one quantity, worst speed."""

    quantity = ""
    field = "rtol"
    unit = ""

    def _evaluate(self, ctx, limit):
        worst = None
        for rec in ctx.speeds:
            meas, ex = _need(rec, self.quantity)
            ref = ex.get(self.quantity, math.nan)
            err = abs(meas[self.quantity] - ref) / abs(ref) if ref else math.inf
            if not math.isfinite(err):
                err = math.inf
            if worst is None or err > worst[0]:
                worst = (err, rec, meas[self.quantity], ref)
        err, rec, got, ref = worst
        if err <= limit:
            return self._result(ctx, "pass", err, 0.0, limit)
        law = rec.law.description if rec.law is not None else ""
        return self._result(
            ctx,
            "fail",
            err,
            0.0,
            limit,
            f"{self.quantity.replace('_', ' ')} {got:.7g}{self.unit} at v0 = "
            f"{rec.v0:g} m/s, exact {ref:.7g}{self.unit} for the implemented law "
            f"({law}): rel. error {err:.2g} > {limit:g}",
        )


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


class RestitutionAsked(Metric):
    name = key = "restitution_asked"
    field = "rtol"
    description = "restitution against the value the code was asked for"

    def _evaluate(self, ctx, limit):
        worst = None
        for rec in ctx.speeds:
            meas, ex = _need(rec, "restitution", exact=False)
            err = abs(meas["restitution"] - rec.asked_e) / rec.asked_e
            if worst is None or err > worst[0]:
                worst = (err, rec, meas["restitution"], ex)
        err, rec, got, ex = worst
        if err <= limit:
            return self._result(ctx, "pass", err, 0.0, limit)
        implemented = ex.get("restitution", math.nan)
        return self._result(
            ctx,
            "fail",
            err,
            0.0,
            limit,
            f"e = {got:.6g} at v0 = {rec.v0:g} m/s but {rec.asked_e:.6g} was asked "
            f"(rel. {err:.2g} > {limit:g}); the law the code implements gives "
            f"{implemented:.6g}",
        )


class RestitutionSpread(Metric):
    name = key = "restitution_v0_spread"
    field = "rtol"
    description = "dependence of the restitution on the impact speed (Theorem 3: none)"

    def applies(self, ctx):
        base = super().applies(ctx)
        if base:
            return base
        if len(ctx.speeds) < 2:
            return "needs at least two impact speeds"
        return None

    def _evaluate(self, ctx, limit):
        es = []
        for rec in ctx.speeds:
            meas, ex = _need(rec, "restitution", exact=False)
            es.append((meas["restitution"], rec.v0, ex.get("restitution", math.nan)))
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
        if spread <= limit:
            return self._result(ctx, "pass", spread, ref, limit)
        lo, hi = es[int(np.argmin(vals))], es[int(np.argmax(vals))]
        return self._result(
            ctx,
            "fail",
            spread,
            ref,
            limit,
            f"e = {lo[0]:.5g} at v0 = {lo[1]:g} m/s but {hi[0]:.5g} at {hi[1]:g} "
            f"m/s: spread {spread:.2g} > {limit:g} (the implemented law's exact "
            f"spread is {ref:.2g})",
        )


class EnergyBalance(Metric):
    name = key = "energy_balance"
    field = "atol"
    description = "energy out / energy in of an elastic impact (should be 1)"

    def applies(self, ctx):
        base = super().applies(ctx)
        return base or ("damped scene" if ctx.damped else None)

    def _evaluate(self, ctx, limit):
        worst = None
        for rec in ctx.speeds:
            meas, _ = _need(rec, "energy_ratio", exact=False)
            err = abs(meas["energy_ratio"] - 1.0)
            if worst is None or err > worst[0]:
                worst = (err, rec, meas["energy_ratio"])
        err, rec, ratio = worst
        if err <= limit:
            return self._result(ctx, "pass", err, 0.0, limit)
        return self._result(
            ctx,
            "fail",
            err,
            0.0,
            limit,
            f"E_out / E_in = {ratio:.8g} at v0 = {rec.v0:g} m/s for an elastic "
            f"impact: |1 - ratio| = {err:.2g} > {limit:g}",
        )


class AttractiveForce(Metric):
    name = key = "attractive_force"
    field = "atol"
    description = (
        "peak attractive (tensile) total force near the end of contact, / peak "
        "force, against the implemented law"
    )

    def _evaluate(self, ctx, limit):
        worst = None
        for rec in ctx.speeds:
            meas, ex = _need(rec, "tensile")
            ref = ex.get("tensile", math.nan)
            err = abs(meas["tensile"] - ref) if math.isfinite(ref) else math.inf
            if worst is None or err > worst[0]:
                worst = (err, rec, meas["tensile"], ref)
        err, rec, got, ref = worst
        if err <= limit:
            return self._result(ctx, "pass", got, ref, limit)
        clip = rec.law is not None and rec.law.clips_tension
        return self._result(
            ctx,
            "fail",
            got,
            ref,
            limit,
            f"tensile force peaks at {got:.3g} of the peak force at v0 = "
            f"{rec.v0:g} m/s, the implemented law "
            f"{'(tension clipped) ' if clip else ''}gives {ref:.3g}: "
            f"|diff| {err:.2g} > {limit:g}",
        )


class DtCrit(Metric):
    name = key = "dt_crit"
    field = "min_ratio"
    magnitude = False  # a ratio compared from above (inf when stable throughout)
    description = (
        "critical step measured on the code, in units of Delta t_safe (section 6), "
        "against textbook Verlet with the same law"
    )

    def _evaluate(self, ctx, limit):
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
            ref = d.get("verlet_ratio", 1.0)
            rel = (
                d["ratio"] / ref if math.isfinite(ref) else (1.0 if math.isinf(d["ratio"]) else 0.0)
            )
            if worst is None or rel < worst[0]:
                worst = (rel, rec, d, ref)
        rel, rec, d, ref = worst
        if rel >= limit:
            return self._result(ctx, "pass", d["ratio"], ref, limit)
        return self._result(
            ctx,
            "fail",
            d["ratio"],
            ref,
            limit,
            f"unstable at dt = {d['dt_crit']:.4g} s = {d['ratio']:.3g} dt_safe "
            f"(v0 = {rec.v0:g} m/s: {d.get('reason', 'energy gain')}), textbook "
            f"Verlet with the same law holds to {ref:.3g} dt_safe: "
            f"{rel:.3g} < {limit:g}",
        )


class SpeedError(Metric):
    name = key = "speed_error"
    field = "min_order"
    magnitude = False  # an order, compared from above
    description = (
        "convergence order of the error against dt (speed-against-error table, middle speed)"
    )

    def _evaluate(self, ctx, limit):
        if ctx.order_internal:
            raise _Internal(ctx.order_internal)
        if ctx.order_error:
            raise _Missing(ctx.order_error)
        if ctx.order is None or not math.isfinite(ctx.order):
            raise _Missing("too few converging points in the speed-against-error table")
        if ctx.order >= limit:
            return self._result(ctx, "pass", ctx.order, 2.0, limit)
        return self._result(
            ctx,
            "fail",
            ctx.order,
            2.0,
            limit,
            f"the largest relative error falls like dt^{ctx.order:.2f} "
            f"(order below {limit:g}): the code does not converge to the law it "
            "implements",
        )


class EnergyDrift(Metric):
    name = key = "energy_drift"
    field = "atol"
    description = "two-walls, elastic: largest |E_n / E_0 - 1| over many impacts"
    impact_only = False

    def applies(self, ctx):
        if ctx.kind != "two-walls":
            return "sustained (two-walls) metric"
        if ctx.damped:
            return "damped scene"
        return None

    def _evaluate(self, ctx, limit):
        s = ctx.sustained
        if s is None:
            raise _Missing("no sustained run")
        if s.get("error"):
            raise _Missing(f"run failed: {s['error']}")
        drift = s["drift"]
        if drift <= limit:
            return self._result(ctx, "pass", drift, 0.0, limit)
        return self._result(
            ctx,
            "fail",
            drift,
            0.0,
            limit,
            f"energy drifts by {drift:.3g} of E_0 over {s['steps']} steps "
            f"({s.get('impacts', '?')} impacts) > {limit:g}",
        )


METRICS: tuple[Metric, ...] = (
    RestitutionAsked(),
    RestitutionExact(),
    RestitutionSpread(),
    MaxPenetration(),
    ContactTime(),
    EnergyBalance(),
    AttractiveForce(),
    DtCrit(),
    SpeedError(),
    EnergyDrift(),
)


def metric_names() -> list[str]:
    """Names of the scorecard metrics, in scorecard order."""
    return [m.name for m in METRICS]
