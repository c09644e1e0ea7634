"""Subprocess adapter: plug in a code that is not Python, through JSON on stdin/stdout.

For every run the suite starts COMMAND once, writes one JSON request to its
standard input, closes it, and reads one JSON response from its standard output.
The command's standard error is kept and shown when the run fails. Protocol
``hcv-adapter/2`` (the same text is in ``docs/adapter-protocol.md``):

Request (stdin)::

    {
      "protocol": "hcv-adapter/2",
      "request": "impact",                 # or "sustained" (two-walls scenes)
      "scene": {
        "name": "hertz-damped",
        "kind": "impact",                  # or "two-walls"
        "potential": {"family": "power", "k": 1.0879e10, "p": 1.5},
        "mass": 0.0041103,                 # effective mass, kg
        "v0": 1.0,                         # approach speed at contact onset, m/s
        "damping": {"law": "universal",    # or any registered law (hcv scenes --laws:
                                           # "none", "linear", "hunt-crossley", ...)
                    "zeta": 0.1,           # C(q) = 2 zeta sqrt(m) U'(q) / sqrt(2 U(q));
                                           # 0 for every other law
                    "restitution": 0.7292, # protocol 1: exp(-pi zeta / sqrt(1 - zeta^2))
                                           # (1 for "none", the asked e for other laws)
                    "params": {"law": "universal", "zeta": 0.1},
                                           # the law and its (solved) parameters, as
                                           # implemented_law.damping
                    "restitution_asked": 0.7292,  # e the scene asks, at:
                    "restitution_end": "overlap", # or "zero-force"
                    "restitution_speed": 0.5},    # m/s; only for a law whose strength
                                           # was solved from e at that speed
        "dt": 1.8e-7,                      # time step, s
        "n_steps": 600,                    # step budget
        "velocities": [0.1, 1.0, 5.0],     # every speed of the scene
        "gap": 0.001                       # two-walls only, m
      }
    }

Potential families are those of the scene files: ``power`` (U' = k q^p),
``ellipsoid``, ``sphere``, ``expression``, ``sum`` (U(q) of each, with units, in
``docs/adapter-protocol.md``, "Contact laws U(q) of every potential family").

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
record every step (t[i] = i dt to round-off, checked: `_check_steps`); stop at the first step after q has returned to <= 0, or after
``n_steps`` steps; all four arrays have the same length (>= 2). Non-finite
numbers may be written as null (a blown-up run is a result, not an error). To
report a failure, write ``{"error": "one line"}`` or exit with a non-zero status.
To decline a scene the code cannot run (no sphere model, no sustained scenes, a
damping law it does not integrate), write ``{"unsupported": "one line"}``: the scene
is skipped, not failed.
Nothing else may be written to stdout; diagnostics go to stderr. An optional
``"staggering"`` key declares samples stored shifted in time (``{"force": 1}``:
force one step late; ``{"v": 0.5}``: half-step velocities), contract item 11 of
`reference_impl.adapters.base`.

Sustained (two-walls) scenes are sent only to commands declared with
``cmd[sustained=true]:COMMAND`` (other ``cmd[...]`` arguments: ``timeout``,
``label``, ``cwd``, ``persistent``). The time-stepping scheme is declared the same
way, ``cmd[time_scheme=implicit-euler,claimed_order=1]:COMMAND`` (``scheme_rtol``
for ``variable-step``; contract item 12, checked before any run by
`reference_impl.adapters._declaration.declared_scheme`); without it the program is
judged as velocity Verlet.

Options: any other ``cmd[key=value,...]`` argument is an *option of the code*,
passed in every request as ``"options": {"key": value}`` (numbers, true/false or
text). This is how ``hcv calibrate`` and ``hcv sweep`` set ``adapter.KEY`` of a
``cmd:`` program: ``hcv calibrate "cmd:./mycode" --param dampratio --range 0.01 2``
sends ``"options": {"dampratio": ...}``. A request without options has no
``"options"`` key. A program that does not know an option should answer
``{"error": "unknown option KEY"}`` (a typo then fails loudly).

Persistent mode, ``cmd[persistent=true]:COMMAND``: the command is started once
and serves every run: one request per line on stdin (the same object plus an
integer ``"id"``, drawn at random per request), one answer per line on stdout
(the same object as above, on one line, with the same ``"id"``, a JSON integer);
lines that do not start with ``{`` are skipped (a launcher's banner); an answer
line already waiting when a request is sent (written ahead) is refused. Closing stdin asks it to exit. A request that
outlives its timeout, or a process that dies, fails that run only (one line) and
the next run starts a fresh process (`reference_impl.adapters._persistent`).

Assembly scenes (chains, lattices: contract item 14) are sent only to commands declared
with ``cmd[assembly=chain]:COMMAND`` (``lattice``, or ``chain+lattice``; ``advice=true``
when it also answers ``"advice"`` requests with its own step advice): request
``"assembly"`` with an ``"assembly"`` object, answer ``t``, ``x``, ``v`` after every step
(`reference_impl.adapters._cmd_assembly`; ``docs/adapter-protocol.md``).

Failures of one run (non-zero exit, timeout, output that is not JSON or breaks
the rules) fail that run only; the benchmark goes on with the next one. Output is
read while the command runs and capped (`response_limit`): a command that writes
more is killed (its whole process group) and the run fails; so is one that
outlives its timeout, and on Ctrl-C the command is killed before the interrupt
propagates.
"""

