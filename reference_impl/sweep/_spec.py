"""Sweep specifications: a scene, a table of swept dotted paths, a task; expanded into cases.

A spec is a TOML document::

    task = "dt-crit"                 # "dt-crit" | "solve" | "bench:ADAPTER" | "calibrate:ADAPTER"
    criterion = "tol=0.5"            # dt-crit only; or a table {impact = "...", two-sided = "..."}
    timeout = 600                    # s per case (optional)
    [scene]                          # the usual scene table (see reference_impl.scenes)
    name = "hertz-map"
    mass = 1.0
    velocities = [1.0]
    kind = "two-sided"
    [scene.potential]
    family = "power"
    k = 1.0
    p = 1.5
    [sweep]                          # dotted path into [scene] -> list of values
    "potential.p" = [1.0, 1.5, 2.0, 3.0]
    "kind" = ["two-sided", "impact"]

A dt-crit sweep of chain or lattice scenes (assemblies) may carry an ``[assembly]`` table
(``horizons``, ``lanes``, ``lane_group``): each scene's ensemble then runs as one case per
horizon and group of lanes (`reference_impl.sweep._assembly`), so that the Dask tasks are
large and even.

Besides dotted paths into ``[scene]``, a ``bench:`` or ``calibrate:`` task may
sweep what belongs to the code: ``"adapter.KEY"`` (a constructor option of the
adapter, any variant key, e.g. ``"adapter.dampratio" = [0.1, 0.2]``) and
``"run.steps_per_contact"`` (dt = exact contact time / N); a ``calibrate:`` task
also ``"calibrate.target"`` and ``"calibrate.end"``. A ``calibrate:ADAPTER`` task
needs a ``[calibrate]`` table: ``param`` (the option searched, or the strength of
the case's scene law, as ``hcv calibrate`` takes it), ``target``
(restitution), optionally ``end``, ``range = [LO, HI]``, ``v0``,
``steps_per_contact`` (see `reference_impl.bench.calibration.calibrate`).

The sweep is the Cartesian product of the ``[sweep]`` lists, in the order the
keys are written (the last key varies fastest). Spec-level problems (syntax,
unknown keys, a sweep value that is not a non-empty list, a task or criterion
that does not parse, too many cases, every case invalid, a code setting that ``hcv
bench`` or ``hcv calibrate`` would refuse, see `_code._check_codes`) raise
`SweepSpecError` with one line. A case whose scene does not validate is kept as an *invalid
case* (its error becomes its row), so one bad combination does not lose the
sweep.
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from reference_impl._userfiles import check_path
from reference_impl.errors import HCVInputError
from reference_impl.scenes import scene_from_dict
from reference_impl.stability.search import KINDS, parse_criterion
from reference_impl.sweep._assembly import ASSEMBLY_KINDS, check_assembly_table, lane_groups
from reference_impl.sweep._code import (  # noqa: F401
    _CALIBRATE_KEYS,
    _CODE_PREFIXES,
    SweepSpecError,
    _check_codes,
    _code_key,
    check_case_param,
)

__all__ = [
    "MAX_CASES",
    "TASKS",
    "DEFAULT_TIMEOUT",
    "Case",
    "SweepSpec",
    "SweepSpecError",
    "load_spec",
    "parse_spec",
    "spec_from_dict",
]

# Refuse sweeps above this many cases: a 1e5-case map is the largest the README
# sizes (about 8 core-hours at 0.3 s a case); more should be split into several
# sweeps (each validated up front, each with its own resumable output directory).
MAX_CASES = 100_000
# Per-case time limit (s) when the spec gives none: 2000 times the 0.3 s of a
# typical sustained search, so it stops a runaway case and never a normal one.
DEFAULT_TIMEOUT = 600.0
# A spec is a few lines; refusing large files keeps a wrong path from being read whole.
_MAX_SPEC_BYTES = 1_000_000
TASKS = ("dt-crit", "solve", "bench:ADAPTER", "calibrate:ADAPTER")
_TOP_KEYS = ("task", "criterion", "timeout", "scene", "sweep", "calibrate", "assembly")


@dataclass(frozen=True)
class Case:
    """One point of the sweep.

    Attributes
    ----------
    index : int
        Position in the Cartesian product (0-based).
    key : str
        Hash of what determines the result (task, criterion, scene): the
        case's identity for `--resume`.
    params : dict
        Swept dotted path -> value for this case.
    scene : dict
        The full scene table of the case (TOML schema).
    task : str
        "dt-crit", "solve", "bench:ADAPTER" or "calibrate:ADAPTER".
    criterion : str or None
        The dt-crit criterion text for this case's kind (None: the default).
    timeout : float
        Time limit of the case (s).
    error : str
        Empty for a valid case; else the one-line reason its scene is invalid.
    code : dict
        What belongs to the code (bench / calibrate): ``adapter`` options, ``run``
        settings, ``calibrate`` settings, each a dict (empty when none).
    """

    index: int
    key: str
    params: dict
    scene: dict
    task: str
    criterion: str | None
    timeout: float
    error: str = ""
    code: dict = field(default_factory=dict)

    def payload(self) -> dict:
        """What a worker needs to run the case (plain data, picklable)."""
        return {
            "key": self.key,
            "task": self.task,
            "criterion": self.criterion,
            "scene": self.scene,
            "timeout": self.timeout,
            **({"code": self.code} if self.code else {}),
        }


@dataclass
class SweepSpec:
    """A parsed and validated sweep.

    Attributes
    ----------
    task : str
        "dt-crit", "solve", "bench:ADAPTER" or "calibrate:ADAPTER".
    criterion : dict
        Scene kind -> criterion text (dt-crit); empty for the defaults.
    timeout : float
        Per-case time limit (s).
    scene : dict
        The base scene table.
    sweep : dict
        Dotted path -> list of values, in the order given.
    source : str
        Where the spec came from.
    text : str
        The spec as TOML text (copied to DIR/spec.toml).
    cases : list of Case
        The Cartesian product, every case's scene validated.
    """

    task: str
    criterion: dict
    timeout: float
    scene: dict
    sweep: dict
    source: str
    text: str
    cases: list[Case] = field(default_factory=list)

    @property
    def varying(self) -> list[str]:
        """Swept paths with more than one value."""
        return [k for k, v in self.sweep.items() if len(v) > 1]

    @property
    def invalid(self) -> list[Case]:
        return [c for c in self.cases if c.error]


def _set_path(table: dict, path: str, value: Any) -> None:
    """table[path] = value for a dotted path; integer parts index arrays (terms.1.p)."""
    parts = path.split(".")
    node: Any = table
    for i, part in enumerate(parts[:-1]):
        if isinstance(node, list):
            node = node[int(part)]
            continue
        nxt = node.get(part)
        if nxt is None:
            nxt = node[part] = [] if parts[i + 1].isdigit() else {}
        node = nxt
        if not isinstance(node, (dict, list)):
            raise SweepSpecError(
                f"sweep key {path!r} goes through {'.'.join(parts[: i + 1])!r} = {node!r}, "
                "which is a value, not a table"
            )
    last = parts[-1]
    if isinstance(node, list):
        if not last.isdigit() or int(last) >= len(node):
            raise SweepSpecError(f"sweep key {path!r}: {last!r} is not an index of that array")
        node[int(last)] = value
    else:
        node[last] = value


def _check_path(err_src: str, path: str, scene: dict) -> None:
    """A sweep key must be a dotted path; array indices must exist in the base scene."""
    parts = path.split(".")
    if not path or any(not p.strip() for p in parts):
        raise SweepSpecError(
            f"spec {err_src}: sweep key {path!r} is not a dotted path such as 'potential.p'"
        )
    node: Any = scene
    for i, part in enumerate(parts):
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise SweepSpecError(
                    f"spec {err_src}: sweep key {path!r}: index {part!r} "
                    f"is not an index of the {len(node)} entries there"
                )
            node = node[int(part)]
        elif isinstance(node, dict):
            node = node.get(part)
        elif node is None:  # a table the sweep creates (e.g. damping.zeta without [damping])
            return
        else:
            where = ".".join(parts[:i])
            raise SweepSpecError(
                f"spec {err_src}: sweep key {path!r} goes through {where!r} = {node!r}, "
                "which is a value, not a table"
            )


def _check_nesting(err_src: str, paths: list[str]) -> None:
    """No swept key may lie inside another ("potential" and "potential.p")."""
    for a in paths:
        for b in paths:
            if a != b and b.startswith(a + "."):
                raise SweepSpecError(
                    f"spec {err_src}: sweep keys {a!r} and {b!r} overlap ({b!r} lies inside "
                    f"{a!r}); sweep whole {a!r} tables or {b!r}, not both"
                )


def _key(task: str, criterion: str | None, scene: dict, code: dict | None = None) -> str:
    what = {"task": task, "criterion": criterion, "scene": scene}
    if code:  # only when present, so the keys of scene-only sweeps stay as they were
        what["code"] = code
    text = json.dumps(what, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def _criterion_table(src: str, task: str, value) -> dict:
    if value is None:
        return {}
    if task != "dt-crit":
        raise SweepSpecError(
            f"spec {src}: criterion applies to task = 'dt-crit' only, "
            f"but task = {task!r}; remove it"
        )
    if isinstance(value, str):
        return {k: value for k in KINDS}
    if isinstance(value, dict):
        for k, v in value.items():
            if k not in KINDS:
                raise SweepSpecError(
                    f"spec {src}: criterion.{k}: not a scene kind ({', '.join(KINDS)})"
                )
            if not isinstance(v, str):
                raise SweepSpecError(
                    f"spec {src}: criterion.{k} must be a string such as 'tol=0.5', got {v!r}"
                )
        return dict(value)
    raise SweepSpecError(
        f"spec {src}: criterion must be a string or a table of strings by kind, got {value!r}"
    )


def _check_task(src: str, task) -> str:
    if not isinstance(task, str) or not (
        task in ("dt-crit", "solve")
        or (task.startswith("bench:") and task[6:].strip())
        or (task.startswith("calibrate:") and task[10:].strip())
    ):
        raise SweepSpecError(
            f"spec {src}: task = {task!r} is not one of 'dt-crit', 'solve', 'bench:ADAPTER', "
            "'calibrate:ADAPTER'"
        )
    return task


def spec_from_dict(
    data: dict, source: str = "<dict>", text: str | None = None, progress=None
) -> SweepSpec:
    """Validate a parsed spec and expand it into validated cases.

    Parameters
    ----------
    data : dict
        The TOML document as a dict (see the module docstring).
    source : str
        Label for messages.
    text : str, optional
        The TOML text (kept for DIR/spec.toml); rebuilt from ``data`` if None.
    progress : callable, optional
        ``progress(done, total)`` while the cases are validated (each distinct
        potential is validated once, so a large sweep of one expression is quick).

    Raises
    ------
    SweepSpecError
        Any spec-level problem, or when every case's scene is invalid.
    """

    src = source
    if not isinstance(data, dict):
        raise SweepSpecError(f"spec {src}: must be a TOML table")
    for k in data:
        if k not in _TOP_KEYS:
            near = difflib.get_close_matches(k, _TOP_KEYS, n=1)
            hint = f"did you mean {near[0]!r}?" if near else f"allowed: {', '.join(_TOP_KEYS)}"
            raise SweepSpecError(f"spec {src}: unknown key {k!r} ({hint})")
    for k in ("task", "scene", "sweep"):
        if k not in data:
            raise SweepSpecError(f"spec {src}: missing key {k!r}")
    task = _check_task(src, data["task"])
    crit = _criterion_table(src, task, data.get("criterion"))
    timeout = data.get("timeout", DEFAULT_TIMEOUT)
    if (
        isinstance(timeout, bool)
        or not isinstance(timeout, (int, float))
        or not (math.isfinite(timeout) and timeout > 0)
    ):
        raise SweepSpecError(
            f"spec {src}: timeout must be a number of seconds > 0, got {timeout!r}"
        )
    scene, sweep = data["scene"], data["sweep"]
    asm = check_assembly_table(src, task, data.get("assembly"))
    calib = data.get("calibrate")
    if task.startswith("calibrate:"):
        if not isinstance(calib, dict):
            raise SweepSpecError(
                f"spec {src}: task {task!r} needs a [calibrate] table with param and target"
            )
        for k in calib:
            if k not in _CALIBRATE_KEYS:
                raise SweepSpecError(
                    f"spec {src}: calibrate.{k}: not one of {', '.join(_CALIBRATE_KEYS)}"
                )
        for k in ("param", "target"):
            if k not in calib and f"calibrate.{k}" not in (sweep or {}):
                raise SweepSpecError(f"spec {src}: [calibrate] needs {k!r}")
    elif calib is not None:
        raise SweepSpecError(f"spec {src}: [calibrate] applies to 'calibrate:ADAPTER' tasks only")
    if not isinstance(scene, dict):
        raise SweepSpecError(f"spec {src}: [scene] must be a table, got {scene!r}")
    if not isinstance(sweep, dict) or not sweep:
        raise SweepSpecError(f"spec {src}: [sweep] must be a table of dotted path = [values]")
    n = 1
    for path, values in sweep.items():
        if path.startswith(_CODE_PREFIXES):
            _code_key(src, task, path)
        else:
            _check_path(src, path, scene)
        if not isinstance(values, list) or not values:
            raise SweepSpecError(
                f"spec {src}: sweep {path!r} must be a non-empty array of values, got {values!r}"
            )
        seen: set[str] = set()
        for v in values:
            canon = json.dumps(v, sort_keys=True)
            if canon in seen:
                raise SweepSpecError(f"spec {src}: sweep {path!r} repeats the value {v!r}")
            seen.add(canon)
        n *= len(values)
    _check_nesting(src, list(sweep))
    if n > MAX_CASES:
        raise SweepSpecError(
            f"spec {src}: {n} cases is more than the maximum {MAX_CASES}; "
            "split the sweep into several specs"
        )
    spec = SweepSpec(
        task, crit, float(timeout), scene, sweep, src, text if text is not None else _to_toml(data)
    )
    paths = list(sweep)
    expanded = []  # (params, case scene) in product order
    for index, combo in enumerate(itertools.product(*(sweep[p] for p in paths))):
        case_scene = copy.deepcopy(scene)
        params = dict(zip(paths, combo, strict=True))
        code: dict = {"calibrate": dict(calib)} if isinstance(calib, dict) else {}
        for p, v in params.items():
            if p.startswith(_CODE_PREFIXES):
                head, _, name = p.partition(".")
                code.setdefault(head, {})[name] = copy.deepcopy(v)
                continue
            if p == "velocities" and not isinstance(v, list):
                v = [v]  # a scalar speed: one speed per case
            try:
                _set_path(case_scene, p, copy.deepcopy(v))
            except SweepSpecError as exc:
                raise SweepSpecError(
                    f"spec {src}: case {index} ({_label(params)}): {exc}"
                ) from None
        expanded.append((params, case_scene, code))
    expanded = _assembly_groups(src, task, asm, expanded)
    if task.startswith(("bench:", "calibrate:")):  # the code's settings: before any scene
        _check_codes(src, task, ((i, _label(p), c) for i, (p, _s, c) in enumerate(expanded)))
    ctexts = [_case_criterion(crit, cs) for _, cs, _code in expanded]
    errors = _validate_cases(src, task, expanded, ctexts, progress)
    keys: dict[str, int] = {}
    for index, ((params, case_scene, code), ctext, error) in enumerate(
        zip(expanded, ctexts, errors, strict=True)
    ):
        key = _key(task, ctext, case_scene, code)
        if key in keys:
            first = spec.cases[keys[key]]
            raise SweepSpecError(
                f"spec {src}: cases {first.index} ({_label(first.params)}) and {index} "
                f"({_label(params)}) give the same scene; remove one of the values"
            )
        keys[key] = index
        spec.cases.append(
            Case(index, key, params, case_scene, task, ctext, float(timeout), error, code)
        )
    if all(c.error for c in spec.cases):
        raise SweepSpecError(f"spec {src}: every case is invalid; first: {spec.cases[0].error}")
    return spec


def _assembly_groups(src: str, task: str, asm: dict | None, expanded: list) -> list:
    """Each dt-crit case of a chain or lattice scene as its groups of lanes, one case per
    horizon and group (`reference_impl.sweep._assembly`); other cases as they are."""
    out, found = [], False
    for params, case_scene, code in expanded:
        if task != "dt-crit" or case_scene.get("kind") not in ASSEMBLY_KINDS:
            out.append((params, case_scene, code))
            continue
        found = True
        for g in lane_groups(asm):
            where = {"assembly.horizon": g["horizon"], "assembly.first_lane": g["first_lane"]}
            out.append(({**params, **where}, case_scene, {**code, "assembly": g}))
    if asm is not None and not found:
        raise SweepSpecError(f"spec {src}: [assembly] applies to chain and lattice scenes only")
    if len(out) > MAX_CASES:
        raise SweepSpecError(
            f"spec {src}: {len(out)} cases (groups of lanes included) is more than the maximum "
            f"{MAX_CASES}; split the sweep into several specs"
        )
    return out


def _case_criterion(crit: dict, case_scene: dict) -> str | None:
    raw_kind = case_scene.get("kind", "impact")
    return crit.get(raw_kind) if isinstance(raw_kind, str) else None


def _energy(case_scene: dict) -> float:
    """Largest impact energy of a case scene (J), -inf when its numbers are not numbers."""
    m, vels = case_scene.get("mass"), case_scene.get("velocities")
    try:
        e = max(0.5 * float(m) * float(v) ** 2 for v in vels)
    except (TypeError, ValueError, OverflowError):
        return -math.inf
    return e if math.isfinite(e) else -math.inf


def _validate_cases(src, task, expanded, ctexts, progress) -> list[str]:
    """Validate every case's scene and code options; the error of each ('' when valid).

    Each distinct potential is validated once (the cache of `scene_from_dict`), and
    cases are validated from the largest impact energy down: once a potential has a
    turning point at energy E it has one at every lower energy (U rises continuously
    from 0), so the turning-point search runs about once per potential instead of
    once per case (issue 22: 1e5 cases of one expression took ~40 min).
    """

    potentials: dict = {}
    errors = [""] * len(expanded)
    order = sorted(range(len(expanded)), key=lambda i: -_energy(expanded[i][1]))
    for done, index in enumerate(order):
        if progress is not None:
            progress(done, len(order))
        params, case_scene, code = expanded[index]
        ctext = ctexts[index]
        try:
            sc = scene_from_dict(
                case_scene, f"case {index} ({_label(params)})", potentials=potentials
            )
            if task == "solve" and sc.kind != "impact":
                raise HCVInputError(
                    f"case {index} ({_label(params)}): task 'solve' solves "
                    f"single impacts, but kind = {sc.kind!r}"
                )
            if task.startswith("bench:") and sc.kind not in ("impact", "two-walls"):
                raise HCVInputError(
                    f"case {index} ({_label(params)}): bench runs impact and "
                    f"two-walls scenes, not {sc.kind!r}"
                )
            if task.startswith("calibrate:") and sc.kind != "impact":
                raise HCVInputError(
                    f"case {index} ({_label(params)}): calibrate runs impact scenes, "
                    f"not {sc.kind!r}"
                )
        except HCVInputError as exc:
            errors[index] = str(exc)
        else:
            if ctext is not None:
                try:
                    parse_criterion(ctext, sc.kind)
                except HCVInputError as exc:
                    raise SweepSpecError(
                        f"spec {src}: criterion {ctext!r} for kind {sc.kind!r}: {exc}"
                    ) from None
            try:  # calibrate.param: an option, or the strength of this case's law
                check_case_param(task, code, sc)
            except HCVInputError as exc:
                raise SweepSpecError(
                    f"spec {src}: case {index} ({_label(params)}): {exc}"
                ) from None
    if progress is not None:
        progress(len(order), len(order))
    return errors


def _label(params: dict) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in params.items())


def _to_toml(data: dict) -> str:
    """Minimal TOML writer for specs given as dicts (strings, numbers, lists, tables)."""

    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (int, float)):
            return (
                repr(v) if math.isfinite(v) else ("nan" if v != v else ("inf" if v > 0 else "-inf"))
            )
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + "}"
        raise SweepSpecError(f"cannot write {v!r} as TOML")

    lines: list[str] = []

    def table(prefix: str, d: dict) -> None:
        subs = {k: v for k, v in d.items() if isinstance(v, dict)}
        for k, v in d.items():
            if k not in subs:
                lines.append(f"{json.dumps(k)} = {val(v)}")
        for k, v in subs.items():
            name = f"{prefix}.{json.dumps(k)}" if prefix else json.dumps(k)
            lines.append(f"\n[{name}]")
            table(name, v)

    table("", data)
    return "\n".join(lines) + "\n"


def parse_spec(text: str, source: str = "<string>", progress=None) -> SweepSpec:
    """Parse and validate the TOML text of a sweep spec (see `spec_from_dict`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SweepSpecError(f"spec {source}: TOML syntax error: {exc}") from None
    return spec_from_dict(data, source, text, progress)


def load_spec(path, progress=None) -> SweepSpec:
    """Load and validate a sweep spec file (one-line `SweepSpecError` on any problem)."""

    check_path(path, "spec file")
    p = Path(path)
    if not p.is_file():
        raise SweepSpecError(f"spec file {path}: not found (give a .toml sweep spec)")
    if p.stat().st_size > _MAX_SPEC_BYTES:
        raise SweepSpecError(
            f"spec file {path}: larger than {_MAX_SPEC_BYTES} bytes; is this the right file?"
        )
    try:
        text = p.read_text(encoding="utf-8")
    except (UnicodeDecodeError, OSError) as exc:
        raise SweepSpecError(f"spec file {path}: cannot be read ({exc})") from None
    return parse_spec(text, str(path), progress)
