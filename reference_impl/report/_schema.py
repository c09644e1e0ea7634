"""results.json, version ``hcv-results/1.3``: what a report run writes and the renderer reads.

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
``codes_side_by_side``, ``hcv-results/1.2`` added ``assemblies``, ``hcv-results/1.3``
``stage_loads``; the same rule holds for
the bench's ``hcv-bench/1`` (`reference_impl.bench.scorecard._json`). Fields (SI units; times in s, speeds in m/s):

``schema`` (str)
    ``"hcv-results/1.3"`` (``"hcv-results/1.2"`` before ``stage_loads``,
    ``"hcv-results/1.1"`` before ``assemblies``, ``"hcv-results/1"`` before
    ``codes_side_by_side``).
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
``assemblies`` (dict or null; absent from files written before ``hcv-results/1.2``)
    Section 6 in chains and packings (issue 39; `reference_impl.campaign._assembly`):
    ``claim`` (the id of the claim whose ``measured.rows`` hold the nonlinear table, the
    P_fail curves and the ``horizon_dependent`` flags: one home for that measurement),
    ``linear`` (the search against 2/omega_max on bonded linear springs: ``rtol``,
    ``criterion``, ``k``, ``m``, ``rows`` of ``case``, ``reference``, ``dt_search``,
    ``dt_reference``, ``rel_diff``, ``holds``), ``figures`` (``p_fail``, ``factor``: paths
    listed in ``figures``) and ``code_advice`` (optional list: the codes' step advice on
    the scenes, one row per code and rule: ``code``, ``advice``, ``verdict``, optionally
    ``scene``, ``dt_advice``, ``dt_crit``, ``factor``, ``note``).
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
``stage_loads`` (dict, absent before ``hcv-results/1.3``)
    The 1-minute load average as each stage of ``timings_seconds`` started and ended
    (``[start, end]``; null where the platform has none), so that every timing has its
    load beside it (issue 41): a stage whose load exceeded the cores is flagged where
    its timings are shown.

The file is checked as a whole before anything reads it (`check_results`, issue 36): against
the JSON Schema ``results.schema.json`` shipped beside this module (Draft 2020-12, with the
maintained ``jsonschema`` validator), which describes every field the renderer and the
campaign's carrying of the code sections read, then against the files: every figure it
names must be ``figures/NAME.png`` inside the report directory, a regular file (not a
link), at most 20 MiB, with the PNG signature (`reference_impl.report._inputs`). A document
that fails is refused in one line naming the JSON path of the first bad field
(``$.claims[0].verdict``); the renderer only ever sees a checked document.
"""

from __future__ import annotations

import errno
import functools
import json
import math
import os
import re
import stat
import sys
from pathlib import Path

from jsonschema import Draft202012Validator
from jsonschema.exceptions import best_match

from reference_impl.errors import HCVInputError
from reference_impl.report._inputs import read_report_file

__all__ = ["FIELDS", "RESULTS_MAX_BYTES", "SCHEMA", "SCHEMA_FILE", "check_results", "read_results"]

SCHEMA = "hcv-results/1.3"
# The one schema file of the document, shipped with the package (package-data).
SCHEMA_FILE = Path(__file__).with_name("results.schema.json")
# The committed results.json, with five codes, is 2.4 MB; 64 MiB keeps a 25x margin and
# bounds what --from reads into memory (a results file may come from anyone).
RESULTS_MAX_BYTES = 64 * 2**20
# What a refusal says of a list that repeats an entry (the schema's uniqueItems).
_TWICE = "lists an entry twice"
# A refusal quotes at most this many characters of a value (one readable line).
_QUOTE = 80


@functools.cache
def _validator() -> Draft202012Validator:
    schema = json.loads(SCHEMA_FILE.read_text(encoding="utf-8"))
    Draft202012Validator.check_schema(schema)  # a broken schema file fails here, not silently
    return Draft202012Validator(schema)


