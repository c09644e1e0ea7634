"""results.json, version ``hcv-results/1.1``: what a report run writes and the renderer reads.

`reference_impl.campaign.build_report` runs the studies and writes ``results.json``; the
report's pages (``index.md``, ``index.html``, ``erratum.md``) are rendered from it and
from the figures beside it only, so ``hcv report --from results.json`` re-renders them
without running anything. The document is one JSON object (strict JSON: no NaN or
Infinity; NaN is written as null, infinities as the strings ``"inf"`` and ``"-inf"``),
versioned by ``"schema"`` as pytest-benchmark versions its JSON. Versions are
``hcv-results/M.N`` (``hcv-results/M`` is minor 0): a new field is a new minor version,
documented here with the minor that added it; a field removed, renamed or changing meaning
is a new major. A reader (``hcv report --from``) accepts its own version and every older
minor of the same major (a field added since is then absent, read as null); it refuses
another major and a newer minor, in one line. ``hcv-results/1.1`` added
``codes_side_by_side``; the same rule holds for the bench's ``hcv-bench/1``
(`reference_impl.bench.scorecard._json`). Fields (SI units; times in s, speeds in m/s):

``schema`` (str)
    ``"hcv-results/1.1"`` (``"hcv-results/1"`` before ``codes_side_by_side``).
``title``, ``generated_utc`` (str), ``mode`` (``"full"`` or ``"quick"``), ``quick_drops`` (list of str)
    What was run, when, and what ``--quick`` left out.
``claims`` (list of dict)
    One per claim in paper order: ``id``, ``section``, ``statement``, ``verdict`` (one of
    ``verified``, ``refuted``, ``inconclusive``), ``evidence``, ``rule``, ``headline``,
    ``tests`` (``file::test`` names), ``measured`` (the claim's figures), ``counterexample``.
``table1`` (list of dict), ``fig1`` (dict: ``runs``, ``rtol``, ``atol``, ``figure``)
    Table 1 cells printed and computed; the Fig. 1 runs.
``dt_crit_map``, ``dt_crit_sensitivity``, ``dt_crit_map_coverage`` (lists of dict)
    The section 6 critical-step map, its criterion sensitivity and coverage.
``dt_crit_settings`` (dict)
    ``recommend_factor``, ``recommend_factor_singular`` (the recommended step's factors per
    scene kind) and ``search_resolution`` (the search's bracket, in units of Δt_safe).
``work_precision``, ``work_precision_summary`` (lists of dict), ``work_precision_settings`` (str),
``work_precision_scenes`` (dict: scene -> description), ``work_precision_families`` (dict)
    The speed-against-error rows, their summary, and per family (``rows``) the exact
    solver against DOP853 at the rtol ``dop853_rtol``.
``hard_cases`` (dict)
    ``cases``, ``sweeps`` (``speed``, ``depth``), ``accuracy`` (str lines) and ``settings``
    (``ode_rtol``, ``verlet_steps``, ``mp_dps``).
``damping_laws`` (dict)
    Restitution against speed per damping law.
``figures`` (list of str), ``figure_captions`` (dict)
    Figure files relative to the results file's directory (``figures/NAME.png``).
``environment`` (dict)
    Python, machine, ``git_commit``, ``git_dirty``, package versions, seeds; the load
    average (1, 5, 15 min) at the start and end (``load_average_start``, ``load_average_end``)
    and numba's cache at the start (``compile_cache_start``: ``dir``, ``entries``), absent
    from files written before they were recorded.
``adapters`` (list of dict), ``steps_per_contact`` (list of dict), ``steps_per_contact_settings`` (dict or null)
    The contact codes' scorecards (``hcv bench`` documents) and what they deliver against
    steps per contact; empty without codes.
``codes_side_by_side`` (dict or null; absent from files written before it existed)
    Asked restitution against delivered, code by code (`reference_impl.campaign._codes`):
    ``settings`` (``asked``, ``steps_per_contact``, ``speeds``, ``mass``, ``hertz_k``,
    ``hooke_k``, ``speed_tolerance``, ``asked_tolerance``, ``calibration_asked``,
    ``calibration_steps_per_contact``, ``calibration_v0``), ``rows`` (one per variant,
    asked e, steps per contact and speed: ``code``, ``variant``, ``spec``, ``match``,
    ``k``, ``p``, ``asked``, ``steps_per_contact``, ``v0``, ``delivered``, ``tensile``
    (largest pull / peak push), ``declared_exact``, ``error``; numbers null where it did
    not deliver), ``calibration`` (``code``, ``variant``, ``spec``, ``match``, ``option``,
    ``asked``, ``found`` and ``value``, or ``delivered`` (the span reached), ``message``
    or ``error``) and ``seconds`` (per spec: ``table``, ``calibration``). Null without codes.
``carried`` (dict or null)
    Set when the code sections were not run but kept from the previous report in the
    output directory: ``sections`` (names of the fields above), ``git_commit``,
    ``generated_utc`` and ``adapters`` of the run they come from, ``reason``.
``timings_seconds`` (dict)
    Wall time of each stage; ``total``.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from reference_impl.claims import VERDICTS
from reference_impl.errors import HCVInputError

__all__ = ["SCHEMA", "check_results", "read_results"]

SCHEMA = "hcv-results/1.1"

# Field -> the JSON type the renderer needs (`check_results`).
FIELDS: dict[str, type | tuple[type, ...]] = {
    "schema": str,
    "title": str,
    "generated_utc": str,
    "mode": str,
    "quick_drops": list,
    "claims": list,
    "table1": list,
    "fig1": dict,
    "dt_crit_map": list,
    "dt_crit_sensitivity": list,
    "dt_crit_map_coverage": list,
    "dt_crit_settings": dict,
    "work_precision": list,
    "work_precision_summary": list,
    "work_precision_settings": str,
    "work_precision_scenes": dict,
    "work_precision_families": dict,
    "hard_cases": dict,
    "damping_laws": dict,
    "figures": list,
    "figure_captions": dict,
    "environment": dict,
    "adapters": list,
    "steps_per_contact": list,
    "steps_per_contact_settings": (dict, type(None)),
    "codes_side_by_side": (dict, type(None)),
    "carried": (dict, type(None)),
    "timings_seconds": dict,
}
# Fields added in a minor version, which a file of an older minor lacks (read as null).
OPTIONAL = ("codes_side_by_side",)
# What the renderer reads of ``codes_side_by_side`` (`reference_impl.report._codes`).
CODES_SETTINGS = ("asked", "steps_per_contact", "speeds", "mass", "hertz_k", "hooke_k",
                  "speed_tolerance", "asked_tolerance", "calibration_asked",
                  "calibration_steps_per_contact", "calibration_v0")  # fmt: skip
CODES_ROW = ("code", "variant", "spec", "match", "asked", "steps_per_contact", "v0",
             "delivered", "tensile", "declared_exact", "error")  # fmt: skip
CODES_CALIBRATION = ("code", "spec", "match", "option", "asked")
CLAIM_FIELDS = ("id", "section", "statement", "verdict", "evidence", "rule", "measured", "headline")


def _version(schema) -> tuple[int, int] | None:
    """(major, minor) of ``hcv-results/M`` or ``hcv-results/M.N``; None for anything else."""
    prefix = SCHEMA.split("/")[0] + "/"
    if not isinstance(schema, str) or not schema.startswith(prefix):
        return None
    m = re.fullmatch(r"(\d+)(?:\.(\d+))?", schema[len(prefix) :], re.ASCII)
    return None if m is None else (int(m[1]), int(m[2] or 0))


def _figure_ok(rel) -> bool:
    """A figure path the renderer may read: figures/NAME.png, nothing above or outside."""
    p = Path(rel) if isinstance(rel, str) else None
    return p is not None and len(p.parts) == 2 and p.parts[0] == "figures" and p.suffix == ".png"


def check_results(results, source: str = "results") -> dict:
    """Refuse a document the renderer cannot read, in one line naming what is wrong.

    Parameters
    ----------
    results : object
        A parsed results.json.
    source : str
        How to name it in the error (the file's path).

    Returns
    -------
    dict
        ``results`` itself.

    Raises
    ------
    HCVInputError
        Not an object, no or another ``schema``, a missing or mistyped field, a claim
        without its fields or with an unknown verdict, a figure path outside ``figures/``.
    """
    if not isinstance(results, dict):
        raise HCVInputError(f"{source}: not a JSON object (got {type(results).__name__})")
    version = results.get("schema")
    got, ours = _version(version), _version(SCHEMA)
    if got is None or got[0] != ours[0] or got[1] > ours[1]:
        what = "has no schema field" if version is None else f"has schema {version!r}"
        raise HCVInputError(
            f"{source} {what}; this hcv reads {SCHEMA!r} and older minors of major "
            f"{ours[0]} (regenerate it with hcv report)"
        )
    for key, typ in FIELDS.items():
        if key not in results and key in OPTIONAL:
            continue
        if key not in results:
            raise HCVInputError(f"{source}: field {key!r} is missing ({SCHEMA})")
        if not isinstance(results[key], typ):
            raise HCVInputError(
                f"{source}: field {key!r} is a {type(results[key]).__name__}, not as {SCHEMA} has it"
            )
    for i, c in enumerate(results["claims"]):
        missing = [k for k in CLAIM_FIELDS if not isinstance(c, dict) or k not in c]
        if missing:
            raise HCVInputError(f"{source}: claims[{i}] lacks {', '.join(missing)}")
        if c["verdict"] not in VERDICTS:
            raise HCVInputError(
                f"{source}: claim {c['id']!r} has verdict {c['verdict']!r}, not one of {VERDICTS}"
            )
    _check_codes(results.get("codes_side_by_side"), source)
    bad = [f for f in results["figures"] if not _figure_ok(f)]
    if bad:
        raise HCVInputError(f"{source}: figure {bad[0]!r} is not figures/NAME.png")
    return results


def _check_codes(sec, source: str) -> None:
    """``codes_side_by_side``: the settings and the fields of each row the renderer reads."""
    if sec is None:
        return
    where = f"{source}: codes_side_by_side"
    parts = {"settings": dict, "rows": list, "calibration": list, "seconds": dict}
    for key, typ in parts.items():
        if not isinstance(sec.get(key), typ):
            raise HCVInputError(f"{where}: {key!r} is missing or not a {typ.__name__}")
    missing = [k for k in CODES_SETTINGS if k not in sec["settings"]]
    if missing:
        raise HCVInputError(f"{where}: settings lack {', '.join(missing)}")
    if len(sec["settings"]["speeds"]) < 2 or not sec["settings"]["steps_per_contact"]:
        raise HCVInputError(f"{where}: settings need two speeds and a steps per contact")
    for name, fields in (("rows", CODES_ROW), ("calibration", CODES_CALIBRATION)):
        for i, row in enumerate(sec[name]):
            lacks = [k for k in fields if not isinstance(row, dict) or k not in row]
            if lacks:
                raise HCVInputError(f"{where}: {name}[{i}] lacks {', '.join(lacks)}")


def read_results(path) -> dict:
    """Read and check a results.json (strict JSON); one-line HCVInputError otherwise."""
    path = Path(path)

    def refuse(token):
        raise ValueError(f"non-standard JSON constant {token}")

    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise HCVInputError(f"--from {str(path)!r}: cannot be read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise HCVInputError(f"--from {str(path)!r}: not UTF-8 text") from None
    try:
        data = json.loads(text, parse_constant=refuse)
    except ValueError as exc:
        raise HCVInputError(f"--from {str(path)!r}: not JSON ({exc})") from None
    return check_results(data, f"--from {str(path)!r}")
