"""Persistent mode of the adapter protocol: one process serves many requests (issue 28).

A code that starts slowly (YADE: about 3 s per process) is started once and
kept: the suite writes one request per line on its stdin and reads one answer
per line on its stdout (JSON lines). `PersistentProcess` is that channel, used
by ``cmd[persistent=true]:COMMAND`` (`reference_impl.adapters.subprocess`) and by
Python adapters that drive such a code (`reference_impl.adapters.yade`).

The rules (also in ``docs/adapter-protocol.md``, "Persistent mode"):

* Each request is one line: a JSON object with an integer ``"id"``. The answer
  is one line: a JSON object with the same ``"id"``, a JSON integer (``true`` or
  ``1.0`` is not one). Requests are sent one at a time: the next is written after
  the answer to the previous one. Each id is drawn at random (`new_id`), not
  counted, so an answer cannot be written before its request has been read.
* An answer waiting before its request is sent is refused: before each request,
  what the process wrote since the last answer is read; a line starting with
  ``{`` (an answer written ahead, or twice) fails that request and the process
  is replaced; other waiting lines (a late banner, a log line) are discarded.
* Lines on stdout that do not start with ``{`` are ignored (a launcher's banner,
  e.g. YADE's "Welcome to Yade"), at most `_MAX_NOISE` bytes of them per request.
* Bounded: a request not answered within its timeout kills the process (and
  everything it started: its own session) and fails with one line; a process
  that has died (between requests or while answering) fails that one request
  with its exit status; an answer with another id, an answer that is not JSON or
  one over the size limit fails the request and the process is replaced. In
  every case the next request starts a fresh process: the rest go on.
* stderr is read while the process runs (a pipe, never a file) and only its last
  ``2 * _STDERR_TAIL`` characters are kept, as in one-shot mode: a program that
  logs without end holds neither memory nor disk; a failure quotes the tail.
* stdin closing is the signal to exit (``close``): the process gets
  `_EXIT_GRACE` s to do so, then it is killed. On Linux, when the suite's
  process has one thread, the server is also killed if that process dies
  (``PR_SET_PDEATHSIG``), so no server outlives a killed benchmark even while
  it computes; otherwise the EOF on its stdin is what ends it.
"""

from __future__ import annotations

import ctypes
import json
import os
import random
import selectors
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence

from reference_impl._procs import kill_group
from reference_impl.adapters._records import AdapterOutputError, AdapterRunError

__all__ = ["PersistentProcess", "PersistentTimeout"]

# Bytes of non-JSON stdout (banners) skipped per request before the answer.
_MAX_NOISE = 1 << 20
# Characters of the process's stderr attached to a failure (the tail); twice as many
# bytes are kept while it runs (a UTF-8 character cut at the front is then replaced).
_STDERR_TAIL = 4000
# Seconds the process gets to exit after its stdin is closed.
_EXIT_GRACE = 5.0
# Seconds the selector waits before it rechecks the deadline.
_POLL = 0.5
_CHUNK = 1 << 16
_PR_SET_PDEATHSIG = 1
# Request ids are drawn from [1, _ID_BOUND): positive, and within a C int of 32 bits, so
# that a program in any language can read and echo them.
_ID_BOUND = 2**31
_IDS = random.SystemRandom()


class PersistentTimeout(AdapterRunError):
    """A request outlived its timeout; the process was killed."""

    timed_out = True


