"""What one benchmark run records: per impact speed (`SpeedRecord`), per adapter variant
and scene (`SceneContext`), and each metric's outcome (`MetricResult`).

Importable from `reference_impl.bench.metrics` as well.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from reference_impl.adapters.base import ImplementedLaw

__all__ = ["MetricResult", "SceneContext", "SpeedRecord"]


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