def _version(schema) -> tuple[int, int] | None:
    """(major, minor) of ``hcv-results/M`` or ``hcv-results/M.N``; None for anything else.

    The version rule: a new field is a new minor version; ``--from`` reads every older
    minor of the same major (the fields it lacks are optional in the schema file) and
    refuses another major or a newer minor."""
    prefix = SCHEMA.split("/")[0] + "/"
    if not isinstance(schema, str) or not schema.startswith(prefix):
        return None
    # At most 9 digits a number: int() of a longer one may exceed Python's 4300-digit
    # limit (a traceback), and no version of this file will have more.
    m = re.fullmatch(r"(\d{1,9})(?:\.(\d{1,9}))?", schema[len(prefix) :], re.ASCII)
    return None if m is None else (int(m[1]), int(m[2] or 0))


# The top-level fields of hcv-results/1, in the order written (documented above).
FIELDS: tuple[str, ...] = tuple(_validator().schema["properties"])


def _quote(x) -> str:
    """A short one-line rendering of a JSON value for a refusal."""
    if isinstance(x, dict):
        return "an object"
    if isinstance(x, list):
        return "an array"
    text = repr(x)  # escapes newlines and control characters: the refusal stays one line
    return text if len(text) <= _QUOTE else text[: _QUOTE - 3] + "..."


def _kind(x) -> str:
    names = {dict: "an object", list: "an array", str: "a string", bool: "a boolean",
             int: "a number", float: "a number", type(None): "null"}  # fmt: skip
    return names.get(type(x), type(x).__name__)


def _json_path(path) -> str:
    """``$.claims[0].verdict`` of a jsonschema error's absolute path (keys quoted when odd)."""
    out = "$"
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        elif re.fullmatch(r"[A-Za-z_][A-Za-z0-9_-]*", part):
            out += f".{part}"
        else:
            out += f"[{_quote(part)}]"
    return out


def _wanted(want: dict) -> str:
    """The entry a ``contains`` asks for, in words: ``'x'`` or ``with id 'x'``."""
    if "const" in want:
        return _quote(want["const"])
    consts = [(k, v["const"]) for k, v in want.get("properties", {}).items() if "const" in v]
    if len(consts) == 1:
        return f"with {consts[0][0]} {_quote(consts[0][1])}"
    return json.dumps(want, ensure_ascii=False)[:120]


def _describe(err) -> str:
    """What is wrong, in words, without repeating a large value (jsonschema's messages do)."""
    kind, want, x = err.validator, err.validator_value, err.instance
    if kind == "required":
        missing = next((k for k in want if isinstance(x, dict) and k not in x), want[0])
        return f"{missing!r} is missing"
    if kind == "type":
        want = [want] if isinstance(want, str) else want
        return f"is {_kind(x)}, should be {' or '.join(want)}"
    if kind in ("enum", "const"):
        allowed = want if kind == "enum" else [want]
        return f"is {_quote(x)}, should be {' or '.join(_quote(a) for a in allowed)}"
    if kind == "pattern":
        if want.startswith("^figures/"):
            return f"{_quote(x)} is not figures/NAME.png inside the report"
        if want.startswith("^steps_"):
            return f"{_quote(x)} is not steps_NAME.png (a figure of the report, in figures/)"
        return f"{_quote(x)} does not match {want}"
    if kind == "uniqueItems":
        return _TWICE
    if kind in ("minItems", "maxItems", "minProperties", "maxProperties"):
        word = "at least" if kind.startswith("min") else "at most"
        return f"has {len(x)} entries, should have {word} {want}"
    if kind == "contains":
        return f"has no entry {_wanted(want)}"
    if kind in ("exclusiveMinimum", "minimum"):
        return f"is {_quote(x)}, should be {'>' if kind == 'exclusiveMinimum' else '>='} {want}"
    if kind in ("oneOf", "anyOf"):
        return f"is {_kind(x)} not of the form the report reads"
    return " ".join(err.message.split())[:200]


def _figure_twice(results) -> bool:
    """True when ``$.figures`` is a list of strings that lists one twice (the schema's
    ``uniqueItems``), found with a set.

    Asked before the schema runs: jsonschema checks every entry of the list (its pattern,
    through a ``$ref``, ~60 us each) before it reports the repeat, so a figure listed 1e5
    times took ~7 s to refuse; a set answers in milliseconds. Other lists are left to the
    schema (no other list of the document has to be unique)."""
    figures = results.get("figures")
    if not isinstance(figures, list) or not all(isinstance(f, str) for f in figures):
        return False  # not a list of names: the schema names what is wrong
    return len(set(figures)) != len(figures)


