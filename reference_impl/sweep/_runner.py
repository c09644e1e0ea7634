"""Run independent cases on a Dask cluster (local processes, or any scheduler named).

`open_client` starts a `distributed.LocalCluster` of single-threaded worker
processes (stopped on exit, also on Ctrl-C) or connects to an existing
scheduler. `iter_outcomes` keeps a bounded window of cases in flight and yields
each case's `Outcome` as it finishes, so the caller can store it at once. A case
that raises becomes an `Outcome` with its one-line error (the exception is
caught inside the worker); a case whose worker dies repeatedly becomes one with
the scheduler's verdict (KilledWorker). `run_cases` is the simple entry point
(a list of items, a function, the values in order) that other modules, e.g. the
report's critical-step map, use; without Dask installed it runs the cases
serially in this process.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from reference_impl.errors import HCVInputError

__all__ = [
    "CaseFailed",
    "Outcome",
    "check_scheduler_address",
    "dask_available",
    "iter_outcomes",
    "open_client",
    "probe_scheduler",
    "run_cases",
]

# Cases in flight per worker thread: enough to keep every worker busy while the
# client stores results, small enough that Ctrl-C or a kill loses little.
_WINDOW_PER_THREAD = 4
# Local cluster settings: non-daemonic workers (a case may start processes, e.g.
# an isolated bench adapter); one queued case per worker thread, so a worker
# that dies takes down only the case it was running, not an innocent neighbour.
_LOCAL_CONFIG = {"distributed.worker.daemon": False, "distributed.scheduler.worker-saturation": 1.0}
# Seconds to wait for an existing scheduler to answer (connection and handshake: a
# scheduler answers its identity in milliseconds; a slow network gets 1000 times that).
_CONNECT_TIMEOUT = 10
# Transports whose addresses are host:port (distributed.comm); a port is 1..65535.
_HOST_PORT_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
# Loggers that report normal cluster shutdown as warnings.
_QUIET_LOGGERS = (
    "distributed",
    "distributed.nanny",
    "distributed.worker",
    "distributed.scheduler",
    "distributed.core",
    "distributed.comm",
    "distributed.client",
    "distributed.batched",
    "tornado",
)


class CaseFailed(HCVInputError):
    """A case of `run_cases(..., errors="raise")` failed; the message names it."""


@dataclass
class Outcome:
    """How one case ended.

    Attributes
    ----------
    index : int
        Position of the case in the submitted list.
    key : str
        The case's task key (a hash of its parameters).
    ok : bool
        The case returned a value.
    value : Any
        What the case function returned (None when it failed).
    error : str
        One line when it failed: the exception, a timeout, a dead worker.
    seconds : float
        Wall time of the case inside its worker (s); 0 when unknown.
    worker : str
        Address of the worker that ran it ("" when unknown).
    cpu_seconds : float
        CPU time of the case's thread (s); below ``seconds`` when the core was shared.
    """

    index: int
    key: str
    ok: bool
    value: Any = None
    error: str = ""
    seconds: float = 0.0
    worker: str = ""
    cpu_seconds: float = 0.0


def dask_available() -> bool:
    """True when dask.distributed can be imported (the ``sweep`` extra)."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


def _call(fn: Callable, item: Any) -> tuple[bool, Any, str, float, str, float]:
    """Run one case in a worker: (ok, value, error, seconds, worker address, CPU seconds)."""
    try:
        from distributed import get_worker

        where = get_worker().address
    except (ImportError, ValueError):
        where = ""
    t, c = time.perf_counter(), time.thread_time()
    try:
        ok, value, error = True, fn(item), ""
    except Exception as exc:  # a failing case is a result, not a lost sweep
        ok, value, error = False, None, _one_line(exc)
    return ok, value, error, time.perf_counter() - t, where, time.thread_time() - c


@contextlib.contextmanager
def _quiet():
    """Silence distributed's shutdown chatter (closed comms, cancelled tasks)."""
    levels = {}
    for name in _QUIET_LOGGERS:
        lg = logging.getLogger(name)
        levels[name] = lg.level
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


