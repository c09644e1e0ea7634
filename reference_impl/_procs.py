"""Signals and child processes of an ``hcv`` command run from the command line.

* SIGTERM (what CI sends on cancel or timeout) is handled like Ctrl-C: the first
  one raises `KeyboardInterrupt` in the main thread, so every command cleans up
  exactly as on Ctrl-C (adapters' process groups killed, clusters closed,
  temporary report directories removed); later ones are ignored while that
  cleanup runs. `terminated` tells the CLI to exit with 128 + SIGTERM = 143.
* Children beyond the process group: an adapter that daemonises (double fork,
  ``setsid``) leaves the process group the suite kills. On Linux the command
  makes itself a *child subreaper* (``prctl(PR_SET_CHILD_SUBREAPER)``), so such
  orphans are re-parented to it instead of to init, and `kill_descendants` kills
  whatever is still below it when the command ends. Elsewhere (macOS, or a
  Dask cluster on other machines) this is not available: a daemonising adapter
  can then outlive the run, which the README states.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time

__all__ = [
    "become_subreaper",
    "descendants",
    "kill_descendants",
    "kill_group",
    "raise_if_terminated",
    "sigterm_as_interrupt",
]

# prctl option number from <linux/prctl.h>.
_PR_SET_CHILD_SUBREAPER = 36
# Rounds of "list the descendants, kill them": a killed process's own children are
# re-parented to us (the subreaper) and found in the next round.
_KILL_ROUNDS = 5
# Seconds to wait for a SIGKILLed child to be reaped (SIGKILL cannot be ignored: the wait
# only covers a process stuck in uninterruptible I/O).
_REAP_WAIT = 5.0

_state = {"terminated": None}


def terminated() -> int | None:
    """The signal that ended the command (SIGTERM), or None."""
    return _state["terminated"]


def raise_if_terminated() -> None:
    """Raise KeyboardInterrupt if SIGTERM arrived: call at a long job's stage boundaries.

    The handler's KeyboardInterrupt can be lost: raised while the main thread runs a
    finaliser (``__del__``, a weakref callback, the garbage collector), it is printed as
    "Exception ignored" and the run goes on, and a second SIGTERM is ignored by design.
    The flag stays set, so the next boundary ends the run as the signal asked.
    """
    if _state["terminated"] is not None:
        raise KeyboardInterrupt


def _on_term(signum, frame):
    if _state["terminated"] is not None:
        return  # cleanup of the first one is running: let it finish
    _state["terminated"] = signum
    raise KeyboardInterrupt


@contextlib.contextmanager
def sigterm_as_interrupt():
    """While active (main thread only), SIGTERM raises KeyboardInterrupt once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _state["terminated"] = None
    old = signal.signal(signal.SIGTERM, _on_term)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def become_subreaper() -> bool:
    """Make this process the reaper of its orphaned descendants (Linux); True if done."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _parents() -> dict[int, int]:
    """pid -> parent pid of every process visible in /proc (empty without /proc)."""
    out = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return out
    for name in entries:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as fh:
                stat = fh.read()
        except OSError:
            continue
        # comm (field 2) is in parentheses and may hold spaces: split after the last ')'.
        fields = stat[stat.rfind(b")") + 2 :].split()
        if len(fields) > 1 and fields[0] != b"Z":  # zombies are dead already
            out[int(name)] = int(fields[1])
    return out


def descendants(pid: int | None = None) -> list[int]:
    """PIDs of the live processes below ``pid`` (default: this process)."""
    root = os.getpid() if pid is None else pid
    children: dict[int, list[int]] = {}
    for p, pp in _parents().items():
        children.setdefault(pp, []).append(p)
    found, stack = [], list(children.get(root, []))
    while stack:
        p = stack.pop()
        found.append(p)
        stack.extend(children.get(p, []))
    return found


def _reap() -> None:
    """Collect the exit status of dead children (orphans re-parented to us included)."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def _own_helpers() -> set[int]:
    """Helper processes of this interpreter that end by themselves at its exit.

    multiprocessing's resource tracker cleans up shared-memory segments and
    semaphores the workers leaked once this process exits; killing it would leak them.
    """
    mp = sys.modules.get("multiprocessing.resource_tracker")
    pid = getattr(getattr(mp, "_resource_tracker", None), "_pid", None)
    return {pid} if isinstance(pid, int) else set()


def kill_descendants() -> int:
    """SIGKILL every process still below this one; returns how many were killed.

    Called when a command ends, after its own cleanup: anything left is an
    adapter (or its daemonised child) that escaped its process-group kill.
    """
    keep = _own_helpers()
    killed = 0
    for _ in range(_KILL_ROUNDS):
        pids = [p for p in descendants() if p not in keep]
        if not pids:
            break
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
                killed += 1
            except (ProcessLookupError, PermissionError):
                pass
        time.sleep(0.05)
        _reap()
    _reap()
    return killed


def kill_group(proc: subprocess.Popen) -> None:
    """SIGKILL a child started with ``start_new_session=True`` and its whole process group
    (everything it started that did not leave the group), then reap it.

    The adapters' one-shot and persistent programs both end this way on a timeout, an
    overflow, a protocol error or Ctrl-C. A child already reaped (its group gone) or one
    whose group cannot be signalled is killed by its own pid.
    """
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()
    try:
        proc.wait(timeout=_REAP_WAIT)
    except subprocess.TimeoutExpired:  # pragma: no cover - SIGKILL is not ignorable
        pass
