"""Run adapter calls in-process or isolated in a worker process (crash and hang isolation).

`WorkerExecutor` starts one worker process per adapter (multiprocessing, spawn)
that builds the adapter from its spec and serves calls ``(variant, method,
scene)`` (variant None: the adapter itself, not one of its variants). Each call
has a timeout: a worker that does not answer in time is killed, the call fails
with "timeout after T s", and the next call starts a new worker. A worker that
dies (segfault, abort, os._exit) fails the call with its exit status or signal.
The worker's stdout and stderr (file descriptors 1 and 2, so C libraries too) go
to a file whose new lines are attached to a failed call. Results already
received are never affected.

`InProcessExecutor` runs calls directly (trusted adapters, adapters that are
themselves isolated such as the subprocess adapter, or adapter instances
that cannot be rebuilt from a spec); exceptions fail the call, there is no
timeout.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass
from typing import Any

from reference_impl.adapters.base import ContactAdapter
from reference_impl.adapters.registry import get_adapter
from reference_impl.errors import HCVInputError
from reference_impl.errors import one_line as _one_line

__all__ = ["InProcessExecutor", "Outcome", "WorkerExecutor", "make_executor"]

# Characters of a worker's output kept with a failure (the tail).
_STDERR_TAIL = 4000
# Bytes the worker may write to its stdout and stderr files during one call (temporary
# files on disk, emptied before each call); checked while waiting, every _POLL s.
_MAX_OUTPUT = 64 << 20
_POLL = 0.25


@dataclass
class Outcome:
    """Result of one adapter call.

    Attributes
    ----------
    ok : bool
        The call returned.
    value : Any
        What it returned (a Trajectory, an ImplementedLaw, a dict).
    error : str
        One line when it failed: the exception, "timeout after T s", "crashed ...".
    stderr : str
        The adapter's diagnostics for a failed call (tail).
    seconds : float
        Wall time of the call inside the adapter process (s).
    timed_out : bool
        The call failed by exceeding its timeout.
    declined : str
        The code declined the scene at run time (the reason): a skip, not a failure.
    """

    ok: bool
    value: Any = None
    error: str = ""
    stderr: str = ""
    seconds: float = 0.0
    timed_out: bool = False
    declined: str = ""


def _tail(text: str) -> str:
    text = text.strip()
    return text if len(text) <= _STDERR_TAIL else "..." + text[-_STDERR_TAIL:]


class InProcessExecutor:
    """Calls the adapter's variants directly; exceptions fail the call."""

    def __init__(self, adapter: ContactAdapter):
        self.adapter = adapter
        self.variants = adapter.variants()

    def call(self, index: int | None, method: str, *args, timeout: float | None = None) -> Outcome:
        t0 = time.perf_counter()
        target = self.adapter if index is None else self.variants[index]
        try:
            value = getattr(target, method)(*args)
        except Exception as exc:  # an adapter failure is a result, never fatal
            return Outcome(
                False,
                error=_one_line(exc),
                stderr=getattr(exc, "stderr", "") or "",
                seconds=time.perf_counter() - t0,
                timed_out=bool(getattr(exc, "timed_out", False)),
                declined=str(getattr(exc, "declined", "") or ""),
            )
        return Outcome(True, value, seconds=time.perf_counter() - t0)

    def close(self) -> None:
        for v in self.variants:
            try:
                v.close()
            except Exception:  # pragma: no cover - closing is best effort
                pass


