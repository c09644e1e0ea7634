"""The long-horizon record of the assemblies claim: its form, and its reading as hostile input.

`reference_impl.campaign.assembly_long` runs the claim's counted cases at `LONG_HORIZON`
steps (minutes of CPU per case, too long for every report run) and writes the record
``reports/assemblies_1e6.json`` (`RECORD_PATH`); `reference_impl.claims.sec6_assemblies`
reads it here and merges its horizon into its rows. The record is a file in the tree,
so it is read as hostile input: `read_record` returns the record's cases, each lane's
Delta t_crit re-checked, or None with one line saying why it was ignored (never an
exception), and the claim then falls back to its own horizons.

The record (JSON object, SI units):

``schema`` (`SCHEMA`), ``claim`` (the claim's id), ``horizon`` (steps, `LONG_HORIZON`),
``date`` (UTC, ISO 8601), ``commit``, ``git_dirty``, ``machine`` (`provenance.machine_info`),
``load_average_start`` / ``load_average_end`` (1, 5, 15 min), ``workers``, ``wall_s``,
``settings`` (must equal the claim's `sec6_assemblies.record_settings`: lanes, the search
grid, the runaway criterion, the potential, masses, radius, striker speed, the
perturbation), ``left_out`` (cases of the claim not run, each ``case`` and ``why``) and
``cases``: per case ``case`` (the claim's label), ``n_bodies``, ``n_contacts``, ``dim``,
``coordination`` (the assembly's shape), ``dt_safe`` (the three conventions, s),
``dt_crit`` and ``dt_stable`` (per lane, s), ``evidence`` (per lane), ``quantiles`` (5 / 50
/ 95 % of Delta t_crit, s), ``ratio`` (the same over Delta t_safe), ``p_fail`` ([dt (s),
fraction of lanes failed]), ``dt_tangent`` (s), ``q_run`` (m), ``cage_fraction`` (lane 0
at its largest stable step over the horizon), ``contact_updates``, ``cpu_s``, and optionally
``commit``, ``date`` and ``git_dirty`` of the run that measured it where that is not the
record's first run (``added``: the later runs of ``--add-to``, each with its commit, date,
machine, load, cases and seconds).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from reference_impl.assembly.search import Ensemble

__all__ = ["LONG_HORIZON", "RECORD_PATH", "SCHEMA", "ensemble_of", "read_record"]

SCHEMA = "hcv-assemblies-long/1"
# The longest horizon (steps).
LONG_HORIZON = 1_000_000
# In the repository's reports/ folder, beside the report (which never writes or deletes it:
# it is not in the report's manifest, `reference_impl.report._files`).
RECORD_PATH = Path(__file__).resolve().parents[2] / "reports" / "assemblies_1e6.json"
# A record of ~10 cases x 32 lanes is ~40 kB; anything much larger was not written by the
# campaign (and is not read whole into memory).
_MAX_BYTES = 4 * 2**20
# Delta t_safe in the record against the claim's own (same model, same formula): equal to
# the last bits; 1e-12 relative allows another machine's libm (sqrt, pow) a few ulps.
_SAFE_RTOL = 1e-12
_WHERE = "reports/assemblies_1e6.json"


class _Bad(Exception):
    """Why the record is ignored (one line)."""


def _num(x, what: str, *, positive: bool = True) -> float:
    """A finite number (> 0, or >= 0 when not ``positive``) from the record."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise _Bad(f"{what} is {x!r}, not a number")
    try:
        v = float(x)
    except OverflowError:  # an integer beyond any float
        raise _Bad(f"{what} is an integer of {len(str(x))} digits, not a finite float") from None
    if not math.isfinite(v) or (v <= 0 if positive else v < 0):
        raise _Bad(f"{what} is {x!r}, should be finite and {'> 0' if positive else '>= 0'}")
    return v


def _field(obj: dict, key: str, what: str):
    if not isinstance(obj, dict) or key not in obj:
        raise _Bad(f"{what} has no {key!r}")
    return obj[key]


