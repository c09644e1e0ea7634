"""``hcv sweep SPEC.toml [--workers N] [--scheduler ADDRESS] [--out DIR] [--resume]``.

Validates the whole spec (every case's scene) before any cluster starts; runs
the valid cases on a local cluster of ``--workers`` processes (default: the CPU
count) or on the Dask scheduler named by ``--scheduler``; stores each finished
case at once (DIR/cases.jsonl) and writes DIR/results.parquet, DIR/spec.toml and
DIR/summary.md (+ summary.png) at the end. Exit status: 0 when every case
succeeded, 1 when some failed (their rows hold the errors) or, for ``bench:``
tasks, when a case's scorecard did not pass (a metric failed), 2 for a bad spec
or bad options (nothing run), 130 on Ctrl-C (cluster closed, results so far
written). A file of DIR that cannot be written (a full disk) is one line naming
it: exit status 2 when no case had run yet (nothing run; what this sweep created
is removed), else 1: the sweep stops, the cases stored so far stay in
cases.jsonl and ``--resume`` runs the rest; when none could be stored, what this
sweep created in DIR is removed (no lock or empty file left).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from pathlib import Path

from reference_impl._userfiles import DirLock, check_path, check_writable_dir
from reference_impl.errors import HCVInputError

__all__ = ["add_parser", "run", "run_sweep"]

EXIT_OK, EXIT_FAIL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
# Plain progress lines (not a terminal): at most one per this many seconds.
_PLAIN_EVERY = 5.0
# The lock file that marks a directory as a sweep's and keeps a second sweep out of it.
LOCK_NAME = ".hcv-sweep.lock"
# What a sweep writes into DIR besides cases.jsonl (never over a user's files of these names).
OUTPUT_NAMES = ("spec.toml", "summary.md", "summary.png", "results.parquet")


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``sweep`` subcommand to an argparse subparsers object."""
    p = subparsers.add_parser(
        "sweep",
        help="run a parameter sweep (dt-crit, solve, bench or calibrate) on a Dask cluster",
        description="Run the Cartesian product of a spec's [sweep] lists over its [scene], "
        "one case per task, on local worker processes or an existing Dask cluster.",
    )
    p.add_argument("spec", help="sweep spec TOML file (task, [scene], [sweep])")
    p.add_argument(
        "--workers", type=int, metavar="N", help="local worker processes (default: the CPU count)"
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="use the existing Dask scheduler at ADDRESS (tcp://host:8786)",
    )
    p.add_argument("--out", metavar="DIR", help="output directory (default: sweep-<spec name>)")
    p.add_argument("--resume", action="store_true", help="skip the cases already stored in DIR")
    p.set_defaults(func=run)
    return p


