"""``hcv report [--out DIR] [--quick] [--force] [--adapter A ...] [--workers N] [--from FILE]``.

Runs every verification and writes DIR/index.html, index.md, results.json and
figures/. The output directory is checked (writable, or creatable) before any work.
``--from results.json`` runs nothing: it re-renders that report's pages into DIR.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from reference_impl._userfiles import check_path
from reference_impl.cli._run import EXIT_OK
from reference_impl.errors import HCVInputError

__all__ = ["add_parser", "run"]

# More local workers than this is a typo, not a machine (each is a process).
_MAX_REPORT_WORKERS = 256

# No time of a full run here: each `hcv report` rewrites reports/results.json with its own
# time (load, cache and codes differ), so a figure copied from it goes stale with the next
# run (issue 41); the measured times live in docs/getting-started.md. The --quick figures
# come from reports/bench/startup.json, which only benchmarks/bench_startup.py rewrites.
_HELP = (
    "run every verification; write HTML, Markdown, JSON and figures (minutes on 2 "
    "cores; docs/getting-started.md gives the measured times)"
)


def add_parser(subparsers) -> None:
    """Add the ``report`` subcommand to an argparse subparsers object."""
    rp = subparsers.add_parser("report", help=_HELP, description=_HELP)
    rp.add_argument("--out", default="reports", help="output directory (default: reports/)")
    rp.add_argument(
        "--quick",
        action="store_true",
        # Measured (issue 20) by benchmarks/bench_startup.py --report, each in a new process
        # on a quiet 2-core machine (reports/bench/startup.json): wall, CPU of every process.
        help="smaller study (measured on 2 cores at load 1.5-1.8, 2026-11-29: 35 s wall and 59 s CPU "
        "once compiled, 150 s wall the first time after installing)",
    )
    rp.add_argument(
        "--force",
        action="store_true",
        help="write into a directory that holds files hcv report did not write (kept, "
        "except files of the report's names, which are replaced)",
    )
    rp.add_argument(
        "--adapter",
        action="append",
        metavar="ADAPTER",
        help="also benchmark this contact code (as for hcv bench) and add its scorecard; "
        "repeatable",
    )
    rp.add_argument(
        "--workers",
        type=int,
        default=0,
        metavar="N",
        help="run the critical-step map on a local Dask cluster of N processes "
        "(sweep extra); 0 (default) runs it in two background processes",
    )
    rp.add_argument(
        "--from",
        dest="from_results",
        metavar="RESULTS",
        help="run nothing: re-render the pages of this results.json (its figures beside it) "
        "into --out",
    )
    rp.set_defaults(func=run)


def _check_out_dir(path: str) -> None:
    """An output directory must be a writable directory, or creatable in one."""
    check_path(path, "--out")
    p = Path(path)
    if p.exists():
        if not p.is_dir():
            raise HCVInputError(f"--out {path}: exists and is not a directory")
        if not os.access(p, os.W_OK | os.X_OK):
            raise HCVInputError(f"--out {path}: directory is not writable")
        _probe(p.parent if p.parent != p else p, path)  # the report is swapped in beside it
        return
    parent = p.parent
    if not parent.is_dir():
        raise HCVInputError(f"--out {path}: parent directory {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise HCVInputError(f"--out {path}: parent directory {str(parent)!r} is not writable")
    _probe(parent, path)


def _probe(directory, path: str) -> None:
    """Create and remove a directory in ``directory``: permission bits do not tell that a
    file system refuses new entries (/proc, /sys, a read-only mount, root's access())."""
    import tempfile

    try:
        os.rmdir(tempfile.mkdtemp(prefix=".hcv-probe-", dir=directory))
    except OSError as exc:
        raise HCVInputError(
            f"--out {path}: cannot create anything in {str(directory)!r} ({exc.strerror})"
        ) from None


def run(args) -> int:
    """Build the report into ``args.out``; print each claim's verdict and what was written."""
    from rich.console import Console

    from reference_impl.campaign import build_report, readme_rewritten_by

    _check_out_dir(args.out)
    if args.from_results is not None:
        return _rerender(args)
    if not 0 <= args.workers <= _MAX_REPORT_WORKERS:
        raise HCVInputError(
            f"--workers {args.workers}: must be 0 (no cluster) to {_MAX_REPORT_WORKERS}"
        )
    if args.workers:
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise HCVInputError(
                f"--workers {args.workers} needs Dask: pip install -e '.[sweep]' "
                "(or leave --workers out)"
            ) from None

    if sys.stderr.isatty():
        with Console(stderr=True).status("hcv report: starting") as status:
            results = build_report(
                args.out,
                quick=args.quick,
                progress=lambda text: status.update(f"hcv report: {text}"),
                adapters=args.adapter or (),
                workers=args.workers,
                force=args.force,
            )
    else:  # CI logs, pipes: one plain line per stage, as bench and sweep print
        t0 = time.perf_counter()

        def line(text: str) -> None:
            print(
                f"hcv report: {text} ({time.perf_counter() - t0:.0f} s)",
                file=sys.stderr,
                flush=True,
            )

        results = build_report(
            args.out,
            quick=args.quick,
            progress=line,
            adapters=args.adapter or (),
            workers=args.workers,
            force=args.force,
        )
    for c in results["claims"]:
        print(f"{c['verdict']:>12}  {c['id']}")
    readme = readme_rewritten_by(args.out)
    print(
        f"wrote {args.out}/index.html, index.md, erratum.md, results.json, figures/"
        + (f" and {os.path.relpath(readme)} (its generated blocks)" if readme else "")
        + f" in {results['timings_seconds']['total']:.0f} s"
    )
    return EXIT_OK


def _rerender(args) -> int:
    """``--from``: the pages of a written results.json, nothing run."""
    from reference_impl.report import render_from

    asked = [o for o, v in (("--quick", args.quick), ("--adapter", args.adapter),
                            ("--workers", args.workers)) if v]  # fmt: skip
    if asked:
        raise HCVInputError(
            f"--from {args.from_results}: re-renders without running; {', '.join(asked)} "
            "needs a run (leave --from out)"
        )
    t0 = time.perf_counter()
    results = render_from(args.from_results, args.out, force=args.force)
    print(
        f"wrote {args.out}/index.html, index.md, erratum.md from {args.from_results} "
        f"(the run of {results['generated_utc']}) in {time.perf_counter() - t0:.1f} s"
    )
    return EXIT_OK