def _load(path: Path):
    """The parsed JSON of ``path`` (no NaN or Infinity: strict JSON)."""
    try:
        if not path.is_file():
            raise _Bad(f"{path.name} not found")
        if path.stat().st_size > _MAX_BYTES:
            raise _Bad(f"{path.name} is {path.stat().st_size} bytes, more than {_MAX_BYTES}")
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise _Bad(f"{path.name} unreadable ({type(exc).__name__})") from None
    except UnicodeDecodeError:
        raise _Bad(f"{path.name} is not UTF-8 text") from None

    def constant(name):
        raise _Bad(f"{path.name} holds {name}, not strict JSON")

    try:
        return json.loads(text, parse_constant=constant)
    except ValueError as exc:
        raise _Bad(f"{path.name} is not JSON ({str(exc).splitlines()[0][:80]})") from None
    except RecursionError:
        raise _Bad(f"{path.name} is nested too deeply") from None


def _lanes(case: dict, key: str, label: str, n_lanes: int, positive: bool) -> np.ndarray:
    xs = _field(case, key, label)
    if not isinstance(xs, list) or len(xs) != n_lanes:
        n = len(xs) if isinstance(xs, list) else type(xs).__name__
        raise _Bad(f"{label}: {key} has {n} lanes, should be {n_lanes}")
    return np.array([_num(x, f"{label}: {key}[{k}]", positive=positive) for k, x in enumerate(xs)])


def ensemble_of(case: dict) -> Ensemble:
    """The record's case as an `Ensemble` (its quantiles and P_fail are the search's own)."""
    return Ensemble(
        horizon=LONG_HORIZON,
        dt_crit=np.asarray(case["dt_crit"], dtype=float),
        dt_stable=np.asarray(case["dt_stable"], dtype=float),
        evidence=list(case["evidence"]),
        q_run=float(case["q_run"]),
        contact_updates=int(case["contact_updates"]),
        criterion=str(case.get("criterion", "")),
    )


def _short(v, what: str) -> str:
    if not isinstance(v, str) or not v or len(v) > 64:
        raise _Bad(f"{what} is {str(v)[:40]!r}, not a short string")
    return v


def _dirty(v, what: str):
    if v is not None and not isinstance(v, bool):
        raise _Bad(f"{what} is {v!r}, not true, false or null")
    return v


def _case(case, expected: dict, n_lanes: int) -> tuple[str, dict]:
    """(label, the case checked) of one record case against the claim's ``expected``."""
    if not isinstance(case, dict):
        raise _Bad(f"a case is {type(case).__name__}, not an object")
    label = _field(case, "case", "a case")
    if not isinstance(label, str) or label not in expected:
        raise _Bad(f"unknown case {str(label)[:60]!r}")
    want = expected[label]
    for key in ("n_bodies", "n_contacts", "dim", "coordination"):
        got = _field(case, key, label)
        if isinstance(got, bool) or got != want[key]:
            raise _Bad(f"{label}: {key} is {got!r}, the claim's assembly has {want[key]!r}")
    safe = _num(_field(_field(case, "dt_safe", label), "paper", label), f"{label}: dt_safe")
    if abs(safe / want["dt_safe"] - 1.0) > _SAFE_RTOL:
        raise _Bad(f"{label}: dt_safe.paper is {safe!r}, the claim's is {want['dt_safe']!r}")
    crit = _lanes(case, "dt_crit", label, n_lanes, True)
    stable = _lanes(case, "dt_stable", label, n_lanes, False)
    if np.any(stable >= crit):
        k = int(np.argmax(stable >= crit))
        raise _Bad(f"{label}: lane {k}'s stable step {stable[k]!r} is not below its "
                   f"Delta t_crit {crit[k]!r}")  # fmt: skip
    ev = _field(case, "evidence", label)
    if not isinstance(ev, list) or len(ev) != n_lanes:
        raise _Bad(f"{label}: evidence should be a list of {n_lanes}")
    if any(e not in ("confirmed", "domain") for e in ev):
        raise _Bad(f"{label}: a lane's evidence is not 'confirmed' or 'domain'")
    out = {
        "case": label,
        "dt_crit": crit.tolist(),
        "dt_stable": stable.tolist(),
        "evidence": list(ev),
        "q_run": _num(_field(case, "q_run", label), f"{label}: q_run", positive=False),
        "contact_updates": int(
            _num(_field(case, "contact_updates", label), f"{label}: contact_updates")
        ),  # fmt: skip
        "dt_tangent": _num(_field(case, "dt_tangent", label), f"{label}: dt_tangent"),
        "cage_fraction": _num(
            _field(case, "cage_fraction", label), f"{label}: cage_fraction", positive=False
        ),  # fmt: skip
        "cpu_s": _num(_field(case, "cpu_s", label), f"{label}: cpu_s", positive=False),
    }
    # The run that measured the case, where it is not the record's first (`--add-to`).
    for key in ("commit", "date"):
        if key in case:
            out[key] = _short(case[key], f"{label}: {key}")
    if "git_dirty" in case:
        out["git_dirty"] = _dirty(case["git_dirty"], f"{label}: git_dirty")
    # The stored quantiles must be those of the stored lanes (the search's own rule).
    qs = ensemble_of(out).quantiles()
    stored = _field(case, "quantiles", label)
    for p, v in qs.items():
        if _num(_field(stored, p, f"{label}: quantiles"), f"{label}: quantiles[{p}]") != v:
            raise _Bad(f"{label}: its {p} % point {stored[p]!r} is not its lanes' ({v!r})")
    out["quantiles"] = qs
    return label, out


