"""Sweep keys that belong to the code under test: adapter options, run settings, calibration.

``"adapter.KEY"`` sets a constructor option of a ``bench:`` / ``calibrate:``
task's adapter, ``"run.steps_per_contact"`` the resolution of its runs (dt =
exact contact time / N), ``"calibrate.KEY"`` a setting of a ``calibrate:`` task.
They are kept apart from the scene (`Case.code`) and checked here.
"""

from __future__ import annotations

from reference_impl.errors import HCVInputError

__all__ = ["SweepSpecError"]


class SweepSpecError(HCVInputError):
    """A sweep specification that cannot run (one line naming the offending value)."""


# Sweep keys that belong to the code under test, not to the scene (bench / calibrate).
_CODE_PREFIXES = ("adapter.", "run.", "calibrate.")
_RUN_KEYS = ("steps_per_contact",)
_CALIBRATE_KEYS = ("param", "target", "end", "range", "v0", "steps_per_contact")
# Bounds of a swept steps-per-contact: 2 samples are the least that show a contact;
# above 1e5 a run of 4 contact times is 4e5 adapter steps (minutes for a Python loop).
_SPC_RANGE = (2, 100_000)


def _code_key(src: str, task: str, path: str) -> None:
    """A sweep key for the code: its prefix must suit the task, its name be known."""
    head, _, name = path.partition(".")
    if not (task.startswith("bench:") or task.startswith("calibrate:")):
        raise SweepSpecError(
            f"spec {src}: sweep key {path!r} sets the code under test; it needs a "
            f"'bench:ADAPTER' or 'calibrate:ADAPTER' task, not {task!r}"
        )
    if head == "calibrate" and not task.startswith("calibrate:"):
        raise SweepSpecError(f"spec {src}: sweep key {path!r} needs a 'calibrate:' task")
    allowed = {"run": _RUN_KEYS, "calibrate": _CALIBRATE_KEYS}.get(head)
    if not name.isidentifier() or (allowed is not None and name not in allowed):
        hint = f"one of {', '.join(allowed)}" if allowed else "an adapter option name"
        raise SweepSpecError(f"spec {src}: sweep key {path!r}: {name!r} is not {hint}")


def _check_code(code: dict, task: str = "") -> None:
    """Validate one case's code settings (HCVInputError: the case is invalid).

    Adapter option names are checked against the adapter's constructor (its module is
    imported, the code itself is not loaded).
    """
    spc = code.get("run", {}).get("steps_per_contact")
    spc = code.get("calibrate", {}).get("steps_per_contact", spc)
    if spc is not None and (
        isinstance(spc, bool)
        or not isinstance(spc, int)
        or not _SPC_RANGE[0] <= spc <= _SPC_RANGE[1]
    ):
        raise HCVInputError(
            f"steps_per_contact must be an integer in [{_SPC_RANGE[0]}, {_SPC_RANGE[1]}], "
            f"got {spc!r}"
        )
    for key, val in code.get("adapter", {}).items():
        if not (val is None or isinstance(val, (bool, int, float, str))):
            raise HCVInputError(f"adapter option {key} = {val!r} must be a number or a string")
    adapter = task.partition(":")[2]
    if adapter and code.get("adapter"):
        from reference_impl.bench.calibrate import check_option

        for key in code["adapter"]:
            check_option(adapter, key)
