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
from reference_impl.errors import one_line as _one_line

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

# Tasks in flight per worker thread: enough to keep every worker busy while the
# client stores results, small enough that Ctrl-C or a kill loses little.
_WINDOW_PER_THREAD = 4
# Local cluster settings: non-daemonic workers (a case may start processes, e.g.
# an isolated bench adapter); one queued case per worker thread, so a worker
# that dies takes down only the case it was running, not an innocent neighbour.
_LOCAL_CONFIG = {"distributed.worker.daemon": False, "distributed.scheduler.worker-saturation": 1.0}
# One compute thread per local worker process: numba's parallel loops and the BLAS would
# otherwise each start a thread per core in every worker, N workers x N threads on N
# cores (issue 27: each case took twice as long with 16 workers on 16 cores). The BLAS
# ones go in Dask's pre-spawn environment (read when a library loads; Dask sets them by
# default, repeated here so that a user's Dask config cannot lose them). NUMBA_NUM_THREADS
# goes in the nanny's `env`, set inside the worker process before it imports anything of
# ours: the pre-spawn environment is written into the *client's* os.environ too
# (distributed.nanny: os.environ.update(pre_spawn_env)), and numba re-reads its config on
# every compilation, so the client's own parallel kernels, once launched with 1 thread,
# then failed with "Cannot set NUMBA_NUM_THREADS to a different value" (found by the suite).
_ONE_BLAS_THREAD = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}
_ONE_NUMBA_THREAD = {"NUMBA_NUM_THREADS": "1"}
# Cases per Dask task: about this many tasks per worker thread, so that the last tasks
# leave the workers unevenly loaded by at most 1/8 of a worker's share; each task costs
# the scheduler and client ~5 ms (README, measured), so grouping divides that per case.
_TASKS_PER_THREAD = 8
# At most this many cases per task: what a killed sweep or a dead worker's retry re-runs.
_MAX_CHUNK = 16
# Where the local scheduler's HTTP server listens. Distributed starts one even without a
# dashboard, on port 8787 unless told otherwise, and warns "Port 8787 is already in use"
# (three lines) when another cluster or service holds it (issue 26). A port the system
# picks (0) on the loopback interface: nothing to warn about, nothing exposed.
_LOCAL_HTTP_ADDRESS = "127.0.0.1:0"
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


def _call_many(fn: Callable, items: Sequence) -> list:
    """`_call` for each item of a group of cases run as one task."""
    return [_call(fn, item) for item in items]


def _chunk_size(n_items: int, threads: int) -> int:
    """Cases per task: `_TASKS_PER_THREAD` tasks per worker thread, 1 to `_MAX_CHUNK`."""
    return max(1, min(_MAX_CHUNK, -(-n_items // (_TASKS_PER_THREAD * max(threads, 1)))))


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
    of its own (isolated adapters of ``bench:``), take one task at a time
    (`_LOCAL_CONFIG`) and run one compute thread each (`_ONE_NUMBA_THREAD`, `_ONE_BLAS_THREAD`: numba and
    BLAS threads). Cluster and client are closed
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
            environ = {
                **(dask.config.get("distributed.nanny.pre-spawn-environ", None) or {}),
                **_ONE_BLAS_THREAD,
            }
            config = {**_LOCAL_CONFIG, "distributed.nanny.pre-spawn-environ": environ}
            with dask.config.set(config), _workers_ignore_ctrl_c():
                cluster = LocalCluster(
                    n_workers=n,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    scheduler_kwargs={"dashboard_address": _LOCAL_HTTP_ADDRESS},
                    silence_logs=logging.CRITICAL,
                    env=_ONE_NUMBA_THREAD,
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
    chunk: int | None = None,
) -> Iterator[Outcome]:
    """Run ``fn(item)`` for every item on ``client``; yield each `Outcome` as it finishes.

    Consecutive cases are grouped into tasks of ``chunk`` cases (one scheduler round trip
    for the group); a group whose worker died is run again one case per task, so only
    the case that kills its worker fails (a KilledWorker row), never its neighbours.

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
        Tasks in flight at once; default 4 per worker thread.
    chunk : int, optional
        Cases per task; default `_chunk_size` (about 8 tasks per worker thread, at most
        `_MAX_CHUNK` cases each; 1 for small sweeps).
    """
    from dask.base import tokenize
    from distributed import as_completed

    keys = (
        list(keys)
        if keys is not None
        else [f"hcv-{getattr(fn, '__name__', 'case')}-{tokenize(fn, it)}" for it in items]
    )
    threads = max(sum(client.nthreads().values()), 1)
    if window is None:
        window = max(2, _WINDOW_PER_THREAD * threads)
    size = _chunk_size(len(items), threads) if chunk is None else max(1, int(chunk))
    groups = [list(range(i, min(i + size, len(items)))) for i in range(0, len(items), size)]
    pending = iter(groups)
    retry: list[list[int]] = []  # groups of a dead worker, to run again one case each
    where: dict[str, list[int]] = {}
    # Results are gathered in the background as they finish (no blocking round trip each).
    ac = as_completed(with_results=True, raise_errors=False)

    def submit() -> None:
        group = retry.pop() if retry else next(pending, None)
        if group is None:
            return
        if len(group) == 1:
            i = group[0]
            fut = client.submit(_call, fn, items[i], key=keys[i], pure=False)
        else:
            key = f"{keys[group[0]]}-group-{len(group)}"
            fut = client.submit(_call_many, fn, [items[i] for i in group], key=key, pure=False)
        where[fut.key] = group
        ac.add(fut)

    for _ in range(min(window, len(groups))):
        submit()
    try:
        for fut, res in ac:
            group = where.pop(fut.key)
            outs: list[Outcome] = []
            if fut.status == "error":
                exc = res[1] if isinstance(res, tuple) else res
                died = type(exc).__name__ == "KilledWorker"
                if died and len(group) > 1:
                    retry.extend([i] for i in reversed(group))
                else:
                    why = (
                        "its worker died while running it"
                        if died
                        else "the cluster could not run it"
                    )
                    outs = [
                        Outcome(i, keys[i], False, error=f"{why} ({_one_line(exc)})") for i in group
                    ]
            elif fut.status == "cancelled" or isinstance(res, BaseException):
                outs = [Outcome(i, keys[i], False, error="cancelled by the cluster") for i in group]
            else:
                values = [res] if len(group) == 1 else res
                outs = [Outcome(i, keys[i], *v) for i, v in zip(group, values, strict=True)]
            fut.release()
            submit()
            while retry and len(ac.futures) < window:
                submit()
            yield from outs
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
