"""The options and settings of a calibration, checked: the one rule ``hcv calibrate`` and
``hcv sweep`` share.

`check_settings` validates a calibration's target, end, steps per contact, speed and
range; `check_option` that the adapter has the option searched; `spec_with_options`
writes options into an adapter spec. `reference_impl.bench.calibration.calibrate` applies them to
one search, `reference_impl.sweep` to every case of a ``calibrate:`` task before any
cluster starts, so a value is refused the same way by both.
"""

from __future__ import annotations

import inspect
import math

from reference_impl.adapters.registry import parse_spec, resolve_class, resolved_spec
from reference_impl.errors import HCVInputError
from reference_impl.theory.damping import RESTITUTION_ENDS

__all__ = ["ENDS", "QUANTITIES", "check_option", "check_settings", "spec_with_options"]

ENDS = RESTITUTION_ENDS
QUANTITIES = ("restitution",)
# Bounds of the steps per contact N: 2 samples are the least that show a contact; above
# 1e5 a run of 4 contact times is 4e5 adapter steps (minutes for a Python loop).
_MIN_STEPS_PER_CONTACT = 2
_MAX_STEPS_PER_CONTACT = 100_000


def spec_with_options(spec: str, options: dict) -> str:
    """``spec`` with constructor arguments added or replaced (``NAME[k=v,...]``, ``cmd[...]:``)."""
    if not options:
        return spec
    # Bare values (``mujoco[timeconst,Euler]``, as the scorecard prints a spec) are mapped
    # to their keys first: the rewritten spec names every value by its key.
    target, kwargs = resolved_spec(spec)
    for key, val in options.items():
        if not isinstance(key, str) or not key.isidentifier():
            raise HCVInputError(f"adapter option {key!r} is not a name")
        kwargs[key] = val
    bad = [v for v in kwargs.values() if isinstance(v, str) and any(c in v for c in ",[]=")]
    if bad:
        raise HCVInputError(f"adapter option value {bad[0]!r} may not contain , [ ] =")

    def text(v) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if v is None:
            return "none"
        return repr(float(v)) if isinstance(v, float) else str(v)

    if target == "subprocess":
        command = kwargs.pop("command")
        args = ",".join(f"{k}={text(v)}" for k, v in kwargs.items())
        return f"cmd[{args}]:{command}"
    return f"{target}[{','.join(f'{k}={text(v)}' for k, v in kwargs.items())}]"


def check_option(spec: str, param: str) -> type:
    """The adapter class of ``spec``; HCVInputError when it has no constructor option ``param``."""
    target, _ = parse_spec(spec)
    cls = resolve_class(target)
    try:
        params = inspect.signature(cls).parameters
    except (TypeError, ValueError):
        return cls
    names = [n for n, p in params.items() if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    if param not in names and not any(p.kind == p.VAR_KEYWORD for p in params.values()):
        raise HCVInputError(
            f"adapter {target!r} has no option {param!r}; its options: {', '.join(names)}"
        )
    return cls


def check_settings(
    *,
    target,
    quantity: str = "restitution",
    end: str = "overlap",
    steps_per_contact=200,
    v0=None,
    bracket=None,
) -> dict:
    """The settings of a calibration checked and normalised; the one rule for them.

    `calibrate` applies it, and ``hcv sweep`` applies it to every case of a
    ``calibrate:`` task before any cluster starts, so both refuse the same values.

    Parameters
    ----------
    target : float
        Restitution to deliver, in (0, 1].
    quantity : str
        "restitution".
    end : str
        One of `ENDS`.
    steps_per_contact : int
        N in [2, 100000] (dt = t_c / N).
    v0 : float, optional
        Impact speed > 0 (m/s); None: the scene's middle speed.
    bracket : (float, float), optional
        Search range LO < HI, both finite; None: the adapter's default.

    Returns
    -------
    dict
        ``target``, ``quantity``, ``end``, ``steps_per_contact``, ``v0``, ``bracket``.

    Raises
    ------
    HCVInputError
        One line naming the first value that breaks its rule.
    """
    if quantity not in QUANTITIES:
        raise HCVInputError(f"target quantity {quantity!r} is not one of {', '.join(QUANTITIES)}")
    if not isinstance(end, str) or end not in ENDS:
        raise HCVInputError(f"end {end!r} is not one of {', '.join(ENDS)}")
    if not (_is_number(target) and math.isfinite(target) and 0 < target <= 1):
        raise HCVInputError(f"target restitution must be a number in (0, 1], got {target!r}")
    if not (
        isinstance(steps_per_contact, int)
        and not isinstance(steps_per_contact, bool)
        and _MIN_STEPS_PER_CONTACT <= steps_per_contact <= _MAX_STEPS_PER_CONTACT
    ):
        raise HCVInputError(
            f"steps per contact must be an integer in [{_MIN_STEPS_PER_CONTACT}, "
            f"{_MAX_STEPS_PER_CONTACT}], got {steps_per_contact!r}"
        )
    if v0 is not None and not (_is_number(v0) and math.isfinite(v0) and v0 > 0):
        raise HCVInputError(f"v0 must be a speed > 0 (m/s), got {v0!r}")
    if bracket is not None:
        pair = list(bracket) if isinstance(bracket, (list, tuple)) else None
        if not (
            pair is not None
            and len(pair) == 2
            and all(_is_number(x) and math.isfinite(x) for x in pair)
            and pair[0] < pair[1]
        ):
            raise HCVInputError(f"range {bracket!r}: need two finite numbers LO < HI")
        bracket = (float(pair[0]), float(pair[1]))
    return {
        "target": float(target),
        "quantity": quantity,
        "end": end,
        "steps_per_contact": steps_per_contact,
        "v0": None if v0 is None else float(v0),
        "bracket": bracket,
    }


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)
