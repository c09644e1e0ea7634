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
    error: float | None = None  # what the limit bounds (relative error, spread, |diff|, ...)
    limit: float | None = None  # the bound applied: base + allowance (tolerances.toml)
    at_v0: float | None = None  # the impact speed the row reports (m/s)
    measured: float | None = None  # the code's value of the compared quantity
    expected: float | None = None  # what it is compared with
    rule: str = ""  # in words: what is compared, and the pass rule
    # per speed: {"v0", "measured", "expected", "error", "limit"} (metrics read per speed)
    per_v0: list = field(default_factory=list)

    def with_tolerance(self, text: str) -> MetricResult:
        self.tolerance = text
        return self

    def to_dict(self) -> dict:
        d = asdict(self)
        d["per_v0"] = [
            {
                k: (v if not isinstance(v, float) or math.isfinite(v) else str(v))
                for k, v in r.items()
            }
            for r in self.per_v0
        ]
        for k in ("value", "reference", "error", "limit", "measured", "expected"):
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
    # errors of textbook velocity Verlet with the implemented law at the same dt
    # (the error a correct code makes at this step; `_SceneRun.textbook`)
    textbook: dict | None = None

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
            "textbook_verlet": self.textbook,
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
    textbook_order: float | None = None  # textbook Verlet's order on the same table
    textbook_order_error: str = ""


# ----------------------------------------------------------------------------
# metrics
# ----------------------------------------------------------------------------
# Nominal convergence order of velocity Verlet (the speed table's order is compared
# with min(textbook Verlet's measured order, this) - order_slack).
_NOMINAL_ORDER = 2.0


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

    def applies(self, ctx: SceneContext) -> str | None:
        if self.impact_only and ctx.kind != "impact":
            return f"impact metric; scene kind is {ctx.kind}"
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
            **cols,
        )

    def evaluate(self, ctx: SceneContext, tol: dict) -> MetricResult:
        if ctx.skipped:
            return self._result(ctx, "skip", explanation=ctx.skipped)
        reason = self.applies(ctx)
        if reason:
            return self._result(ctx, "skip", explanation=reason)
        limit = float(tol[self.key][self.field])
        factor = float(tol["allowance"]["textbook_verlet"])
        if ctx.internal:
            return self._result(ctx, "error", tol=limit, explanation=_ours(ctx.internal))
        try:
            res = self._evaluate(ctx, limit, factor)
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
                f"({law}): rel. error {err:.2g} > {lim:.2g}"
            )

        return self._worst(ctx, rows, base, factor, why)


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
    rule = "|e - e_asked| / e_asked, every speed, <= limit"

    def _evaluate(self, ctx, base, factor):
        rows = []
        for rec in ctx.speeds:
            meas, ex = _need(rec, "restitution", exact=False)
            err = abs(meas["restitution"] - rec.asked_e) / rec.asked_e
            # the allowance needs the implemented law's exact solution; without it, none
            allow = _allowance(rec, "restitution") if rec.exact is not None else 0.0
            rows.append((rec, meas["restitution"], rec.asked_e, err, allow))

        def why(rec, got, want, err, lim):
            implemented = (rec.exact or {}).get("restitution", math.nan)
            return (
                f"e = {got:.6g} at v0 = {rec.v0:g} m/s but {want:.6g} was asked "
                f"(rel. {err:.2g} > {lim:.2g}); the law the code implements gives "
                f"{implemented:.6g}"
            )

        return self._worst(ctx, rows, base, factor, why)


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
                f"(v0 = {rec.v0:g} m/s: {d.get('reason') or 'energy gain'}), textbook "
                f"Verlet with the same law holds to {ref:.3g} dt_safe: "
                f"{rel:.3g} < {base:g}"
            ),
            error=rel,
            limit=base,
            at_v0=rec.v0,
            measured=d["ratio"],
            expected=ref,
            rule=self.rule,
        )


class SpeedError(Metric):
    name = key = "speed_error"
    field = "order_slack"
    magnitude = False  # an order, compared from above
    description = (
        "convergence order of the error against dt (speed-against-error table, middle speed)"
    )
    rule = (
        "order of the largest relative error (e, t_c, q_max) against dt >= "
        "min(textbook Verlet's order on the same table, 2) - order_slack"
    )

    def _evaluate(self, ctx, base, factor):
        if ctx.order_internal:
            raise _Internal(ctx.order_internal)
        if ctx.order_error:
            raise _Missing(ctx.order_error)
        if ctx.textbook_order_error:
            raise _Skip(f"{ctx.textbook_order_error}: no order to compare with")
        if ctx.textbook_order is None:
            raise _Internal("textbook Verlet's order was not measured")
        if ctx.order is None or not math.isfinite(ctx.order) and not ctx.order > 0:
            raise _Missing("too few converging points in the speed-against-error table")
        want = min(ctx.textbook_order, _NOMINAL_ORDER)
        lim = want - base
        ok = ctx.order >= lim
        return self._result(
            ctx,
            "pass" if ok else "fail",
            ctx.order,
            want,
            None,
            ""
            if ok
            else (
                f"the largest relative error falls like dt^{ctx.order:.2f}, textbook "
                f"Verlet's like dt^{ctx.textbook_order:.2f} on the same table: order "
                f"{ctx.order:.2f} < {lim:.2f}"
            ),
            error=ctx.order,
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
