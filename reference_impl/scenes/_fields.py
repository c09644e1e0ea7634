"""The checks every scene value goes through: each error one line, prefixed with the
scene's source (`_Where`), naming the offending key and value. Private to the scenes
package (the scene parser `_scene` and the damping table `_damping`)."""

from __future__ import annotations

import difflib
import math
import sys

from reference_impl.errors import SceneError

__all__: list[str] = []  # private helpers of the scenes package

# Longest name (scene name, family, law) accepted, in characters.
_MAX_NAME_CHARS = 200


class _Where:
    """Error factory that prefixes the scene source to every message."""

    def __init__(self, source: str):
        self.source = source

    def __call__(self, message: str) -> SceneError:
        return SceneError(f"scene {self.source}: {message}")


def _keys(err: _Where, table: dict, path: str, allowed, required=()) -> None:
    """Reject unknown keys (naming the closest allowed one) and missing ones."""
    for key in table:
        if key not in allowed:
            near = difflib.get_close_matches(key, allowed, n=1)
            hint = f"did you mean {near[0]!r}?" if near else f"allowed: {', '.join(allowed)}"
            raise err(f"unknown key {_short(path + str(key))} ({hint})")
    for key in required:
        if key not in table:
            raise err(f"missing key {path + key!r}")


def _number(
    err: _Where,
    value,
    name: str,
    *,
    low: float = -math.inf,
    strict: bool = True,
    high: float = math.inf,
) -> float:
    """``value`` as a float, or SceneError unless it is finite and in (low, high]."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise err(f"{name} must be a number, got {_short(value)}")
    try:
        v = float(value)
    except OverflowError:  # an integer beyond the float range (e.g. 400 digits)
        raise err(f"{name} must be a finite number, got {_short(value)}") from None
    if not math.isfinite(v):
        raise err(f"{name} must be a finite number, got {_short(value)}")
    if 0.0 < abs(v) < sys.float_info.min:  # subnormal: 1 / v overflows to inf
        raise err(f"{name} = {v!r} is below the smallest normal float ({sys.float_info.min:g})")
    if (v <= low if strict else v < low) or v > high:
        rel = ">" if strict else ">="
        bound = f"{rel} {low:g}" + (f" and <= {high:g}" if math.isfinite(high) else "")
        raise err(f"{name} must be {bound}, got {_short(value)}")
    return v


def _short(value, limit: int = 60) -> str:
    """repr(value), cut to ``limit`` characters (a message stays one short line)."""
    if isinstance(value, int) and value.bit_length() > 200:  # no str(): ints of > 4300 digits
        return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _string(err: _Where, value, name: str, choices=None, max_chars: int = _MAX_NAME_CHARS) -> str:
    if not isinstance(value, str) or not value.strip():
        raise err(f"{name} must be a non-empty string, got {_short(value)}")
    if len(value) > max_chars:
        raise err(f"{name} has {len(value)} characters; at most {max_chars}")
    if choices is not None and value not in choices:
        # 'hunt_crossley' for 'hunt-crossley', 'zero_force' for 'zero-force': name the one meant
        near = difflib.get_close_matches(value.replace("_", "-"), list(choices), n=1, cutoff=0.75)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        raise err(
            f"{name} = {_short(value)} is not one of {', '.join(repr(c) for c in choices)}{hint}"
        )
    return value


def _table(err: _Where, value, name: str) -> dict:
    if not isinstance(value, dict):
        raise err(f"{name} must be a table, got {_short(value)}")
    return value
