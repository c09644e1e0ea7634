"""Subprocess adapter: plug in a code that is not Python, through JSON on stdin/stdout.

For every run the suite starts COMMAND once, writes one JSON request to its
standard input, closes it, and reads one JSON response from its standard output.
The command's standard error is kept and shown when the run fails. Protocol
``hcv-adapter/1`` (the same text is in ``docs/adapter-protocol.md``):

Request (stdin)::

    {
      "protocol": "hcv-adapter/1",
      "request": "impact",                 # or "sustained" (two-walls scenes)
      "scene": {
        "name": "hertz-damped",
        "kind": "impact",                  # or "two-walls"
        "potential": {"family": "power", "k": 1.0879e10, "p": 1.5},
        "mass": 0.0041103,                 # effective mass, kg
        "v0": 1.0,                         # approach speed at contact onset, m/s
        "damping": {"law": "universal",    # or "none"
                    "zeta": 0.1,           # C(q) = 2 zeta sqrt(m) U'(q) / sqrt(2 U(q))
                    "restitution": 0.7292},# e asked for (1 for "none")
        "dt": 1.8e-7,                      # time step, s
        "n_steps": 600,                    # step budget
        "velocities": [0.1, 1.0, 5.0],     # every speed of the scene
        "gap": 0.001                       # two-walls only, m
      }
    }

Potential families are those of the scene files: ``power`` (U' = k q^p),
``ellipsoid``, ``sphere``, ``expression``, ``sum`` (README, "Scenes").

Response (stdout), one JSON object::

    {
      "t": [0.0, 1.8e-7, ...],             # s, from 0 (contact onset), increasing
      "q": [0.0, 1.8e-7, ...],             # overlap, m (<= 0: separated)
      "v": [1.0, 0.9999, ...],             # dq/dt, m/s (> 0 approaching)
      "force": [0.0, 12.5, ...],           # normal contact force, N (> 0 repulsive)
      "meta": {"code": "mycode 2.1"},      # optional, free-form
      "implemented_law": {                 # optional: the law the code really uses
        "potential": {"family": "power", "k": 1.0879e10, "p": 1.5},
        "mass": 0.0041103,
        "damping": {"law": "power", "c": 3.2, "exponent": 0.25},
                   # or {"law": "universal", "zeta": 0.1} or {"law": "none"}
        "clips_tension": false,
        "description": "hertz, tsuji damping"
      }
    }

Rules: start at t = 0 with q = 0 and dq/dt = v0; step with exactly ``dt``;
record every step; stop at the first step after q has returned to <= 0, or after
``n_steps`` steps; all four arrays have the same length (>= 2). Non-finite
numbers may be written as null (a blown-up run is a result, not an error). To
report a failure, write ``{"error": "one line"}`` or exit with a non-zero status.
Nothing else may be written to stdout; diagnostics go to stderr.

Failures of one run (non-zero exit, timeout, output that is not JSON or breaks
the rules) fail that run only; the benchmark goes on with the next one.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import signal
import subprocess
import tempfile
from collections.abc import Mapping, Sequence

from ..errors import HCVInputError
from ..scenes._scene import _potential, _Where
from .base import (
    AdapterOutputError,
    AdapterRunError,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    PowerDamping,
    trajectory_from_mapping,
)

__all__ = ["PROTOCOL", "SubprocessAdapter", "law_from_json"]

PROTOCOL = "hcv-adapter/1"
# Characters of the command's stderr kept for a failure report (the tail).
_STDERR_TAIL = 4000
# Largest response accepted (bytes): a trajectory of 1e6 samples is ~80 MB of JSON.
_MAX_STDOUT = 256 * 1024 * 1024


def _tail(text: str) -> str:
    text = text.strip()
    return text if len(text) <= _STDERR_TAIL else "..." + text[-_STDERR_TAIL:]


def law_from_json(data, scene: AdapterScene, who: str) -> ImplementedLaw:
    """An `ImplementedLaw` from the ``implemented_law`` object of a response."""
    if not isinstance(data, Mapping):
        raise AdapterOutputError(f"{who}: 'implemented_law' must be an object")
    try:
        pot = (_potential(_Where(who), dict(data["potential"]), "implemented_law.potential")
               if "potential" in data else scene.potential)
    except HCVInputError as exc:
        raise AdapterOutputError(f"{who}: {exc}") from None
    mass = data.get("mass", scene.mass)
    damping = data.get("damping", {"law": "none"})
    if not isinstance(mass, (int, float)) or not mass > 0 or not isinstance(damping, Mapping):
        raise AdapterOutputError(f"{who}: 'implemented_law' needs mass > 0 and a damping object")
    law = damping.get("law")
    kw = dict(clips_tension=bool(data.get("clips_tension", False)),
              description=str(data.get("description", "")))
    try:
        if law == "none":
            return ImplementedLaw(pot, float(mass), zeta=0.0, **kw)
        if law == "universal":
            return ImplementedLaw(pot, float(mass), zeta=float(damping["zeta"]), **kw)
        if law == "power":
            c, a = float(damping["c"]), float(damping.get("exponent", 0.0))
            if not (math.isfinite(c) and c >= 0 and math.isfinite(a)):
                raise ValueError("c must be >= 0 and exponent finite")
            return ImplementedLaw(pot, float(mass), C=PowerDamping(c, a), **kw)
    except (KeyError, TypeError, ValueError, HCVInputError) as exc:
        raise AdapterOutputError(f"{who}: bad 'implemented_law.damping' ({exc})") from None
    raise AdapterOutputError(f"{who}: implemented_law.damping.law must be none, universal or "
                             f"power, got {law!r}")


class SubprocessAdapter(ContactAdapter):
    """Run an external command per impact, speaking the JSON protocol of this module.

    Parameters
    ----------
    command : str or sequence of str
        The command; a string is split like a POSIX shell does (no shell is run).
    timeout : float, optional
        Seconds allowed per run (the process group is killed after it); default
        the benchmark's per-run timeout (tolerances ``[run] timeout``), else 60.
    cwd : str, optional
        Working directory of the command.
    label : str, optional
        Name in scorecards (default: the program's base name).
    sustained : bool
        The command also answers "sustained" requests (two-walls scenes).
    """

    name = "subprocess"
    isolate = False  # every run is already a separate process with a timeout

    def __init__(self, command: str | Sequence[str], timeout: float | None = None,
                 cwd: str | None = None, label: str | None = None, sustained: bool = False):
        if isinstance(command, str):
            argv = shlex.split(command)
        elif isinstance(command, Sequence) and all(isinstance(a, str) for a in command):
            argv = list(command)
        else:
            raise HCVInputError(f"subprocess adapter: command must be a string or a list of "
                                f"strings, got {command!r}")
        if not argv:
            raise HCVInputError("subprocess adapter: empty command")
        self.timeout_given = timeout is not None
        timeout = 60.0 if timeout is None else timeout
        if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
            raise HCVInputError(f"subprocess adapter: timeout must be > 0 s, got {timeout!r}")
        self.argv = argv
        self.timeout = float(timeout)
        self.cwd = cwd
        prog = argv[0]
        if os.path.basename(prog).startswith("python"):
            prog = next((a for a in argv[1:] if not a.startswith("-")), prog)
        self._label = label or os.path.basename(prog)
        self.supports_sustained = bool(sustained)
        self._laws: dict[tuple, ImplementedLaw] = {}

    @property
    def label(self) -> str:
        return self._label

    def describe(self) -> dict:
        return {"name": self.name, "label": self.label, "command": self.argv,
                "timeout": self.timeout, "protocol": PROTOCOL}

    def _call(self, request: str, scene: AdapterScene) -> dict:
        payload = json.dumps({"protocol": PROTOCOL, "request": request, "scene": scene.to_json()})
        with tempfile.TemporaryFile() as err, tempfile.TemporaryFile() as out:
            try:
                proc = subprocess.Popen(self.argv, stdin=subprocess.PIPE, stdout=out, stderr=err,
                                        cwd=self.cwd, start_new_session=True)
            except OSError as exc:
                raise AdapterRunError(f"{self.label}: cannot start {self.argv[0]!r} "
                                      f"({exc.strerror})") from None
            try:
                proc.communicate(payload.encode(), timeout=self.timeout)
            except subprocess.TimeoutExpired:
                _kill_group(proc)
                err.seek(0)
                raise AdapterRunError(f"{self.label}: timeout after {self.timeout:g} s",
                                      _tail(err.read().decode(errors="replace"))) from None
            except BrokenPipeError:
                proc.wait(timeout=self.timeout)
            err.seek(0)
            stderr = _tail(err.read().decode(errors="replace"))
            if proc.returncode != 0:
                rc = proc.returncode
                how = (f"killed by signal {-rc} ({_signame(-rc)})" if rc < 0
                       else f"exit status {rc}")
                raise AdapterRunError(f"{self.label}: command failed, {how}", stderr)
            size = out.tell()
            if size > _MAX_STDOUT:
                raise AdapterOutputError(f"{self.label}: {size} bytes on stdout, more than "
                                         f"{_MAX_STDOUT}")
            out.seek(0)
            raw = out.read().decode(errors="replace")
        try:
            data = json.loads(raw)
        except json.JSONDecodeError as exc:
            first = raw.strip().splitlines()[0][:80] if raw.strip() else "(empty)"
            raise AdapterOutputError(f"{self.label}: stdout is not one JSON object ({exc.msg} at "
                                     f"line {exc.lineno}; starts with {first!r})") from None
        if not isinstance(data, dict):
            raise AdapterOutputError(f"{self.label}: stdout must be a JSON object, got "
                                     f"{type(data).__name__}")
        if "error" in data:
            raise AdapterRunError(f"{self.label}: reported error: {str(data['error'])[:300]}",
                                  stderr)
        return data

    def _run(self, request: str, scene: AdapterScene):
        data = self._call(request, scene)
        if "implemented_law" in data:
            self._laws[(scene.name, scene.v0)] = law_from_json(data["implemented_law"], scene,
                                                               self.label)
        return trajectory_from_mapping(data, who=self.label)

    def _impact_impl(self, scene: AdapterScene):
        return self._run("impact", scene)

    def _sustained_impl(self, scene: AdapterScene):
        return self._run("sustained", scene)

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        """The law declared in the last response for this scene and speed, else the scene's."""
        law = self._laws.get((scene.name, scene.v0))
        return law if law is not None else super().implemented_law(scene)


def _signame(num: int) -> str:
    try:
        return signal.Signals(num).name
    except ValueError:
        return "unknown signal"


def _kill_group(proc: subprocess.Popen) -> None:
    """Kill the command and everything it started (its own session), then reap it."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:  # pragma: no cover - SIGKILL is not ignorable
        pass
