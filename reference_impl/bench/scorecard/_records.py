"""What one benchmark run records: per impact speed (`SpeedRecord`), per adapter variant
and scene (`SceneContext`), each metric's outcome (`MetricResult`), and the whole run
(`BenchResult`, with its gate exit status).

The first three are importable from `reference_impl.bench.scorecard.metrics`, `BenchResult` and
`EXIT_INTERNAL` from `reference_impl.bench.scorecard.runner`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from reference_impl.adapters.base import ImplementedLaw
from reference_impl.bench.scorecard._json import result_to_dict

__all__ = [
    "DELIVERY_METRICS",
    "EXIT_INTERNAL",
    "GATES",
    "NA",
    "VERDICTS",
    "BenchResult",
    "MetricResult",
    "SceneContext",
    "SpeedRecord",
]

# The two questions a scorecard answers (issue 26): does the code implement the law it
# declares as well as a correct code can at this step ("implementation"), and does the
# user get what the scene asks ("delivery")?
VERDICTS = ("implementation", "delivery")
# What ``--gate`` may select: one verdict, or both (the default).
GATES = ("both", *VERDICTS)
# Status of a metric that does not apply to the scene (its kind, damping or number of
# speeds): not a test at all, unlike "skip" (a test that could not be run).
NA = "n/a"
# The delivery metrics (`reference_impl.bench.scorecard._delivery`); every other metric is implementation.
DELIVERY_METRICS = ("restitution_asked", "contact_time_asked", "peak_force_asked")


@dataclass
class MetricResult:
    """Outcome of one metric for one adapter variant and one scene."""

    variant: str
    scene: str
    metric: str
    status: str  # "pass" | "fail" | "skip" | "error" (ours, not the code) | "n/a" (see NA)
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
    # per speed: {"v0", "measured", "expected", "error", "limit"} (metrics read per speed;
    # delivery metrics add "model_error" and "step_error")
    per_v0: list = field(default_factory=list)
    # which question the metric answers: "implementation" (against the exact solution of
    # the law the code declares, step-scaled allowance) or "delivery" (against what the
    # scene asks, fixed user-facing tolerance): see `VERDICTS`
    verdict: str = ""  # "" = from the metric's name (`DELIVERY_METRICS`)
    # delivery metrics: the error split at the reported speed, both relative to the asked
    # value: model = |declared law's exact answer - asked| (step-free: recalibrate),
    # step = |measured - declared law's exact answer| (discretisation: refine the step)
    model_error: float | None = None
    step_error: float | None = None
    ratio: float | None = None  # dt_crit: code's critical step / textbook Verlet's
    order: float | None = None  # speed_error: observed convergence order

    def __post_init__(self):
        if not self.verdict:
            self.verdict = "delivery" if self.metric in DELIVERY_METRICS else "implementation"

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
        for k in (
            "value", "reference", "error", "limit", "measured", "expected",
            "model_error", "step_error", "ratio", "order",
        ):  # fmt: skip
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
    # (the error a correct code makes at this step; `_textbook.textbook_errors`)
    textbook: dict | None = None
    # what the scene asks at this speed (the scene's own law solved exactly): restitution
    # at the asked end ("end"), contact time (s) and peak total force (N)
    asked: dict | None = None

    def to_dict(self) -> dict:
        return {
            "v0": self.v0,
            "dt": self.dt,
            "asked_restitution": self.asked_e,
            "asked": self.asked,
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
    # the scene's damping law when its restitution depends on the speed (not the
    # universal law, Theorem 3): the spread metric then does not apply
    speed_dependent: str = ""
    skipped: str = ""
    speeds: list[SpeedRecord] = field(default_factory=list)
    order: float | None = None
    order_error: str = ""
    sustained: dict | None = None
    internal: str = ""  # the suite's own reference failed on this scene
    order_internal: str = ""  # ... on the speed table only
    textbook_order: float | None = None  # the declared scheme's order on the same table
    textbook_order_error: str = ""
    scheme: object = None  # the variant's declared `Scheme` (None: velocity Verlet)
    # the step-refinement study's extrapolated answer: {"error", "quantity", "allowance",
    # "order", "steps"} (`reference_impl.bench.scorecard._textbook.extrapolated_error`)
    extrapolated: dict | None = None
    # why the scene's metrics but restitution_asked do not apply: the code reported no
    # penetration (a rigid, impulse-based contact; issue 40, §3); "" otherwise
    rigid: str = ""


# Gate exit status when no metric failed but the suite's own reference could not decide one.
EXIT_INTERNAL = 3


@dataclass
class BenchResult:
    """Everything one `run_bench` call measured (see `reference_impl.bench.scorecard.report` for output).

    Attributes
    ----------
    adapter : str
        The adapter spec.
    variants : list of dict
        ``describe()`` of each variant.
    scenes : list of str
        Scene names, in run order.
    metrics : list of MetricResult
        The scorecard: one entry per variant, scene and metric.
    contexts : list of SceneContext
        Raw per-speed records (runs, exact references, critical steps).
    speed_error : list of dict
        Speed-against-error rows (workprecision style).
    tolerances : dict
        The tolerances used.
    machine : dict
        Machine and commit information.
    interrupted : bool
        The run was interrupted; the results are those computed so far.
    """

    adapter: str
    variants: list[dict] = field(default_factory=list)
    scenes: list[str] = field(default_factory=list)
    metrics: list[MetricResult] = field(default_factory=list)
    contexts: list[SceneContext] = field(default_factory=list)
    speed_error: list[dict] = field(default_factory=list)
    tolerances: dict = field(default_factory=dict)
    machine: dict = field(default_factory=dict)
    started: float = 0.0
    seconds: float = 0.0
    interrupted: bool = False

    def counts(self) -> dict[str, int]:
        """Metrics per status: pass, fail, skip, and error (our reference failed)."""
        c = {"pass": 0, "fail": 0, "skip": 0, "error": 0, NA: 0}
        for m in self.metrics:
            c[m.status] += 1
        return c

    @property
    def failures(self) -> list[MetricResult]:
        return [m for m in self.metrics if m.status == "fail"]

    def gated(self, gate: str = "both") -> list[MetricResult]:
        """The metrics a gate on ``gate`` ("both", "implementation", "delivery") reads."""
        if gate not in GATES:
            raise ValueError(f"gate must be one of {', '.join(GATES)}, got {gate!r}")
        return [m for m in self.metrics if gate == "both" or m.verdict == gate]

    @property
    def internal_errors(self) -> list[MetricResult]:
        """Metrics not decided because the suite's own reference failed (never the code's fault)."""
        return [m for m in self.metrics if m.status == "error"]

    @property
    def measured_nothing(self) -> bool:
        """No metric was decided (every one skipped: declined scenes, no reference)."""
        return not any(m.status in ("pass", "fail", "error") for m in self.metrics)

    def exit_status(self, gate: bool | str) -> int:
        """0; with ``gate`` 1 when a metric it reads failed, it measured nothing (every
        metric skipped or n/a: a gate that measured nothing does not pass) or the run was
        interrupted, else `EXIT_INTERNAL` when the reference failed on one, else 0.

        ``gate``: False (no gate), True or "both" (every metric), "implementation" or
        "delivery" (that verdict's metrics only).
        """
        if not gate:
            return 0
        mine = self.gated("both" if gate is True else gate)
        if any(m.status == "fail" for m in mine) or self.interrupted:
            return 1
        if not any(m.status in ("pass", "fail", "error") for m in mine):
            return 1
        return EXIT_INTERNAL if any(m.status == "error" for m in mine) else 0

    def to_dict(self) -> dict:
        return result_to_dict(self)
