"""What an adapter returns, checked: arrays of numbers, times from 0, declared staggering
re-aligned (items 5 and 11 of the contract in `reference_impl.adapters.base`, where every
name here is importable from)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from reference_impl.adapters._records import AdapterOutputError, Trajectory

__all__ = ["align_staggered", "check_staggering", "trajectory_from_mapping"]

# t[0] must be 0 within this fraction of the trajectory's duration.
_T0_RTOL = 1e-9
# Declarable staggering (contract item 11): the quantity and the allowed shifts.
_STAGGER_KEYS = ("force", "v")
_MAX_FORCE_LAG = 4  # a larger lag is a mistake, not a scheme

_NONE = object()


def _short_repr(value, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _array(name: str, value, who: str) -> np.ndarray:
    if value is None:
        raise AdapterOutputError(f"{who}: output has no {name!r}")
    if isinstance(value, (list, tuple)):
        # Numbers only: numpy would read "1.5" or true as numbers, hiding a wrong writer.
        bad = next(
            (
                x
                for x in value
                if x is not None
                and not isinstance(x, (list, tuple))  # nested: refused below as not 1-D
                and (isinstance(x, bool) or not isinstance(x, (int, float)))
            ),
            _NONE,
        )
        if bad is not _NONE:
            raise AdapterOutputError(
                f"{who}: {name!r} is not an array of numbers (or null): it holds {_short_repr(bad)}"
            )
        value = [np.nan if x is None else x for x in value]
    elif isinstance(value, (str, bytes, Mapping)):
        raise AdapterOutputError(
            f"{who}: {name!r} is not an array of numbers, got {_short_repr(value)}"
        )
    else:
        kind = getattr(np.asarray(value), "dtype", np.dtype(object)).kind
        if kind not in "fiu":
            raise AdapterOutputError(
                f"{who}: {name!r} is not an array of numbers (dtype kind {kind!r})"
            )
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise AdapterOutputError(f"{who}: {name!r} is not an array of numbers") from None
    if a.ndim != 1:
        raise AdapterOutputError(f"{who}: {name!r} must be 1-D, got shape {a.shape}")
    return a


def check_staggering(value, who: str = "adapter") -> dict:
    """Validate a staggering declaration (contract item 11); returns a plain dict.

    Raises
    ------
    AdapterOutputError
        One line naming the offending key or value.
    """
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise AdapterOutputError(
            f"{who}: 'staggering' must be a mapping such as {{\"force\": 1}}, got {value!r}"
        )
    out: dict = {}
    for key, shift in value.items():
        if key not in _STAGGER_KEYS:
            raise AdapterOutputError(
                f"{who}: staggering key {key!r} is not one of {', '.join(_STAGGER_KEYS)}"
            )
        if key == "force":
            if (
                isinstance(shift, bool)
                or not isinstance(shift, (int, float))
                or shift != int(shift)
                or not 0 <= shift <= _MAX_FORCE_LAG
            ):
                raise AdapterOutputError(
                    f"{who}: staggering 'force' must be an integer lag in "
                    f"0..{_MAX_FORCE_LAG} steps, got {shift!r}"
                )
            if shift:
                out["force"] = int(shift)
        elif shift not in (0, 0.0, 0.5):
            raise AdapterOutputError(
                f"{who}: staggering 'v' must be 0 or 0.5 (half a step behind), got {shift!r}"
            )
        elif shift:
            out["v"] = 0.5
    return out


def align_staggered(tr: Trajectory, staggering: Mapping) -> Trajectory:
    """Re-align staggered force / velocity samples onto t (contract item 11)."""
    if not staggering:
        return tr
    q = tr.q
    out_of_contact = q <= 0
    force, v = tr.force, tr.v
    done = {}
    k = int(staggering.get("force", 0))
    if k:
        k_in = min(k, q.size)  # a lag longer than the run leaves no known force
        tail = np.where(out_of_contact[q.size - k_in :], 0.0, np.nan)
        force = np.concatenate([force[k_in:], tail])
        done["force"] = f"force[n] <- force[n + {k}]"
    if staggering.get("v"):
        last = v[-1] if out_of_contact[-1] else np.nan
        v = np.concatenate([0.5 * (v[:-1] + v[1:]), [last]])
        done["v"] = "v[n] <- (v[n] + v[n + 1]) / 2"
    return Trajectory(tr.t, q, v, force, {**tr.meta, "staggering_aligned": done})


def trajectory_from_mapping(obj, who: str = "adapter", staggering=None) -> Trajectory:
    """Validate an adapter's output (a `Trajectory` or a mapping) and return a `Trajectory`.

    A ``"staggering"`` key of a mapping, or the ``staggering`` argument (the
    adapter's declaration), re-aligns shifted samples (contract item 11).

    Raises
    ------
    AdapterOutputError
        With one line saying what is wrong.
    """
    if isinstance(obj, Trajectory):
        data: Mapping = {"t": obj.t, "q": obj.q, "v": obj.v, "force": obj.force, "meta": obj.meta}
    elif isinstance(obj, Mapping):
        data = obj
    else:
        raise AdapterOutputError(
            f"{who}: returned {type(obj).__name__}, expected a Trajectory or a mapping with "
            "t, q, v, force"
        )
    arrays = {k: _array(k, data.get(k), who) for k in ("t", "q", "v", "force")}
    n = arrays["t"].size
    for k, a in arrays.items():
        if a.size != n:
            raise AdapterOutputError(f"{who}: {k!r} has {a.size} samples but 't' has {n}")
    if n < 2:
        raise AdapterOutputError(f"{who}: need at least 2 samples, got {n}")
    t = arrays["t"]
    if not np.all(np.isfinite(t)):
        raise AdapterOutputError(f"{who}: 't' contains non-finite values")
    if np.any(np.diff(t) <= 0):
        i = int(np.argmax(np.diff(t) <= 0))
        raise AdapterOutputError(
            f"{who}: 't' must increase strictly (t[{i}] = {t[i]!r}, t[{i + 1}] = {t[i + 1]!r})"
        )
    if abs(t[0]) > _T0_RTOL * (t[-1] - t[0]):
        raise AdapterOutputError(f"{who}: 't' must start at 0 (contact onset), got {t[0]!r}")
    meta = data.get("meta") or {}
    if not isinstance(meta, Mapping):
        raise AdapterOutputError(f"{who}: 'meta' must be a mapping, got {type(meta).__name__}")
    declared = check_staggering(staggering, who)
    declared.update(
        check_staggering(data.get("staggering"), who) if isinstance(data, Mapping) else {}
    )
    tr = Trajectory(arrays["t"], arrays["q"], arrays["v"], arrays["force"], dict(meta))
    return align_staggered(tr, declared)