def check_scheduler_address(address) -> str:
    """The address of ``--scheduler`` checked for form (one-line `HCVInputError`); no I/O.

    An empty address is refused rather than read as "no scheduler" (local cluster).
    """
    if not isinstance(address, str) or not address.strip():
        raise HCVInputError(
            f"--scheduler {address!r}: give the scheduler's address, e.g. tcp://host:8786, "
            "or leave --scheduler out for a local cluster"
        )
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, loc = parse_address(address.strip(), strict=False)
        if scheme in _HOST_PORT_SCHEMES:
            _, port = parse_host_port(loc)
            if not 0 < int(port) < 65536:
                raise ValueError(f"port {port} is not in 1..65535")
    except (ValueError, TypeError) as exc:
        raise HCVInputError(
            f"--scheduler {address!r} is not a Dask scheduler address such as "
            f"tcp://host:8786 ({exc})"
        ) from None
    return address.strip()


def probe_scheduler(address: str, timeout: float | None = None) -> None:
    """Ask ``address`` for its identity within ``timeout`` s; `HCVInputError` unless a scheduler.

    ``timeout`` defaults to `_CONNECT_TIMEOUT`.

    ``distributed.Client(address, timeout=...)`` bounds the TCP connection but not the
    handshake after it, so a server that accepts and never answers (a dashboard port,
    any other service) would hang it forever; this bounds both.
    """
    import asyncio

    from distributed.core import rpc

    timeout = _CONNECT_TIMEOUT if timeout is None else timeout

    async def identity():
        r = rpc(address, timeout=timeout)
        try:
            return await r.identity()
        finally:
            await r.close_rpc()

    async def bounded():
        return await asyncio.wait_for(identity(), timeout)

    with _quiet():
        try:
            info = asyncio.run(bounded())
        except TimeoutError:
            raise HCVInputError(
                f"--scheduler {address}: no Dask scheduler answered within {timeout:g} s "
                "(is this the scheduler's port, e.g. 8786, and not its dashboard?)"
            ) from None
        except OSError as exc:  # refused, reset, unreachable
            raise HCVInputError(
                f"cannot connect to the Dask scheduler {address!r}: {_one_line(exc)}"
            ) from None
        except Exception as exc:  # garbage on the wire: some other service listens there
            raise HCVInputError(
                f"--scheduler {address}: the server there does not answer as a Dask "
                f"scheduler ({_one_line(exc)[:120]})"
            ) from None
    if not isinstance(info, dict) or info.get("type") != "Scheduler":
        kind = info.get("type") if isinstance(info, dict) else type(info).__name__
        raise HCVInputError(
            f"--scheduler {address}: the server there is not a Dask scheduler "
            f"(it says it is {kind!r})"
        )


@contextlib.contextmanager
def open_client(workers: int | None = None, scheduler: str | None = None):
    """A `distributed.Client`: a new local cluster, or the scheduler at ``scheduler``.

    Parameters
    ----------
    workers : int, optional
        Worker processes of the local cluster (one thread each); default the CPU count.
        Ignored with ``scheduler``.
    scheduler : str, optional
        Address of an existing scheduler, e.g. ``tcp://host:8786``.

    The local cluster's workers are non-daemonic, so a case may start processes
    of its own (isolated adapters of ``bench:``), and take one case at a time
    (`_LOCAL_CONFIG`). Cluster and client are closed
    on exit, also on KeyboardInterrupt.
    """
    import dask
    from distributed import Client, LocalCluster

    cluster = client = None
    try:
        if scheduler is not None:
            scheduler = check_scheduler_address(scheduler)
            probe_scheduler(scheduler)
            try:
                client = Client(scheduler, timeout=f"{_CONNECT_TIMEOUT}s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise HCVInputError(
                    f"cannot connect to the Dask scheduler {scheduler!r}: {_one_line(exc)}"
                ) from None
        else:
            n = workers or os.cpu_count() or 1
            with dask.config.set(_LOCAL_CONFIG), _workers_ignore_ctrl_c():
                cluster = LocalCluster(
                    n_workers=n,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    silence_logs=logging.CRITICAL,
                )
            client = Client(cluster)
        yield client
    finally:
        with _quiet():
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()


