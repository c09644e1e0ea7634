"""Sweep keys that belong to the code under test: adapter options, run settings, calibration.

``"adapter.KEY"`` sets a constructor option of a ``bench:`` / ``calibrate:``
task's adapter, ``"run.steps_per_contact"`` the resolution of its runs (dt =
exact contact time / N), ``"calibrate.KEY"`` a setting of a ``calibrate:`` task.
They are kept apart from the scene (`Case.code`) and checked here.

A ``calibrate:`` task's ``param`` is an option of the adapter or, as in ``hcv
calibrate``, the strength of the case's scene law (`LawFamily.strength`: Hunt-Crossley's
``alpha``, a linear dashpot's ``c``): which one depends on each case's scene, so a name
that is some law's strength is checked against every case's law by `check_case_param`.
"""

from __future__ import annotations

from reference_impl.adapters.registry import get_adapter
from reference_impl.bench.calibration._law import option_class, searches_strength
from reference_impl.bench.calibration._options import (
    check_option,
    check_settings,
    spec_with_options,
)
from reference_impl.errors import HCVInputError
from reference_impl.theory.laws import LAWS

__all__ = ["SweepSpecError", "check_case_param"]


class SweepSpecError(HCVInputError):
    """A sweep specification that cannot run (one line naming the offending value)."""


# Sweep keys that belong to the code under test, not to the scene (bench / calibrate).
_CODE_PREFIXES = ("adapter.", "run.", "calibrate.")
_RUN_KEYS = ("steps_per_contact",)
_CALIBRATE_KEYS = ("param", "target", "end", "range", "v0", "steps_per_contact")


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


def _check_codes(src: str, task: str, cases) -> None:
    """Check every distinct code setting of a spec's cases; `SweepSpecError` on the first bad one.

    ``cases`` yields (index, label, code). A value the single command refuses refuses
    the whole spec (exit status 2, nothing run), as ``hcv bench`` / ``hcv calibrate``
    refuse it: a bad step, target, end, range, speed or adapter option is no
    combination's accident but a typo, the same in every case it reaches.
    """
    import json

    seen: set[str] = set()
    built: dict = {}
    for index, label, code in cases:
        text = json.dumps(code, sort_keys=True, default=str)
        if text in seen:
            continue
        seen.add(text)
        try:
            _check_code(code, task, built)
        except HCVInputError as exc:
            raise SweepSpecError(f"spec {src}: case {index} ({label}): {exc}") from None


def _check_code(code: dict, task: str, built: dict | None = None) -> None:
    """Validate one case's code settings with the single commands' rules (HCVInputError).

    ``bench:`` run settings follow ``hcv bench``'s (`load_tolerances`: ``[run]`` of a
    tolerances file), ``calibrate:`` settings ``hcv calibrate``'s (`check_settings`,
    ``run.steps_per_contact`` standing for ``calibrate.steps_per_contact`` as the
    case runs it), and adapter options the adapter's own: each distinct set is built as
    ``hcv bench ADAPTER[options]`` builds it (the constructor checks its values; the
    code is not loaded), when the adapter can be built on this machine at all (on a
    remote cluster the code may live on the workers only: they check it there).
    ``built`` caches the option sets already built (text -> error, '' when fine).
    """
    adapter = task.partition(":")[2]
    options = code.get("adapter", {})
    for key, val in options.items():
        if not (val is None or isinstance(val, (bool, int, float, str))):
            raise HCVInputError(f"adapter option {key} = {val!r} must be a number or a string")
    if task.startswith("bench:") and code.get("run"):
        from reference_impl.bench.scorecard.tolerances import load_tolerances

        load_tolerances({"run": dict(code["run"])})
    if task.startswith("calibrate:"):
        _check_calibration(code, adapter)
    if adapter and options:
        from reference_impl.bench.calibration._options import check_option

        for key in options:
            check_option(adapter, key)
        _build(adapter, options, {} if built is None else built)


def _check_calibration(code: dict, adapter: str) -> None:
    """A ``calibrate:`` case's settings, as ``hcv calibrate`` checks them."""

    cal = dict(code.get("calibrate", {}))
    param = cal.get("param")
    if not (isinstance(param, str) and param.isidentifier()):
        raise HCVInputError(f"calibrate.param must be an option name, got {param!r}")
    strengths = sorted({f.strength for f in LAWS.values() if f.strength})
    if param not in strengths:  # no law's strength: an option of the code, or a typo
        try:
            check_option(adapter, param)
        except HCVInputError as exc:
            listed = str(exc) + ("none" if str(exc).endswith("its options: ") else "")
            raise HCVInputError(
                f"{listed}; nor is it a damping law's strength ({', '.join(strengths)})"
            ) from None
    if param in code.get("adapter", {}):
        raise HCVInputError(
            f"adapter.{param} is the option being calibrated (calibrate.param = {param!r}): "
            "the search sets it, so its swept values would be ignored; sweep another key"
        )
    spc = cal.get("steps_per_contact", code.get("run", {}).get("steps_per_contact", 200))
    check_settings(
        target=cal.get("target"),
        end=cal.get("end", "overlap"),
        steps_per_contact=spc,
        v0=cal.get("v0"),
        bracket=cal.get("range"),
    )


def check_case_param(task: str, code: dict, sc) -> None:
    """A ``calibrate:`` case's ``param`` is an option of its adapter or the strength of
    the case's scene law, as ``hcv calibrate`` takes it (`searches_strength`); else
    HCVInputError, one line naming the option, the adapter's options and the strength
    the law has (`option_class`). Other tasks: nothing to check.

    Parameters
    ----------
    task : str
        The spec's task.
    code : dict
        The case's code settings (``calibrate.param``).
    sc : Scene
        The case's validated scene.
    """
    if not task.startswith("calibrate:"):
        return
    adapter, param = task.partition(":")[2], code["calibrate"]["param"]
    if not searches_strength(adapter, param, sc):
        option_class(adapter, param, sc)


def _build(adapter: str, options: dict, built: dict) -> None:
    """Build the adapter with ``options`` as ``hcv bench`` would (cached in ``built``)."""
    import json

    if "" not in built:  # can the code be built here at all? (the base spec, once)
        try:
            get_adapter(adapter).close()
            built[""] = ""
        except HCVInputError as exc:
            built[""] = str(exc) or "not here"
    if built[""]:
        return
    text = json.dumps(options, sort_keys=True)
    if text not in built:
        try:
            get_adapter(spec_with_options(adapter, options)).close()
            built[text] = ""
        except HCVInputError as exc:
            built[text] = str(exc)
    if built[text]:
        raise HCVInputError(built[text])