def _first_error(results):
    """The error to name, or None: the deepest bad field (the most precise: a bad entry
    rather than the list lacking a good one), the first found among equals; within a
    oneOf or anyOf, jsonschema's best match of its branches."""
    errors = list(_validator().iter_errors(results))
    if not errors:
        return None
    err = max(errors, key=lambda e: len(e.absolute_path))  # max keeps the first of equals
    return best_match(err.context) if err.validator in ("oneOf", "anyOf") and err.context else err


def _not_utf8(text: str) -> bool:
    """True for a string UTF-8 cannot encode: a lone surrogate (JSON's ``"\\ud800"``)."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def _out_of_range(doc) -> tuple[str, object] | None:
    """(JSON path, value) of the first number that is not a finite double, or of the first
    string or key that is not UTF-8 text; None when there is none.

    Strict JSON has no infinity, but ``1e999`` parses to one and a 400-digit integer
    cannot become a float: the renderer formats numbers as floats, so both are refused
    here (a results file writes infinities as the strings "inf" and "-inf"). JSON's
    ``\\ud800`` escape parses to a lone surrogate, which no page can be written with
    (the pages are UTF-8 files)."""
    stack = [((), doc)]
    while stack:
        path, x = stack.pop()
        if isinstance(x, dict):
            bad_key = next((k for k in x if _not_utf8(k)), None)
            if bad_key is not None:
                return _json_path(path), bad_key
            stack += [((*path, k), v) for k, v in reversed(x.items())]
        elif isinstance(x, str) and _not_utf8(x):
            return _json_path(path), x
        elif isinstance(x, list):
            stack += [((*path, i), v) for i, v in reversed(list(enumerate(x)))]
        elif isinstance(x, float) and not math.isfinite(x):
            return _json_path(path), x
        elif isinstance(x, int) and not isinstance(x, bool) and abs(x) > sys.float_info.max:
            return _json_path(path), x
    return None


def _cross_checks(r: dict) -> tuple[str, str] | None:
    """(JSON path, what is wrong) of the first reference the schema cannot express, or None."""
    listed = set(r["figures"])
    needed = [("$.fig1.figure", r["fig1"].get("figure"))]
    if r["damping_laws"]:
        needed.append(("$.damping_laws", "figures/damping_laws.png"))
    for i, code in enumerate(r["steps_per_contact"]):
        if code.get("figure"):
            needed.append((f"$.steps_per_contact[{i}].figure", f"figures/{code['figure']}"))
    asm = r.get("assemblies")
    if asm:
        ids = [c["id"] for c in r["claims"]]
        if asm["claim"] not in ids:
            return "$.assemblies.claim", f"names claim {asm['claim']!r}, which $.claims lacks"
        needed += [(f"$.assemblies.figures.{k}", rel) for k, rel in asm["figures"].items()]
    for where, rel in needed:
        if rel is not None and rel not in listed:
            return where, f"its figure {rel} is not listed in $.figures"
    summary = r["work_precision_summary"]
    targets = [k for k in summary[0] if k.startswith("fastest to")]
    for i, row in enumerate(summary):
        missing = [k for k in targets if k not in row]
        if missing:
            return (
                f"$.work_precision_summary[{i}]",
                f"{missing[0]!r} is missing (the first row has it)",
            )
    return None


def check_results(results, source: str = "results", base=None) -> dict:
    """Refuse a document the renderer cannot read, in one line naming the first bad field.

    Parameters
    ----------
    results : object
        A parsed results.json.
    source : str
        How to name it in the error (the file's path).
    base : str or Path, optional
        The report directory the document's figures lie in (its results.json's): every
        figure is then checked as a file (`reference_impl.report._inputs`); None checks
        the document alone.

    Returns
    -------
    dict
        ``results`` itself.

    Raises
    ------
    HCVInputError
        Not an object, no or another ``schema``; a field the schema ``results.schema.json``
        refuses (its JSON path named), a figure the document uses but does not list, or
        (given ``base``) a figure that is not a regular PNG file of at most 20 MiB inside
        ``base``.
    """
    if not isinstance(results, dict):
        raise HCVInputError(f"{source}: not a JSON object (got {_kind(results)})")
    version = results.get("schema")
    got, ours = _version(version), _version(SCHEMA)
    if got is None or got[0] != ours[0] or got[1] > ours[1]:
        what = "has no schema field" if version is None else f"has schema {_quote(version)}"
        raise HCVInputError(
            f"{source} {what}; this hcv reads {SCHEMA!r} and older minors of major "
            f"{ours[0]} (regenerate it with hcv report)"
        )
    big = _out_of_range(results)
    if big is not None:
        if isinstance(big[1], str):
            raise HCVInputError(
                f"{source}: {big[0]}: {_quote(big[1])} holds a lone surrogate, "
                f"not UTF-8 text ({SCHEMA})"
            )
        shown = f"a {len(str(abs(big[1])))}-digit integer" if isinstance(big[1], int) else big[1]
        raise HCVInputError(f"{source}: {big[0]}: is {shown}, not a finite number ({SCHEMA})")
    if _figure_twice(results):
        raise HCVInputError(f"{source}: $.figures: {_TWICE} ({SCHEMA})")
    err = _first_error(results)
    if err is not None:
        raise HCVInputError(
            f"{source}: {_json_path(err.absolute_path)}: {_describe(err)} ({SCHEMA})"
        )
    bad = _cross_checks(results)
    if bad is not None:
        raise HCVInputError(f"{source}: {bad[0]}: {bad[1]} ({SCHEMA})")
    if base is not None:
        for i, rel in enumerate(results["figures"]):
            read_report_file(Path(base), rel, f"{source}: $.figures[{i}]", head_only=True)
    return results


def _refuse_constant(token):
    raise ValueError(f"non-standard JSON constant {token}")


def _unique_keys(pairs: list) -> dict:
    """An object's members as a dict; a key given twice is refused: Python keeps the last,
    other readers the first, so a copy of the file would mean another document to them."""
    doc = dict(pairs)
    if len(doc) != len(pairs):
        seen: set = set()
        twice = next(k for k, _ in pairs if k in seen or seen.add(k))
        raise ValueError(f"the key {_quote(twice)} is given twice in one object")
    return doc


def read_results(path, label: str = "--from", files: bool = True) -> dict:
    """Read and check a results.json (strict JSON, its figures beside it); one line otherwise.

    Parameters
    ----------
    path : str or Path
        The file; its figures are checked in its directory (`check_results`).
    label : str
        How the refusal names where the path came from (the option, the command).
    files : bool
        Check every figure it names as a file beside it (False: the document alone; the
        caller checks the files it reads).

    Raises
    ------
    HCVInputError
        Not a regular readable file, over `RESULTS_MAX_BYTES`, not UTF-8 strict JSON (a key
        given twice in one object included), or a document `check_results` refuses.
    """
    path = Path(path)
    name = f"{label} {str(path)!r}"
    try:  # non-blocking: a FIFO given as the file must not hang the open
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        why = "is a directory" if exc.errno == errno.EISDIR else f"cannot be read ({exc.strerror})"
        raise HCVInputError(f"{name}: {why}") from None
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(f.fileno())
        if not stat.S_ISREG(st.st_mode):
            raise HCVInputError(f"{name}: not a regular file")
        data = f.read(RESULTS_MAX_BYTES + 1)
    if len(data) > RESULTS_MAX_BYTES:
        raise HCVInputError(f"{name}: over {RESULTS_MAX_BYTES} bytes, not a results.json of hcv")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise HCVInputError(f"{name}: not UTF-8 text") from None
    try:
        doc = json.loads(text, parse_constant=_refuse_constant, object_pairs_hook=_unique_keys)
    except ValueError as exc:
        raise HCVInputError(f"{name}: not JSON ({' '.join(str(exc).split())[:200]})") from None
    except RecursionError:
        raise HCVInputError(f"{name}: not JSON this hcv reads (nested too deeply)") from None
    return check_results(doc, name, base=path.resolve().parent if files else None)