def read_record(path, settings: dict, expected: dict) -> tuple[dict | None, str | None]:
    """The long-horizon record at ``path`` checked against the claim, or why it is ignored.

    Parameters
    ----------
    path : str or os.PathLike
        The record (`RECORD_PATH` by default in the claim).
    settings : dict
        The claim's settings (`sec6_assemblies.record_settings`); the record's must equal
        them, key by key.
    expected : dict
        Per counted case label: ``n_bodies``, ``n_contacts``, ``dim``, ``coordination``
        and ``dt_safe`` (the paper's Delta t_safe of the claim's model, s).

    Returns
    -------
    (dict or None, str or None)
        The record (``horizon``, ``commit``, ``date``, ``git_dirty`` of its first run,
        ``cases``: label -> checked case, each with the ``commit``, ``date`` and
        ``git_dirty`` of its own run, ``left_out``: label -> why) and None; or None and one line why it is
        ignored (missing, not JSON, another schema, settings, lane count, a number that is
        not finite or positive, an unknown case, ...).
    """
    try:
        return _read(Path(path), settings, expected), None
    except _Bad as exc:
        return None, str(exc)


def _read(path: Path, settings: dict, expected: dict) -> dict:
    data = _load(path)
    if not isinstance(data, dict):
        raise _Bad(f"{path.name} is a JSON {type(data).__name__}, not an object")
    if data.get("schema") != SCHEMA:
        raise _Bad(f"schema is {str(data.get('schema'))[:40]!r}, should be {SCHEMA!r}")
    horizon = _field(data, "horizon", "the record")
    if isinstance(horizon, bool) or horizon != LONG_HORIZON:
        raise _Bad(f"horizon is {horizon!r}, should be {LONG_HORIZON}")
    got = _field(data, "settings", "the record")
    if not isinstance(got, dict):
        raise _Bad("settings is not an object")
    for key in sorted(set(settings) | set(got)):
        if got.get(key) != settings.get(key):
            raise _Bad(f"settings.{key} is {str(got.get(key))[:80]}, the claim's is "
                       f"{str(settings.get(key))[:80]}")  # fmt: skip
    meta = {key: _short(_field(data, key, "the record"), key) for key in ("commit", "date")}
    dirty = _dirty(_field(data, "git_dirty", "the record"), "git_dirty")
    n_lanes = settings["n_lanes"]
    cases = _field(data, "cases", "the record")
    if not isinstance(cases, list) or not cases:
        raise _Bad("cases is not a non-empty list")
    out: dict = {}
    for c in cases:
        label, case = _case(c, expected, n_lanes)
        if label in out:
            raise _Bad(f"case {label!r} appears twice")
        case.setdefault("commit", meta["commit"])
        case.setdefault("date", meta["date"])
        case.setdefault("git_dirty", dirty)
        out[label] = case
    left = _field(data, "left_out", "the record")
    if not isinstance(left, list):
        raise _Bad("left_out is not a list")
    left_out = {}
    for x in left:
        if not (isinstance(x, dict) and isinstance(x.get("case"), str)
                and isinstance(x.get("why"), str)):  # fmt: skip
            raise _Bad("a left_out entry is not {case, why}")
        left_out[x["case"][:80]] = x["why"][:200]
    missing = [k for k in expected if k not in out and k not in left_out]
    if missing:
        raise _Bad(f"case {missing[0]!r} is neither in the record nor left out with a reason")
    return {**meta, "horizon": LONG_HORIZON, "git_dirty": dirty, "cases": out,
            "left_out": left_out}  # fmt: skip