def _worker_main(
    conn, spec: str, log_path: str, out_path: str | None = None
) -> None:  # pragma: no cover - runs in a child
    """Entry point of the worker process: build the adapter, then serve calls.

    File descriptor 2 goes to ``log_path``, 1 to ``out_path`` (so that the parent
    can tell an adapter that prints on stdout, against the contract).
    """
    fd = os.open(log_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT)
    out = os.open(out_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT) if out_path else fd
    os.dup2(out, 1)
    os.dup2(fd, 2)
    try:
        adapter = get_adapter(spec)
        variants = adapter.variants()
    except BaseException as exc:
        conn.send(("error", _one_line(exc), traceback.format_exc()))
        return
    conn.send(("ready", [v.label for v in variants]))
    while True:
        try:
            msg = conn.recv()
        except EOFError:
            break
        if msg is None:
            break
        index, method, args = msg
        t0 = time.perf_counter()
        try:
            # index None: the adapter itself (``hcv dt-crit --adapter`` runs the spec's adapter)
            value = getattr(adapter if index is None else variants[index], method)(*args)
            conn.send(("ok", value, time.perf_counter() - t0))
        except BaseException as exc:
            stderr = getattr(exc, "stderr", "") or ""
            conn.send(
                (
                    "error",
                    _one_line(exc),
                    stderr + "\n" + traceback.format_exc(),
                    time.perf_counter() - t0,
                    str(getattr(exc, "declined", "") or ""),
                )
            )
    for v in variants:
        try:
            v.close()
        except Exception:
            pass


