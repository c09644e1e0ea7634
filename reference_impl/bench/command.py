"""``hcv bench``: the command line of the benchmark and CI gate.

    hcv bench ADAPTER [--scenes S [S ...]] [--tolerances FILE] [--gate]
                      [--json FILE] [--junit FILE] [--plot FILE] [--markdown FILE]

ADAPTER is a registered name (``reference``, ``lammps``, ``subprocess``), an
import path ``package.module:Class``, or ``cmd:COMMAND`` (a program speaking the
JSON protocol of docs/adapter-protocol.md); names and import paths take
constructor arguments as ``NAME[key=value,...]``.

Exit status: 0; with ``--gate`` 0 when every metric passes and 1 when any fails
(or the run was interrupted); 2 for usage or configuration errors (unknown
adapter, bad scene or tolerances file, an adapter that supports none of the
scenes). `add_bench_parser` adds the subcommand to the ``hcv`` parser;
``python -m reference_impl.bench`` runs it stand-alone.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..errors import HCVInputError

__all__ = ["add_bench_parser", "cmd_bench", "main"]

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


def _scene_args(values: Sequence[str] | None) -> list[str] | None:
    if not values:
        return None
    out = [s.strip() for v in values for s in v.split(",") if s.strip()]
    return out or None


def add_bench_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``bench`` subcommand to an argparse subparsers object."""
    b = subparsers.add_parser(
        "bench", help="benchmark a contact code against the exact solution (CI gate)",
        description="Run scenes through a contact code's adapter and through the exact "
                    "solution; print the scorecard; with --gate exit 1 when a metric fails.")
    b.add_argument("adapter", help="registered name (reference, lammps, subprocess), "
                                   "package.module:Class or cmd:COMMAND; NAME[key=value,...] "
                                   "passes arguments")
    b.add_argument("--scenes", nargs="+", metavar="SCENE",
                   help="scene names or TOML files (space or comma separated); default: "
                        "hertz, hertz-damped, hooke-damped, hertz-walls")
    b.add_argument("--tolerances", metavar="FILE",
                   help="TOML file overriding the default tolerances")
    b.add_argument("--gate", action="store_true",
                   help="exit 1 when any metric fails (0 when all pass)")
    b.add_argument("--json", metavar="FILE", help="write the JSON report here")
    b.add_argument("--junit", metavar="FILE", help="write JUnit XML here")
    b.add_argument("--plot", metavar="FILE", help="write the speed-against-error plot (PNG)")
    b.add_argument("--markdown", metavar="FILE", help="write the scorecard as markdown")
    b.add_argument("--show-skipped", action="store_true", help="list skipped metrics too")
    b.set_defaults(func=cmd_bench)
    return b


def cmd_bench(args) -> int:
    """Run the benchmark for parsed ``hcv bench`` arguments; returns the exit status."""
    from pathlib import Path

    from rich.console import Console

    from .report import plot_speed_error, render_scorecard, render_speed_error, scorecard_markdown
    from .runner import run_bench

    if sys.stderr.isatty():
        from rich.progress import Progress

        with Progress(transient=True, console=Console(stderr=True)) as bar:
            task = bar.add_task(f"bench {args.adapter}", total=None)
            result = run_bench(args.adapter, scenes=_scene_args(args.scenes),
                               tolerances=args.tolerances, json_path=args.json,
                               junit_path=args.junit,
                               progress=lambda d, t: bar.update(task, completed=d, total=t))
    else:
        result = run_bench(args.adapter, scenes=_scene_args(args.scenes),
                           tolerances=args.tolerances, json_path=args.json,
                           junit_path=args.junit)
    console = Console()
    render_scorecard(result, console=console, show_skipped=args.show_skipped)
    if result.speed_error:
        render_speed_error(result, console=console)
    if args.plot:
        try:
            plot_speed_error(result.speed_error, args.plot)
        except ImportError:
            raise HCVInputError("--plot needs matplotlib (pip install -e '.[report]')") from None
    if args.markdown:
        Path(args.markdown).write_text(scorecard_markdown(result), encoding="utf-8")
    written = [p for p in (args.json, args.junit, args.plot, args.markdown) if p]
    if written:
        print("written: " + ", ".join(written))
    status = result.exit_status(args.gate)
    if args.gate:
        c = result.counts()
        print(f"gate: {'FAIL' if status else 'pass'} ({c['fail']} of {c['pass'] + c['fail']} "
              f"metrics failed)")
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m reference_impl.bench ADAPTER ...`` (same options as ``hcv bench``)."""
    parser = argparse.ArgumentParser(prog="hcv")
    sub = parser.add_subparsers(dest="command", required=True)
    add_bench_parser(sub)
    args = parser.parse_args(["bench", *(sys.argv[1:] if argv is None else argv)])
    try:
        return args.func(args)
    except HCVInputError as exc:
        print(f"hcv: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:
        sys.stderr.close()
        return EXIT_OK