from __future__ import annotations

import difflib
import json
import math
import os
import selectors
import shlex
import shutil
import signal
import subprocess
import time
from collections.abc import Mapping, Sequence

from reference_impl._procs import kill_group
from reference_impl.adapters._cmd_assembly import assembly_advice, assembly_run
from reference_impl.adapters._cmd_assembly import check_steps as _check_steps
from reference_impl.adapters._declaration import declared_assembly, declared_scheme
from reference_impl.adapters._persistent import PersistentProcess
from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterOutputError,
    AdapterRunError,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    trajectory_from_mapping,
)
from reference_impl.adapters.law_damping import implemented_law_from_table
from reference_impl.errors import HCVInputError
from reference_impl.scenes._scene import _potential, _Where
from reference_impl.theory.laws import LAWS

__all__ = [
    "PROTOCOL",
    "AdapterDeclined",
    "AdapterTimeout",
    "SubprocessAdapter",
    "law_from_json",
    "response_limit",
]

# Protocol 2 (issue 26) adds to protocol 1's request ``damping.params`` (the law with its
# solved parameters), ``restitution_asked``, ``restitution_end`` and, for a law solved
# from a restitution, ``restitution_speed``; every protocol-1 field is still sent with
# its meaning, so a protocol-1 program runs unchanged on the scenes it knew.
PROTOCOL = "hcv-adapter/2"
# Characters of the command's stderr kept for a failure report (the tail).
_STDERR_TAIL = 4000
# Response size bound: a sample is 4 numbers of at most ~25 characters in JSON plus
# separators (~110 bytes); 160 leaves room for spaces. Plus 1 MiB for meta and the
# implemented law. Never more than 32 MiB: json.loads peaks at ~15x the text size.
_BYTES_PER_SAMPLE = 160
_RESPONSE_SLACK = 1 << 20
_MAX_STDOUT = 32 << 20
# Bytes read from a pipe at a time.
_CHUNK = 1 << 16
# Seconds the selector waits before it rechecks the deadline.
_POLL = 0.5


# The adapter's own cmd[...] arguments (every other key is an option of the code).
_OWN_ARGUMENTS = (
    "command", "timeout", "cwd", "label", "sustained", "persistent",
    "time_scheme", "claimed_order", "scheme_rtol", "assembly", "advice",
)  # fmt: skip