def _die_with_parent() -> None:  # pragma: no cover - runs in the child before exec
    """Linux: SIGKILL this child when the process that started it dies."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        pass


class PersistentProcess:
    """A long-lived program answering JSON-line requests (see the module docstring).

    Parameters
    ----------
    argv : sequence of str
        The command.
    label : str
        Name used in error messages.
    cwd : str, optional
        Working directory.
    startup_timeout : float
        Seconds added to the first request's timeout after a (re)start: the
        program's own start-up (YADE: ~3 s), not the code under test.
    """

    def __init__(
        self,
        argv: Sequence[str],
        label: str,
        cwd: str | None = None,
        startup_timeout: float = 60.0,
    ):
        self.argv = list(argv)
        self.label = label
        self.cwd = cwd
        self.startup_timeout = float(startup_timeout)
        self._proc: subprocess.Popen | None = None
        self._err = bytearray()  # the last 2 * _STDERR_TAIL bytes of the process's stderr
        self._buf = bytearray()
        self._last_id = 0
        self.starts = 0  # processes started so far (for tests and reports)

    # -- process lifetime -------------------------------------------------------
    @property
    def alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def _start(self) -> None:
        self._err = bytearray()
        try:
            self._proc = subprocess.Popen(
                self.argv,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                cwd=self.cwd,
                start_new_session=True,
                # a preexec_fn in a threaded process may deadlock the child (dlopen locks):
                # only when this is the only thread; else stdin's EOF still ends the server
                preexec_fn=(
                    _die_with_parent
                    if sys.platform.startswith("linux") and threading.active_count() == 1
                    else None
                ),
            )
        except OSError as exc:
            raise AdapterRunError(
                f"{self.label}: cannot start {self.argv[0]!r} ({exc.strerror})"
            ) from None
        os.set_blocking(self._proc.stderr.fileno(), False)
        self._buf = bytearray()
        self.starts += 1

    def _read_err(self) -> bool:
        """Move what waits on the stderr pipe into the kept tail (never blocks); False at
        its end (the program closed it: a selector must stop watching it)."""
        proc = self._proc
        if proc is None or proc.stderr is None or proc.stderr.closed:
            return False
        while True:
            try:
                data = os.read(proc.stderr.fileno(), _CHUNK)
            except (BlockingIOError, InterruptedError):
                return True
            except OSError:
                return False
            if not data:
                return False
            self._err += data
            del self._err[: -2 * _STDERR_TAIL]

    def _stderr_tail(self) -> str:
        self._read_err()
        text = self._err.decode(errors="replace").strip()
        return text if len(text) <= _STDERR_TAIL else "..." + text[-_STDERR_TAIL:]

    def _kill(self) -> str:
        """Kill the process group and reap it; returns the stderr tail."""
        proc, tail = self._proc, self._stderr_tail()
        self._proc = None
        if proc is not None:
            kill_group(proc)
            for f in (proc.stdin, proc.stdout, proc.stderr):
                try:
                    f.close()
                except OSError:
                    pass
        self._err = bytearray()
        return tail

    def _died(self, when: str) -> AdapterRunError:
        proc, rc = self._proc, None
        if proc is not None:
            try:
                rc = proc.wait(timeout=5)
            except subprocess.TimeoutExpired:  # stdout closed, process still running
                pass
        tail = self._kill()
        how = (
            f"killed by signal {-rc} ({_signame(-rc)})"
            if rc is not None and rc < 0
            else f"exit status {rc}"
        )
        return AdapterRunError(
            f"{self.label}: the persistent process ended {when} ({how}); it is restarted "
            "for the next request",
            tail,
        )

    def close(self) -> None:
        """Close stdin (the signal to exit), wait `_EXIT_GRACE` s, then kill.

        stderr is read meanwhile: a program blocked on a full stderr pipe could not exit.
        """
        proc = self._proc
        if proc is None:
            return
        try:
            proc.stdin.close()
        except OSError:
            pass
        deadline = time.monotonic() + _EXIT_GRACE
        with selectors.DefaultSelector() as sel:
            sel.register(proc.stderr, selectors.EVENT_READ)
            while proc.poll() is None and time.monotonic() < deadline:
                if sel.get_map() and sel.select(min(_POLL, deadline - time.monotonic())):
                    if not self._read_err():
                        sel.unregister(proc.stderr)
                elif not sel.get_map():
                    time.sleep(min(0.05, max(deadline - time.monotonic(), 0.0)))
        self._kill()

    # -- one request ------------------------------------------------------------
    def request(self, obj: dict, timeout: float, limit: int, check=None) -> dict:
        """Send ``obj`` (an ``"id"`` is added) and return the answer object. ``check(raw)``,
        when given, may refuse the answer line's bytes before they are parsed (raising
        `AdapterOutputError`; the process is then replaced, as for an answer over ``limit``).

        Raises
        ------
        PersistentTimeout
            No answer within ``timeout`` s (plus `startup_timeout` after a start).
        AdapterRunError
            The process could not start or ended before answering.
        AdapterOutputError
            The answer is not one JSON object with the request's id, or is over
            ``limit`` bytes.
        """
        rid = self.new_id()
        line = (json.dumps({**obj, "id": rid}) + "\n").encode()
        raw = self.exchange(
            line, lambda ln: ln.startswith(b"{"), timeout, limit, keep=False, rid=rid
        )[-1]
        if check is not None:
            try:
                check(raw)
            except AdapterOutputError:
                self._kill()
                raise
        try:
            data = json.loads(raw)
        except (json.JSONDecodeError, RecursionError, UnicodeDecodeError):
            self._kill()
            raise AdapterOutputError(
                f"{self.label}: answer line is not JSON (starts with {raw[:60]!r})"
            ) from None
        if not isinstance(data, dict) or type(data.get("id")) is not int or data["id"] != rid:
            got = data.get("id") if isinstance(data, dict) else type(data).__name__
            why = (
                f" (a {type(got).__name__}: 'id' must be the request's integer)"
                if got is not None and type(got) is not int and isinstance(data, dict)
                else ""
            )
            self._kill()
            raise AdapterOutputError(
                f"{self.label}: answer to request {rid} carries id {got!r}{why}; the process "
                "is replaced"
            )
        return data

    def new_id(self) -> int:
        """A request id drawn at random, never the previous one (see the module docstring)."""
        rid = self._last_id
        while rid == self._last_id:
            rid = _IDS.randrange(1, _ID_BOUND)
        self._last_id = rid
        return rid

    def exchange(
        self,
        payload: bytes,
        is_end,
        timeout: float,
        limit: int,
        keep: bool = True,
        rid: int | None = None,
    ) -> list[bytes]:
        """The raw form of `request`: write ``payload``, read stdout lines up to the first
        for which ``is_end(line)`` holds (a code that reads a script on stdin and prints an
        end marker, e.g. LIGGGHTS). Returns the lines read, the end line last (with
        ``keep=False`` only the end line; the others are skipped, `_MAX_NOISE` bytes at
        most). Bounded like `request`; when the process dies, the message quotes its last
        line of output that names an error, else its last line (a code's own message).
        Output waiting before ``payload`` is sent is read first: a line starting with ``{``
        there fails the call (an answer written before its request; ``rid`` names the
        request in the message), other lines are discarded."""
        budget = float(timeout)
        if not self.alive:
            if self._proc is not None:  # died since the last answer: say so, then restart
                raise self._died("between requests")
            self._start()
            budget += self.startup_timeout
        else:
            self._refuse_waiting(rid)
        deadline = time.monotonic() + budget
        try:
            self._write(payload, deadline, budget)
            return self._read_until(is_end, deadline, budget, limit, keep)
        except (AdapterRunError, AdapterOutputError):
            raise  # the process was already replaced where it had to be
        except BaseException:
            self._kill()  # Ctrl-C or any surprise: no process left mid-request
            raise

    def _refuse_waiting(self, rid: int | None) -> None:
        """Read what waits on stdout before a request is sent (never blocks): fail on a line
        starting with ``{``, discard the rest (`_MAX_NOISE` bytes at most)."""
        proc = self._proc
        with selectors.DefaultSelector() as sel:
            sel.register(proc.stdout, selectors.EVENT_READ)
            while len(self._buf) <= _MAX_NOISE and sel.select(0):
                data = os.read(proc.stdout.fileno(), _CHUNK)
                if not data:
                    break  # the process is ending: writing the request will say so
                self._buf += data
        waiting, self._buf = bytes(self._buf), bytearray()
        ahead = next((ln for ln in waiting.split(b"\n") if ln.lstrip().startswith(b"{")), None)
        if ahead is None and len(waiting) <= _MAX_NOISE:
            return
        self._kill()
        if ahead is None:
            raise AdapterOutputError(
                f"{self.label}: more than {_MAX_NOISE} bytes on stdout between requests; "
                "the process is replaced"
            )
        which = f"request {rid}" if rid is not None else "the next request"
        raise AdapterOutputError(
            f"{self.label}: stdout held a line starting with {ahead.lstrip()[:40]!r} before "
            f"{which} was sent (an answer must follow its request, once); the process is "
            "replaced"
        )

    def _write(self, line: bytes, deadline: float, budget: float) -> None:
        proc = self._proc
        os.set_blocking(proc.stdin.fileno(), False)
        sent = 0
        with selectors.DefaultSelector() as sel:
            sel.register(proc.stdin, selectors.EVENT_WRITE)
            sel.register(proc.stderr, selectors.EVENT_READ)
            while sent < len(line):
                left = deadline - time.monotonic()
                if left <= 0:
                    tail = self._kill()
                    raise PersistentTimeout(f"{self.label}: timeout after {budget:g} s", tail)
                ready = {key.fileobj for key, _ in sel.select(min(left, _POLL))}
                if proc.stderr in ready and not self._read_err():
                    sel.unregister(proc.stderr)
                if proc.stdin not in ready:
                    continue
                try:
                    sent += os.write(proc.stdin.fileno(), line[sent : sent + _CHUNK])
                except BlockingIOError:
                    continue
                except BrokenPipeError:
                    raise self._died("before reading the request") from None

    def _read_until(self, is_end, deadline: float, budget: float, limit: int, keep: bool):
        proc = self._proc
        lines: list[bytes] = []
        size = 0
        last = b""
        with selectors.DefaultSelector() as sel:
            sel.register(proc.stdout, selectors.EVENT_READ)
            sel.register(proc.stderr, selectors.EVENT_READ)
            while True:
                nl = self._buf.find(b"\n")
                while nl >= 0:
                    line = bytes(self._buf[:nl]).strip()
                    del self._buf[: nl + 1]
                    if is_end(line):
                        lines.append(line)
                        return lines
                    size += len(line) + 1
                    if line and (b"error" in line.lower() or b"error" not in last.lower()):
                        last = line  # the last line naming an error, else the last line
                    if keep:
                        lines.append(line)
                    if size > (limit if keep else _MAX_NOISE):
                        self._kill()
                        what = "of output" if keep else "on stdout that are not a JSON answer"
                        raise AdapterOutputError(
                            f"{self.label}: more than {limit if keep else _MAX_NOISE} bytes "
                            f"{what}; the process is replaced"
                        )
                    nl = self._buf.find(b"\n")
                if len(self._buf) > limit:
                    self._kill()
                    raise AdapterOutputError(
                        f"{self.label}: answer over {limit} bytes; the process is replaced"
                    )
                left = deadline - time.monotonic()
                if left <= 0:
                    tail = self._kill()
                    raise PersistentTimeout(f"{self.label}: timeout after {budget:g} s", tail)
                ready = {key.fileobj for key, _ in sel.select(min(left, _POLL))}
                if proc.stderr in ready and not self._read_err():
                    sel.unregister(proc.stderr)
                if proc.stdout not in ready:
                    continue
                data = os.read(proc.stdout.fileno(), _CHUNK)
                if not data:
                    err = self._died("before answering")
                    if last:
                        err.args = (
                            f"{err.args[0]}; its last output: {last[:200].decode(errors='replace')!r}",
                        )
                    raise err
                self._buf += data


def _signame(num: int) -> str:
    try:
        return signal.Signals(num).name
    except ValueError:
        return "unknown signal"
