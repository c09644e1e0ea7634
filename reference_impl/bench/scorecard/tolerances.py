"""Tolerances of the benchmark: the shipped defaults, overridden key by key by a user file.

The defaults are ``reference_impl/bench/scorecard/tolerances.toml`` (read it for what each
key means). A user TOML file may set any subset of the same tables and keys;
anything else is refused with one line (`HCVInputError`, exit status 2).
"""

from __future__ import annotations

import copy
import difflib
import math
import os
import tomllib
from importlib import resources
from typing import Any

from reference_impl.errors import HCVInputError

__all__ = ["default_tolerances", "load_tolerances"]

# Keys whose value is a list of positive integers; every other key is a number > 0.
_INT_LISTS = {("run", "speed_error_steps")}
_INTS = {("run", "steps_per_contact"), ("run", "sustained_steps")}
_MAX_BYTES = 1_000_000
# Upper bounds of the sizes a tolerances file controls (run length, counts, waits),
# checked before any work: a run is at most ~1e7 steps (~1 GB of trajectory at 4 x 8
# bytes per sample in the parent), a wait at most a day.
_MAX = {
    ("run", "timeout"): 86400.0,
    ("run", "startup_timeout"): 86400.0,
    ("run", "steps_per_contact"): 100_000,
    ("run", "budget"): 100.0,
    ("run", "speed_error_steps"): 100_000,
    ("run", "sustained_steps"): 10_000_000,
}
_MAX_SPEED_ERROR_ROWS = 12
# The critical-step bisection stops at this fraction of dt_safe at the finest.
_MIN_RESOLUTION = 1e-4


def default_tolerances() -> dict[str, dict[str, Any]]:
    """The shipped defaults as nested dicts (a fresh copy)."""
    text = (resources.files(__package__) / "tolerances.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def _check(table: str, key: str, value, where: str):
    if (table, key) in _INT_LISTS:
        ok = (
            isinstance(value, list)
            and len(value) >= 2
            and all(isinstance(v, int) and not isinstance(v, bool) and v >= 2 for v in value)
        )
        if not ok:
            raise HCVInputError(
                f"{where}: {table}.{key} must be a list of at least two integers "
                f">= 2, got {value!r}"
            )
        top = _MAX[(table, key)]
        if len(value) > _MAX_SPEED_ERROR_ROWS or max(value) > top:
            raise HCVInputError(
                f"{where}: {table}.{key} takes at most {_MAX_SPEED_ERROR_ROWS} "
                f"values, each <= {top}"
            )
        return sorted(set(value))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise HCVInputError(f"{where}: {table}.{key} must be a number, got {value!r}")
    if not (math.isfinite(value) and value > 0):
        raise HCVInputError(f"{where}: {table}.{key} must be a finite number > 0, got {value!r}")
    top = _MAX.get((table, key))
    if top is not None and value > top:
        raise HCVInputError(f"{where}: {table}.{key} must be <= {top:g}, got {value!r}")
    if (table, key) == ("dt_crit", "resolution") and value < _MIN_RESOLUTION:
        raise HCVInputError(
            f"{where}: dt_crit.resolution must be >= {_MIN_RESOLUTION:g}, got {value!r}"
        )
    if (table, key) in _INTS:
        if int(value) != value or value < 2:
            raise HCVInputError(f"{where}: {table}.{key} must be an integer >= 2, got {value!r}")
        return int(value)
    return float(value)


def load_tolerances(source: str | os.PathLike | dict | None = None) -> dict[str, dict[str, Any]]:
    """Defaults overridden by ``source`` (a TOML file path, or a dict of the same shape).

    Raises
    ------
    HCVInputError
        Missing or unreadable file, TOML syntax error, unknown table or key
        (naming the closest known one), or a value that is not a positive number.
    """
    tol = default_tolerances()
    if source is None:
        return tol
    if isinstance(source, dict):
        user, where = copy.deepcopy(source), "tolerances"
    else:
        where = f"tolerances file {os.fspath(source)}"
        try:
            size = os.path.getsize(source)
            if size > _MAX_BYTES:
                raise HCVInputError(f"{where}: {size} bytes is too large for a tolerances file")
            with open(source, "rb") as fh:
                user = tomllib.load(fh)
        except FileNotFoundError:
            raise HCVInputError(f"{where}: not found") from None
        except tomllib.TOMLDecodeError as exc:
            raise HCVInputError(f"{where}: TOML syntax error: {exc}") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise HCVInputError(f"{where}: cannot be read ({exc})") from None
    for table, entries in user.items():
        if table not in tol:
            near = difflib.get_close_matches(table, list(tol), n=1)
            hint = f"did you mean {near[0]!r}?" if near else f"known: {', '.join(tol)}"
            raise HCVInputError(f"{where}: unknown table [{table}] ({hint})")
        if not isinstance(entries, dict):
            raise HCVInputError(f"{where}: [{table}] must be a table of key = value")
        for key, value in entries.items():
            if key not in tol[table]:
                near = difflib.get_close_matches(key, list(tol[table]), n=1)
                hint = f"did you mean {near[0]!r}?" if near else f"known: {', '.join(tol[table])}"
                raise HCVInputError(f"{where}: unknown key {table}.{key} ({hint})")
            tol[table][key] = _check(table, key, value, where)
    return tol