def response_limit(n_steps: int) -> int:
    """Largest response (bytes) accepted for a run of ``n_steps`` steps."""
    return min(_MAX_STDOUT, _RESPONSE_SLACK + _BYTES_PER_SAMPLE * (int(n_steps) + 2))


class AdapterTimeout(AdapterRunError):
    """The command outlived its timeout and was killed."""

    timed_out = True


def _tail(text: str) -> str:
    text = text.strip()
    return text if len(text) <= _STDERR_TAIL else "..." + text[-_STDERR_TAIL:]


# Keys of a response's implemented_law object (its damping table is checked by
# `DampingLaw`): anything else is a typo whose silent omission would change the law the
# code is judged against.
_LAW_KEYS = ("potential", "mass", "damping", "clips_tension", "description")


def law_from_json(data, scene: AdapterScene, who: str) -> ImplementedLaw:
    """An `ImplementedLaw` from the ``implemented_law`` object of a response."""
    if not isinstance(data, Mapping):
        raise AdapterOutputError(f"{who}: 'implemented_law' must be an object")
    try:
        pot = (
            _potential(_Where(who), dict(data["potential"]), "implemented_law.potential")
            if "potential" in data
            else scene.potential
        )
    except HCVInputError as exc:
        raise AdapterOutputError(f"{who}: {exc}") from None
    unknown = sorted(set(data) - set(_LAW_KEYS))
    if unknown:
        raise AdapterOutputError(
            f"{who}: unknown key 'implemented_law.{unknown[0]}' (allowed: {', '.join(_LAW_KEYS)})"
        )
    mass = data.get("mass", scene.mass)
    damping = data.get("damping", {"law": "none"})
    if (
        isinstance(mass, bool)
        or not isinstance(mass, (int, float))
        or not mass > 0
        or not isinstance(damping, Mapping)
    ):
        raise AdapterOutputError(f"{who}: 'implemented_law' needs mass > 0 and a damping object")
    law = damping.get("law")
    clips = data.get("clips_tension", False)
    if not isinstance(clips, bool):
        raise AdapterOutputError(
            f"{who}: 'implemented_law.clips_tension' must be true or false, got {clips!r}"
        )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise AdapterOutputError(f"{who}: 'implemented_law.description' must be a string")
    kw = dict(clips_tension=clips, description=description)

    if law not in LAWS:
        raise AdapterOutputError(
            f"{who}: implemented_law.damping.law must be one of {', '.join(LAWS)}, got {law!r}"
        )
    try:
        # Unknown keys and non-numbers of every law are refused by `DampingLaw`.
        return implemented_law_from_table(pot, float(mass), dict(damping), **kw)
    except (KeyError, TypeError, ValueError, HCVInputError) as exc:
        raise AdapterOutputError(f"{who}: bad 'implemented_law.damping' ({exc})") from None