@contextlib.contextmanager
def _workers_ignore_ctrl_c():
    """Start the local cluster's processes with SIGINT ignored (issue 17).

    Ctrl-C goes to the whole foreground process group: each worker and nanny would
    print its own KeyboardInterrupt traceback (some 30 lines) before the client's one
    line. A signal ignored at exec stays ignored (Python installs its SIGINT handler
    only when it is not), so the spawned processes leave Ctrl-C to this process,
    which closes the cluster and says "interrupted".
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def iter_outcomes(
    client,
    fn: Callable,
    items: Sequence,
    keys: Sequence[str] | None = None,
    window: int | None = None,
) -> Iterator[Outcome]:
    """Run ``fn(item)`` for every item on ``client``; yield each `Outcome` as it finishes.

    Parameters
    ----------
    client : distributed.Client
    fn : callable
        Module-level function (it is pickled by reference to the workers).
    items : sequence
        Picklable arguments, one per case.
    keys : sequence of str, optional
        Task keys (unique; default ``dask.base.tokenize(fn, item)``).
    window : int, optional
        Cases in flight at once; default 4 per worker thread.
    """
    from dask.base import tokenize
    from distributed import as_completed

    keys = (
        list(keys)
        if keys is not None
        else [f"hcv-{getattr(fn, '__name__', 'case')}-{tokenize(fn, it)}" for it in items]
    )
    if window is None:
        window = max(2, _WINDOW_PER_THREAD * max(sum(client.nthreads().values()), 1))
    pending = iter(range(len(items)))
    where: dict[str, int] = {}
    # Results are gathered in the background as they finish (no blocking round trip each).
    ac = as_completed(with_results=True, raise_errors=False)

    def submit() -> None:
        i = next(pending, None)
        if i is not None:
            fut = client.submit(_call, fn, items[i], key=keys[i], pure=False)
            where[fut.key] = i
            ac.add(fut)

    for _ in range(min(window, len(items))):
        submit()
    try:
        for fut, res in ac:
            i = where.pop(fut.key)
            if fut.status == "error":
                exc = res[1] if isinstance(res, tuple) else res
                why = (
                    "its worker died while running it"
                    if type(exc).__name__ == "KilledWorker"
                    else "the cluster could not run it"
                )
                out = Outcome(i, keys[i], False, error=f"{why} ({_one_line(exc)})")
            elif fut.status == "cancelled" or isinstance(res, BaseException):
                out = Outcome(i, keys[i], False, error="cancelled by the cluster")
            else:
                out = Outcome(i, keys[i], *res)
            fut.release()
            submit()
            yield out
    finally:
        for fut in list(ac.futures):
            fut.cancel()


def run_cases(
    items: Sequence,
    fn: Callable,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    errors: str = "raise",
) -> list:
    """``[fn(item) for item in items]`` on a Dask cluster; the sweep engine as a function.

    Parameters
    ----------
    items : sequence
        One picklable argument per case.
    fn : callable
        A module-level function of one item (pure: its value depends on the item only).
    workers : int, optional
        Local worker processes (default: the CPU count). 0 runs the cases serially
        in this process, as does a missing Dask without ``scheduler``.
    scheduler : str, optional
        Address of an existing Dask scheduler instead of a local cluster.
    progress : callable, optional
        ``progress(done, total)`` after every finished case.
    errors : {"raise", "return"}
        "raise": the first failing case raises `CaseFailed` (cluster closed);
        "return": the list holds an `Outcome` for every case instead of values.

    Returns
    -------
    list
        The values (or Outcomes) in the order of ``items``.
    """
    if errors not in ("raise", "return"):
        raise HCVInputError(f"errors must be 'raise' or 'return', got {errors!r}")
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 0
    ):
        raise HCVInputError(f"workers must be an integer >= 0, got {workers!r}")
    items = list(items)
    total = len(items)
    results: list = [None] * total

    def take(out: Outcome, done: int) -> None:
        if not out.ok and errors == "raise":
            raise CaseFailed(f"case {out.index} failed: {out.error}")
        results[out.index] = out if errors == "return" else out.value
        if progress is not None:
            progress(done, total)

    if total == 0:
        return results
    if scheduler is None and (workers == 0 or not dask_available()):
        for i, item in enumerate(items):
            take(Outcome(i, "", *_call(fn, item)), i + 1)
        return results
    with open_client(workers, scheduler) as client:
        for done, out in enumerate(iter_outcomes(client, fn, items), start=1):
            take(out, done)
    return results
