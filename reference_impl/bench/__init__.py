"""Benchmark and CI gate for third-party contact codes (``hcv bench``).

`run_bench` runs scenes through an adapter (`reference_impl.adapters`) and
through the exact solution, evaluates the scorecard metrics
(`reference_impl.bench.scorecard.metrics`) against tolerances (`load_tolerances`, defaults
in ``tolerances.toml``), and writes JSON and JUnit reports
(`reference_impl.bench.scorecard._json`, `reference_impl.bench.scorecard._junit`;
`reference_impl.bench.scorecard.report` renders the scorecard for people). A metric is "pass", "fail", "skip", "error"
(the suite's own reference could not decide it: never the code's failure) or "n/a"
(it does not apply to the scene), and belongs to one of two verdicts: "implementation"
(against the exact solution of the declared law) or "delivery" (against what the
scene asks). ``BenchResult.exit_status(gate)`` (gate True or "both", "implementation",
"delivery") is 0 when every metric it reads passes, 1 when one
failed (or the run was interrupted), 3 when none failed but one is "error";
usage and configuration errors raise `HCVInputError` (exit status 2).
"""

from reference_impl.bench.scorecard._json import write_json
from reference_impl.bench.scorecard._junit import write_junit
from reference_impl.bench.scorecard.metrics import METRICS, MetricResult, metric_names
from reference_impl.bench.scorecard.report import (
    plot_speed_error,
    render_scorecard,
    render_speed_error,
    scorecard_markdown,
    write_markdown,
)
from reference_impl.bench.scorecard.runner import (
    DEFAULT_SCENES,
    BenchResult,
    bench_scene_names,
    resolve_scenes,
    run_bench,
)
from reference_impl.bench.scorecard.tolerances import default_tolerances, load_tolerances

__all__ = [
    "DEFAULT_SCENES",
    "METRICS",
    "BenchResult",
    "MetricResult",
    "bench_scene_names",
    "default_tolerances",
    "load_tolerances",
    "metric_names",
    "plot_speed_error",
    "render_scorecard",
    "render_speed_error",
    "resolve_scenes",
    "run_bench",
    "scorecard_markdown",
    "write_json",
    "write_junit",
    "write_markdown",
]