class _Display:
    """Progress: a rich bar on a terminal, else a plain line every few seconds."""

    def __init__(self, total: int, done: int, failed: int, tty: bool):
        self.total, self.done, self.failed, self.tty = total, done, failed, tty
        self.t0, self.last, self.base = time.monotonic(), 0.0, done
        self.bar = None

    def __enter__(self):
        if self.tty:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeRemainingColumn,
            )

            self.bar = Progress(
                TextColumn("sweep"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("[red]{task.fields[failed]} failed"),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                console=Console(stderr=True),
                transient=True,
            )
            self.bar.__enter__()
            self.task = self.bar.add_task(
                "sweep", total=self.total, completed=self.done, failed=self.failed
            )
        else:
            self._line(force=True)
        return self

    def update(self, ok: bool) -> None:
        self.done += 1
        self.failed += 0 if ok else 1
        if self.bar is not None:
            self.bar.update(self.task, completed=self.done, failed=self.failed)
        else:
            self._line(force=self.done == self.total)

    def _line(self, force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self.last < _PLAIN_EVERY:
            return
        self.last = now
        ran = self.done - self.base
        left = self.total - self.done
        eta = f"{(now - self.t0) / ran * left:.0f} s" if ran else "unknown"
        print(
            f"sweep: {self.done}/{self.total} done, {self.failed} failed, ETA {eta}",
            file=sys.stderr,
            flush=True,
        )

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.__exit__(*exc)
        return False


def _record(
    case, ok: bool, rows, error: str, seconds: float, worker: str, cpu: float = 0.0
) -> dict:
    return {
        "key": case.key,
        "index": case.index,
        "params": case.params,
        "ok": ok,
        "error": error,
        "seconds": seconds,
        "cpu_seconds": cpu,
        "worker": worker,
        "rows": rows or [],
    }


def run_sweep(
    spec,
    out_dir,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    progress: bool | None = None,
    on_start=None,
) -> dict:
    """Run a validated `SweepSpec` into ``out_dir``; the function ``hcv sweep`` calls.

    Returns a dict with ``cases``, ``ok``, ``failed``, ``rows``, ``seconds``,
    ``interrupted`` (True after Ctrl-C; the results so far are written, the
    cluster closed), ``write_error`` (one line naming the file of DIR that could not
    be written once cases had run, e.g. a full disk: the sweep stopped there; "" when
    none) and ``stored`` (records in cases.jsonl). Raises `HCVInputError` for bad
    options, or a file of DIR that cannot be written before any case ran (nothing run).
    ``on_start()`` is called once the options are accepted and the cluster answers
    (before anything is written), e.g. to print notes that a refusal must not precede.
    """
    from reference_impl.sweep._output import CaseStore
    from reference_impl.sweep._runner import check_scheduler_address, dask_available

    if workers is not None and workers < 1:
        raise HCVInputError(f"--workers must be >= 1, got {workers}")
    if scheduler is not None:
        if workers is not None:
            raise HCVInputError(
                "--workers sizes a local cluster; with --scheduler the cluster's "
                "own workers run the sweep (give one or the other)"
            )
    if scheduler is None and spec.task.startswith("bench:"):
        # The local workers build the adapter as this process would: a configuration
        # error (a cmd: program that does not exist) is refused now, not once per case,
        # and before Dask is imported. (On a remote cluster the program lives on the
        # workers: checked there.)
        from reference_impl.adapters.registry import get_adapter

        get_adapter(spec.task[len("bench:") :]).close()
    if not dask_available():
        raise HCVInputError("hcv sweep needs dask.distributed: pip install -e '.[sweep]'")
    if scheduler is not None:
        scheduler = check_scheduler_address(scheduler)
    out = Path(out_dir)
    store = CaseStore(out)
    _check_out(out, store)
    with _claim(out, store, resume) as records:
        return _run_claimed(spec, out, store, records, workers, scheduler, progress, on_start)


def _check_out(out: Path, store) -> None:
    """Refuse an output directory that cannot be written or holds a user's files."""
    check_writable_dir(out, "--out")
    if os.path.lexists(store.path) and not store.path.is_file():
        raise HCVInputError(
            f"--out {out}: {store.path.name} is not a regular file (a sweep stores its cases "
            "there); move it away or choose another directory"
        )
    # A directory without the case store and without the lock file was not written by a
    # sweep: its spec.toml, summary.md or results.parquet belong to someone else.
    if out.is_dir() and not os.path.lexists(store.path) and not (out / LOCK_NAME).exists():
        theirs = [n for n in OUTPUT_NAMES if os.path.lexists(out / n)]
        if theirs:
            raise HCVInputError(
                f"--out {out}: holds {', '.join(theirs)} but no sweep ({store.path.name}); "
                "a sweep would overwrite them: choose another directory"
            )


@contextlib.contextmanager
def _claim(out: Path, store, resume: bool):
    """Create DIR if needed and hold its lock; yield the stored records.

    A second sweep into the same DIR is refused while the first runs (`DirLock`).
    When nothing was written (refused: exit status 2, or interrupted before the
    cluster answered), what this created is removed again (the lock file, DIR).
    """
    made_dir = not out.exists()
    lock_path = out / LOCK_NAME
    made_lock = not lock_path.exists()
    out.mkdir(parents=True, exist_ok=True)
    lock = DirLock(out, LOCK_NAME, "--out")

    def undo() -> None:
        if made_lock and not os.path.lexists(store.path):
            with contextlib.suppress(OSError):
                lock_path.unlink()
        if made_dir:
            with contextlib.suppress(OSError):
                out.rmdir()  # only when empty

    try:
        lock.acquire()
    except HCVInputError:
        undo()
        raise
    except OSError as exc:  # the pid could not be written (a full disk): nothing run
        undo()
        raise HCVInputError(f"--out {out}: {_cannot_write(exc, lock_path)}; nothing run") from None
    except BaseException:
        undo()
        raise
    try:
        if store.exists() and not resume:
            raise HCVInputError(
                f"--out {out}: already holds a sweep (cases.jsonl); add --resume "
                "to continue it or choose another directory"
            )
        yield store.load()
    finally:
        lock.release()
        if not os.path.lexists(store.path) and not os.path.lexists(out / "spec.toml"):
            undo()  # refused or interrupted before anything was written


def _cannot_write(exc: OSError, path=None) -> str:
    """One line naming the file a write failed on (``path`` when the error names none)."""
    name = exc.filename if exc.filename else path
    return f"cannot write {name} ({exc.strerror or exc})"


def _forget(out: Path, store, fresh_spec: bool, fresh_store: bool) -> None:
    """After a write failure that stored no case: remove what this sweep created in DIR
    (an empty case store, its spec.toml), so that `_claim` removes the lock and DIR too."""
    if store.stored():
        return
    for path, fresh in ((store.path, fresh_store), (out / "spec.toml", fresh_spec)):
        if fresh:
            with contextlib.suppress(OSError):
                path.unlink()


def _run_claimed(spec, out: Path, store, records, workers, scheduler, progress, on_start) -> dict:
    from reference_impl.sweep._output import (
        consolidate,
        replacing,
        write_parquet,
        write_summary,
    )
    from reference_impl.sweep._runner import iter_outcomes, open_client
    from reference_impl.sweep._tasks import run_case

    todo = [c for c in spec.cases if not c.error and c.key not in records]
    fresh_spec = not os.path.lexists(out / "spec.toml")
    fresh_store = not os.path.lexists(store.path)

    def prepare() -> None:
        """Copy the spec, store the invalid cases (after the cluster is reachable).

        A write that fails here is before any case ran: one line, exit status 2.
        """
        if on_start is not None:
            on_start()
        try:
            with replacing(out / "spec.toml") as tmp:
                tmp.write_text(spec.text, encoding="utf-8")
            for case in spec.invalid:  # a row with the reason; never sent to a worker
                if case.key not in records:
                    rec = _record(case, False, [], case.error, 0.0, "")
                    store.append(rec)
                    records[case.key] = rec
        except OSError as exc:
            _forget(out, store, fresh_spec, fresh_store)
            raise HCVInputError(f"--out {out}: {_cannot_write(exc)}; nothing run") from None

    tty = sys.stderr.isatty() if progress is None else progress
    t0 = time.perf_counter()
    where = f"scheduler {scheduler}" if scheduler else "local cluster"
    interrupted = False
    write_error = ""  # the first file of DIR that could not be written
    try:
        if not todo:
            prepare()
        else:
            with open_client(workers, scheduler) as client, contextlib.ExitStack() as stack:
                prepare()
                done0 = len(spec.cases) - len(todo)
                failed0 = sum(
                    1 for c in spec.cases if c.key in records and not records[c.key]["ok"]
                )
                n = sum(client.nthreads().values())
                where = (
                    f"scheduler {scheduler} ({n} worker threads)"
                    if scheduler
                    else f"local cluster of {n} worker process{'es' if n != 1 else ''}"
                )
                outcomes = stack.enter_context(
                    contextlib.closing(
                        iter_outcomes(
                            client,
                            run_case,
                            [c.payload() for c in todo],
                            keys=[f"hcv-case-{c.key}" for c in todo],
                        )
                    )
                )
                with _Display(len(spec.cases), done0, failed0, tty) as disp:
                    for o in outcomes:
                        case = todo[o.index]
                        rec = _record(
                            case, o.ok, o.value, o.error, o.seconds, o.worker, o.cpu_seconds
                        )
                        try:
                            store.append(rec)
                        except OSError as exc:  # a full disk: stop, keep what is stored
                            write_error = _cannot_write(exc)
                            break
                        records[case.key] = rec
                        disp.update(o.ok)
    except KeyboardInterrupt:
        interrupted = True
        if not (out / "spec.toml").exists():  # interrupted before anything was written
            return {"interrupted": True}
    seconds = time.perf_counter() - t0
    stored = store.stored()
    if write_error and not stored:
        _forget(out, store, fresh_spec, fresh_store)  # nothing to resume: leave DIR as found
        return _result(spec, records, 0, seconds, interrupted, where, write_error, stored)
    df = consolidate(spec, records)
    for write in (
        (lambda: write_parquet(df, out / "results.parquet")) if len(df) else None,
        lambda: write_summary(spec, df, out, seconds=seconds, where=where,
                              interrupted=interrupted),
    ):  # fmt: skip
        try:
            if write is not None:
                write()
        except OSError as exc:
            write_error = write_error or _cannot_write(exc)
    return _result(spec, records, len(df), seconds, interrupted, where, write_error, stored)


def _result(spec, records, rows, seconds, interrupted, where, write_error, stored) -> dict:
    """What `run_sweep` returns (see there)."""
    finished = [records[c.key] for c in spec.cases if c.key in records]
    failed = sum(1 for r in finished if not r["ok"])
    return {
        "cases": len(spec.cases),
        "ok": len(finished) - failed,
        "failed": failed,
        # bench: cases that ran but whose scorecard is not a pass (a metric failed, our
        # reference could not decide one, or nothing was measured)
        "not_passed": sum(
            1
            for r in finished
            if r["ok"] and any(row.get("status", "pass") != "pass" for row in r.get("rows") or [])
        )
        if spec.task.startswith("bench:")
        else 0,
        "rows": rows,
        "seconds": seconds,
        "interrupted": interrupted,
        "where": where,
        "write_error": write_error,
        "stored": stored,
    }


def _check_options(args, out: Path) -> None:
    """The options that need no spec, checked before the (possibly long) validation."""
    from reference_impl.sweep._output import CaseStore
    from reference_impl.sweep._runner import check_scheduler_address, dask_available

    check_path(args.spec, "spec file")
    if args.workers is not None and args.workers < 1:
        raise HCVInputError(f"--workers must be >= 1, got {args.workers}")
    if args.scheduler is not None and dask_available():
        check_scheduler_address(args.scheduler)
    _check_out(out, CaseStore(out))


class _Validating:
    """Progress of spec validation: a plain line after 1 s, then every few seconds."""

    def __init__(self):
        self.t0 = time.monotonic()
        self.last = None

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if now - self.t0 < 1.0 or (self.last is not None and now - self.last < _PLAIN_EVERY):
            if not (done == total and self.last is not None):
                return
        self.last = now
        print(
            f"sweep: validated {done}/{total} cases ({now - self.t0:.0f} s)",
            file=sys.stderr,
            flush=True,
        )


def run(args) -> int:
    """``hcv sweep`` for parsed arguments; returns the exit status."""
    from reference_impl.sweep._spec import load_spec

    try:
        out = Path(args.out or f"sweep-{Path(args.spec).stem}")
        _check_options(args, out)  # cheap checks first: a refusal is the only line
        spec = load_spec(args.spec, progress=_Validating())

        def note() -> None:
            if spec.invalid:
                first = spec.invalid[0]
                print(
                    f"sweep: {len(spec.invalid)} of {len(spec.cases)} cases have invalid "
                    f"parameters and are recorded as failed (first: {first.error})",
                    file=sys.stderr,
                )

        res = run_sweep(
            spec,
            out,
            workers=args.workers,
            scheduler=args.scheduler,
            resume=args.resume,
            on_start=note,
        )
    except KeyboardInterrupt:  # during validation or cluster start-up
        res = {"interrupted": True}
    if res["interrupted"]:
        from reference_impl._procs import terminated

        print(
            "hcv: terminated (SIGTERM)" if terminated() else "interrupted",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED  # the CLI makes it 143 after SIGTERM
    if res.get("write_error"):
        print(
            f"hcv: error: {res['write_error']}: the sweep stopped; {res['stored']} of "
            f"{res['cases']} cases are stored in {out / 'cases.jsonl'}"
            + (
                ", --resume runs the rest"
                if res["stored"]
                else " (none: what this sweep created there is removed)"
            ),
            file=sys.stderr,
        )
        return EXIT_FAIL
    gate = (
        f"; {res['not_passed']} of {res['ok']} benchmarked cases did not pass their "
        "scorecard (a metric failed, was undecided, or nothing was measured)"
        if res.get("not_passed")
        else ""
    )
    print(
        f"wrote {out / 'results.parquet'} ({res['rows']} rows; {res['ok']} cases ran, "
        f"{res['failed']} failed to run{gate}), {out / 'summary.md'} in "
        f"{res['seconds']:.1f} s on {res['where']}"
    )
    return EXIT_FAIL if res["failed"] or res.get("not_passed") else EXIT_OK