def _num(value) -> float:
    """A JSON number (never a string or a boolean) as a float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"expected a number, got {value!r}")
    return float(value)


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
    persistent : bool
        Start the command once and send it every run as a JSON line (persistent
        mode, see the module docstring).
    time_scheme, claimed_order, scheme_rtol : optional
        The program's time-stepping scheme, the order it claims and, for
        ``variable-step``, its relative tolerance (contract item 12; none given:
        velocity Verlet, order 2).
    assembly : str, optional
        The assembly scenes the command runs, ``"chain"``, ``"lattice"`` or
        ``"chain+lattice"`` (contract item 14; none given: it declines them).
    advice : bool, optional
        It also answers ``"advice"`` requests with its own step advice.
    **options
        Options of the code, sent in each request as ``"options"`` (numbers,
        booleans or text): what ``hcv calibrate`` / ``hcv sweep`` vary.
    """

    name = "subprocess"
    isolate = False  # every run is already a separate process with a timeout

    def __init__(
        self,
        command: str | Sequence[str],
        timeout: float | None = None,
        cwd: str | None = None,
        label: str | None = None,
        sustained: bool = False,
        persistent: bool = False,
        time_scheme: str | None = None,
        claimed_order: float | None = None,
        scheme_rtol: float | None = None,
        assembly: str | None = None,
        advice: bool | None = None,
        **options,
    ):
        if isinstance(command, str):
            try:
                argv = shlex.split(command)
            except ValueError as exc:  # e.g. an unbalanced quote
                raise HCVInputError(
                    f"subprocess adapter: cannot split the command {command!r} "
                    f"({exc}); check its quotes"
                ) from None
        elif isinstance(command, Sequence) and all(isinstance(a, str) for a in command):
            argv = list(command)
        else:
            raise HCVInputError(
                f"subprocess adapter: command must be a string or a list of "
                f"strings, got {command!r}"
            )
        if not argv:
            raise HCVInputError("subprocess adapter: empty command")
        self.timeout_given = timeout is not None
        timeout = 60.0 if timeout is None else timeout
        if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
            raise HCVInputError(f"subprocess adapter: timeout must be > 0 s, got {timeout!r}")
        if not isinstance(sustained, bool):
            raise HCVInputError(
                f"subprocess adapter: sustained must be true or false, got {sustained!r}"
            )
        if label is not None and not isinstance(label, str):
            raise HCVInputError(f"subprocess adapter: label must be text, got {label!r}")
        if cwd is not None and not (isinstance(cwd, str) and os.path.isdir(cwd)):
            raise HCVInputError(f"subprocess adapter: cwd {cwd!r} is not a directory")
        if not isinstance(persistent, bool):
            raise HCVInputError(
                f"subprocess adapter: persistent must be true or false, got {persistent!r}"
            )
        for key, val in options.items():
            near = difflib.get_close_matches(key, _OWN_ARGUMENTS, n=1, cutoff=0.8)
            if near:  # a typo of an argument of ours would silently become a code option
                raise HCVInputError(
                    f"subprocess adapter: {key!r} looks like a misspelt {near[0]!r}; "
                    "options of the code must not resemble the adapter's own arguments"
                )
            if isinstance(val, bool) or isinstance(val, str) or val is None:
                continue
            if not (isinstance(val, (int, float)) and math.isfinite(val)):
                raise HCVInputError(
                    f"subprocess adapter: option {key}={val!r} must be a finite number, "
                    "true/false or text"
                )
        _check_program(argv[0], cwd)
        self.persistent = persistent
        self.options = dict(options)
        self._server = None  # the PersistentProcess of persistent mode
        self.argv = argv
        self.timeout = float(timeout)
        self.cwd = cwd
        prog = argv[0]
        if os.path.basename(prog).startswith("python"):
            prog = next((a for a in argv[1:] if not a.startswith("-")), prog)
        self._label = label or os.path.basename(prog)
        if self.options and label is None:  # calibration and sweep points are told apart
            self._label += "[" + ",".join(f"{k}={v!r}" for k, v in self.options.items()) + "]"
        self.supports_sustained = bool(sustained)
        scheme = declared_scheme(self._label, time_scheme, claimed_order, scheme_rtol)
        if scheme is not None:  # instance attributes, read by scheme_of as a class's are
            self.time_scheme, self.claimed_order = scheme.name, scheme.order
            self.scheme_rtol = scheme.rtol
        kinds, self.advice = declared_assembly(self._label, assembly, advice)
        self.assembly_kinds = tuple(k for k in ("chain", "lattice") if k in kinds)
        self.supports_assembly, self.supports_lattice = bool(kinds), "lattice" in kinds
        self._n_steps = 0
        self._laws: dict[tuple, ImplementedLaw] = {}

    @property
    def label(self) -> str:
        return self._label

    def describe(self) -> dict:
        return {
            "name": self.name,
            "label": self.label,
            "command": self.argv,
            "timeout": self.timeout,
            "protocol": PROTOCOL,
            "persistent": self.persistent,
            "options": dict(self.options),
            "time_scheme": self.time_scheme,
            "claimed_order": self.claimed_order,
            "scheme_rtol": self.scheme_rtol,
            "assembly": "+".join(self.assembly_kinds) or None,
            "advice": self.advice,
        }

    def _exchange(self, payload: bytes, limit: int) -> tuple[int, bytes, str]:
        """Run the command once: (exit status, stdout, stderr tail); kill it on any way out."""
        try:
            proc = subprocess.Popen(
                self.argv,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                cwd=self.cwd,
                start_new_session=True,
            )
        except OSError as exc:
            raise AdapterRunError(
                f"{self.label}: cannot start {self.argv[0]!r} ({exc.strerror})"
            ) from None
        out, err = bytearray(), bytearray()
        deadline = time.monotonic() + self.timeout
        sel = selectors.DefaultSelector()
        done = False
        try:
            os.set_blocking(proc.stdin.fileno(), False)
            sel.register(proc.stdin, selectors.EVENT_WRITE)
            sel.register(proc.stdout, selectors.EVENT_READ)
            sel.register(proc.stderr, selectors.EVENT_READ)
            sent = 0
            while sel.get_map():
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AdapterTimeout(
                        f"{self.label}: timeout after {self.timeout:g} s",
                        _tail(err.decode(errors="replace")),
                    )
                for key, _ in sel.select(min(left, _POLL)):
                    f = key.fileobj
                    if f is proc.stdin:
                        try:
                            sent += os.write(f.fileno(), payload[sent : sent + _CHUNK])
                        except BlockingIOError:
                            continue
                        except BrokenPipeError:
                            sent = len(payload)  # the command does not read its input
                        if sent >= len(payload):
                            sel.unregister(f)
                            f.close()
                        continue
                    data = os.read(f.fileno(), _CHUNK)
                    if not data:
                        sel.unregister(f)
                        continue
                    if f is proc.stdout:
                        out += data
                        if len(out) > limit:
                            raise AdapterOutputError(
                                f"{self.label}: more than {limit} bytes on stdout for a run of "
                                f"{self._n_steps} steps; the command was stopped"
                            )
                    else:
                        err += data
                        del err[: -2 * _STDERR_TAIL]
            left = deadline - time.monotonic()
            try:
                rc = proc.wait(timeout=max(left, 0.0))
            except subprocess.TimeoutExpired:
                raise AdapterTimeout(
                    f"{self.label}: timeout after {self.timeout:g} s",
                    _tail(err.decode(errors="replace")),
                ) from None
            done = True
        finally:
            sel.close()
            if not done:  # timeout, overflow, Ctrl-C, any error: no process left behind
                kill_group(proc)
            for f in (proc.stdin, proc.stdout, proc.stderr):
                try:
                    f.close()
                except OSError:
                    pass
        return rc, bytes(out), _tail(err.decode(errors="replace"))

    def _persistent_call(self, obj: dict, limit: int, guard=None) -> dict:
        """One request in persistent mode (the process is started on first use)."""

        if self._server is None:
            self._server = PersistentProcess(
                self.argv, self.label, cwd=self.cwd, startup_timeout=self.timeout
            )
        check = None if guard is None else (lambda raw: guard(raw, self.label))
        data = self._server.request(obj, timeout=self.timeout, limit=limit, check=check)
        data.pop("id", None)
        return data

    def close(self) -> None:
        if self._server is not None:
            self._server.close()

    def _call(self, request: str, scene: AdapterScene) -> dict:
        obj = {"request": request, "scene": scene.to_json()}
        return self._send(obj, response_limit(scene.n_steps), int(scene.n_steps))

    def _send(self, obj: dict, limit: int, n_steps: int, guard=None) -> dict:
        """One request (``obj`` with the protocol and options added) in either mode: the
        answer object, or the skip / failure it reports. ``limit``: bytes of the answer;
        ``guard(raw, label)`` checks them before they are parsed."""
        obj = {"protocol": PROTOCOL, **obj}
        if self.options:
            obj["options"] = dict(self.options)
        self._n_steps = int(n_steps)
        if self.persistent:
            return self._answer(self._persistent_call(obj, limit, guard), "")
        payload = json.dumps(obj)
        rc, raw_bytes, stderr = self._exchange(payload.encode(), limit)
        if rc != 0:
            how = f"killed by signal {-rc} ({_signame(-rc)})" if rc < 0 else f"exit status {rc}"
            raise AdapterRunError(f"{self.label}: command failed, {how}", stderr)
        if guard is not None:
            guard(raw_bytes, self.label)
        raw = raw_bytes.decode(errors="replace")
        try:
            data = json.loads(raw)
        except json.JSONDecodeError as exc:
            first = raw.strip().splitlines()[0][:80] if raw.strip() else "(empty)"
            raise AdapterOutputError(
                f"{self.label}: stdout is not one JSON object ({exc.msg} at "
                f"line {exc.lineno}; starts with {first!r})"
            ) from None
        except RecursionError:
            raise AdapterOutputError(f"{self.label}: stdout is JSON nested too deeply") from None
        if not isinstance(data, dict):
            raise AdapterOutputError(
                f"{self.label}: stdout must be a JSON object, got {type(data).__name__}"
            )
        return self._answer(data, stderr)

    def _answer(self, data: dict, stderr: str) -> dict:
        """The response object, or the skip / failure it reports."""
        if "unsupported" in data:  # one line, whatever the program wrote
            raise AdapterDeclined(" ".join(str(data["unsupported"]).split())[:300])
        if "error" in data:
            raise AdapterRunError(
                f"{self.label}: reported error: {str(data['error'])[:300]}", stderr
            )
        return data

    def _run(self, request: str, scene: AdapterScene):
        data = self._call(request, scene)
        if "implemented_law" in data:
            self._laws[(scene.name, scene.v0)] = law_from_json(
                data["implemented_law"], scene, self.label
            )
        tr = trajectory_from_mapping(data, who=self.label)
        _check_steps(tr.t, float(scene.dt), self.label)
        return tr

    def _impact_impl(self, scene: AdapterScene):
        return self._run("impact", scene)

    def _sustained_impl(self, scene: AdapterScene):
        return self._run("sustained", scene)

    def _assembly_impl(self, request):
        """A chain or lattice run (contract item 14), checked (`_cmd_assembly.assembly_run`)."""
        return assembly_run(self._send, request, self.label, self.assembly_kinds)

    def step_advice(self, request) -> dict:
        """The program's own step advice when declared (``advice=true``), else none."""
        return assembly_advice(self._send, request, self.label) if self.advice else {}

    def implemented_law(self, scene: AdapterScene) -> ImplementedLaw:
        """The law declared in the last response for this scene and speed, else the scene's."""
        law = self._laws.get((scene.name, scene.v0))
        return law if law is not None else super().implemented_law(scene)


def _check_program(prog: str, cwd: str | None) -> None:
    """The command's program exists and is executable: a configuration error otherwise.

    A missing program is the user's setup, not a failure of the code under test, so
    it is refused before any run (exit status 2) instead of failing every run.
    """
    if os.sep in prog or (os.altsep and os.altsep in prog):
        path = prog if os.path.isabs(prog) else os.path.join(cwd or os.getcwd(), prog)
        if not os.path.isfile(path):
            raise HCVInputError(f"subprocess adapter: program {prog!r} does not exist")
        if not os.access(path, os.X_OK):
            raise HCVInputError(
                f"subprocess adapter: program {prog!r} is not executable (chmod +x, or run "
                "it through its interpreter, e.g. cmd:python3 my_code.py)"
            )
    elif shutil.which(prog) is None:
        raise HCVInputError(
            f"subprocess adapter: program {prog!r} is not found on PATH; give its path"
        )


def _signame(num: int) -> str:
    try:
        return signal.Signals(num).name
    except ValueError:
        return "unknown signal"