class WorkerExecutor:
    """Serves adapter calls from a worker process, restarted after a crash or a timeout.

    Parameters
    ----------
    spec : str
        Adapter spec (rebuilt in the worker with `get_adapter`).
    startup_timeout : float
        Seconds allowed for the worker to import and build the adapter.
    """

    def __init__(self, spec: str, startup_timeout: float = 300.0):
        self.spec = spec
        self.startup_timeout = startup_timeout
        self.adapter = get_adapter(spec)  # parent-side copy: labels, supports()
        self.variants = self.adapter.variants()
        self._ctx = multiprocessing.get_context("spawn")
        self._proc = None
        self._conn = None
        fd, self._log = tempfile.mkstemp(prefix="hcv-worker-", suffix=".log")
        os.close(fd)
        fd, self._out = tempfile.mkstemp(prefix="hcv-worker-", suffix=".stdout")
        os.close(fd)
        self.stdout_warned = False

    def _log_size(self) -> int:
        try:
            return os.path.getsize(self._log)
        except OSError:
            return 0

    def _check_stdout(self) -> None:
        """Warn once (stderr) when the adapter wrote to its stdout, naming the adapter."""
        if self.stdout_warned:
            return
        try:
            size = os.path.getsize(self._out)
            with open(self._out, "rb") as fh:
                head = fh.read(80).decode(errors="replace").strip().splitlines()
        except OSError:
            return
        if size:
            self.stdout_warned = True
            first = head[0] if head else ""
            print(
                f"hcv: warning: adapter {self.spec!r} printed {size} bytes on stdout (starting "
                f"{first!r}); the contract asks for stderr: stdout is discarded",
                file=sys.stderr,
            )

    def _log_since(self, offset: int) -> str:
        try:
            with open(self._log, "rb") as fh:
                fh.seek(offset)
                return _tail(fh.read().decode(errors="replace"))
        except OSError:
            return ""

    def _start(self) -> Outcome | None:
        """Start the worker; an Outcome describing the failure, or None when ready."""
        offset = self._log_size()
        parent, child = self._ctx.Pipe()
        proc = self._ctx.Process(
            target=_worker_main,
            args=(child, self.spec, self._log, self._out),
            daemon=True,
            name=f"hcv-adapter-{self.adapter.name}",
        )
        proc.start()
        child.close()
        self._proc, self._conn = proc, parent
        if not parent.poll(self.startup_timeout):
            self._kill()
            return Outcome(
                False,
                error=f"adapter worker did not start within {self.startup_timeout:g} s",
                stderr=self._log_since(offset),
            )
        try:
            msg = parent.recv()
        except (EOFError, OSError):
            return self._died(offset)
        if msg[0] != "ready":
            self._kill()
            return Outcome(
                False,
                error=f"adapter worker could not build {self.spec!r}: {msg[1]}",
                stderr=_tail(msg[2]),
            )
        if msg[1] != [v.label for v in self.variants]:
            self._kill()
            return Outcome(False, error="adapter worker built different variants than the parent")
        return None

    def _output_size(self) -> int:
        total = 0
        for path in (self._log, self._out):
            try:
                total += os.path.getsize(path)
            except OSError:
                pass
        return total

    def _wait(self, timeout: float | None) -> str:
        """Wait for the answer: "ready", "timeout", or "output" (the worker's output overflowed)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            step = _POLL if deadline is None else min(_POLL, deadline - time.monotonic())
            if step > 0 and self._conn.poll(step):
                return "ready"
            if self._output_size() > _MAX_OUTPUT:
                return "output"
            if deadline is not None and time.monotonic() >= deadline:
                return "timeout"

    def _died(self, offset: int) -> Outcome:
        proc = self._proc
        proc.join(timeout=5)
        code = proc.exitcode
        self._proc = self._conn = None
        if code is not None and code < 0:
            try:
                name = signal.Signals(-code).name
            except ValueError:
                name = "unknown signal"
            how = f"crashed (killed by signal {-code}, {name})"
        else:
            how = f"crashed (worker exited with status {code})"
        return Outcome(False, error=how, stderr=self._log_since(offset))

    def _kill(self) -> None:
        if self._proc is not None:
            self._proc.kill()
            self._proc.join(timeout=10)
        if self._conn is not None:
            self._conn.close()
        self._proc = self._conn = None

    def call(self, index: int | None, method: str, *args, timeout: float | None = None) -> Outcome:
        for path in (self._log, self._out):  # output is bounded per call (the worker appends)
            try:
                os.truncate(path, 0)
            except OSError:
                pass
        try:
            return self._call(index, method, *args, timeout=timeout)
        finally:
            self._check_stdout()

    def _call(self, index: int | None, method: str, *args, timeout: float | None = None) -> Outcome:
        if self._proc is None or not self._proc.is_alive():
            failed = self._start()
            if failed is not None:
                return failed
        offset = self._log_size()
        t0 = time.perf_counter()
        try:
            self._conn.send((index, method, args))
        except (OSError, ValueError, EOFError):
            return self._died(offset)
        except Exception as exc:  # the arguments cannot be pickled
            return Outcome(False, error=f"cannot send the call to the worker: {_one_line(exc)}")
        waited = self._wait(timeout)
        if waited == "output":
            self._kill()
            return Outcome(
                False,
                error=f"the adapter wrote more than {_MAX_OUTPUT} bytes of output; stopped",
                seconds=time.perf_counter() - t0,
                stderr=self._log_since(max(offset, self._log_size() - _STDERR_TAIL)),
            )
        if waited == "timeout":
            self._kill()
            return Outcome(
                False,
                error=f"timeout after {timeout:g} s",
                seconds=timeout or 0.0,
                stderr=self._log_since(offset),
                timed_out=True,
            )
        try:
            msg = self._conn.recv()
        except (EOFError, OSError):
            return self._died(offset)
        except Exception as exc:  # the result cannot be unpickled
            return Outcome(
                False, error=f"malformed output: {_one_line(exc)}", stderr=self._log_since(offset)
            )
        if msg[0] == "ok":
            return Outcome(True, msg[1], seconds=msg[2])
        stderr = (msg[2] or "") + "\n" + self._log_since(offset)
        return Outcome(
            False,
            error=msg[1],
            stderr=_tail(stderr),
            seconds=msg[3] if len(msg) > 3 else time.perf_counter() - t0,
            declined=msg[4] if len(msg) > 4 else "",
        )

    def close(self) -> None:
        if self._conn is not None:
            try:
                self._conn.send(None)
                self._proc.join(timeout=10)
            except (OSError, ValueError):
                pass
        self._kill()
        for path in (self._log, self._out):
            try:
                os.unlink(path)
            except OSError:
                pass


def make_executor(spec, startup_timeout: float = 300.0, isolate: bool | None = None):
    """The executor for an adapter spec: a worker when the adapter asks for isolation.

    An adapter *instance* always runs in-process (it cannot be rebuilt in a worker).
    """
    if isinstance(spec, ContactAdapter):
        return InProcessExecutor(spec)
    if not isinstance(spec, str):
        raise HCVInputError(f"adapter must be a spec string or a ContactAdapter, got {spec!r}")
    adapter = get_adapter(spec)
    want = adapter.isolate if isolate is None else isolate
    if not want:
        return InProcessExecutor(adapter)
    adapter.close()
    return WorkerExecutor(spec, startup_timeout)
