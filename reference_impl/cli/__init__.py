"""Command-line interface ``hcv``.

Every input problem (missing or malformed scene, a potential that violates the
paper's assumptions, NaN, an output path that cannot be written) is reported as
one line on stderr with exit status 2; nothing is computed for a scene that
fails validation. Ctrl-C ends any command with the line "hcv: interrupted" and
exit status 130 (128 + SIGINT, as shells report it); SIGTERM (CI's cancel) is
handled the same way, with "hcv: terminated (SIGTERM)" and exit status 143.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import sys
from collections.abc import Iterable, Sequence

from reference_impl import _procs
from reference_impl._version import version
from reference_impl.cli._run import EXIT_INTERRUPTED, interrupted, run_command

__all__ = ["COMMANDS", "main", "run_command", "solve_scene"]  # solve_scene: from tasks

# One row per command: its name, the module that parses and runs it (`add_parser(sub)`,
# `run(args)`), and the help line `hcv --help` shows. Only the chosen command's module is
# imported; the help is repeated here so that listing the commands imports none of them
# (verification/test_startup.py checks that each module gives the same help).
COMMANDS: tuple[tuple[str, str, str], ...] = (
    ("solve", "reference_impl.cli.solve", "exact impact solution for each velocity of a scene"),
    ("dt-crit", "reference_impl.cli.dt_crit",
     "measure the Verlet critical time step and test dt_safe"),
    ("report", "reference_impl.cli.report",
     "run every verification; write HTML, Markdown, JSON and figures (minutes on 2 "
     "cores; docs/getting-started.md gives the measured times)"),
    ("scenes", "reference_impl.cli.scenes",
     "list the scene catalogue (the same names work in every command); --show NAME prints "
     "one as TOML"),
    ("bench", "reference_impl.cli.bench",
     "benchmark a contact code against the exact solution (CI gate)"),
    ("sweep", "reference_impl.cli.sweep",
     "run a parameter sweep (dt-crit, solve, bench or calibrate) on a Dask cluster"),
    ("calibrate", "reference_impl.cli.calibrate",
     "find the value of a code's option that delivers a target restitution"),
)  # fmt: skip


# Parsing arguments and refusing bad ones imports nothing numerical (issue 20): a command
# module imports what it runs inside its `run`, and `solve_scene` is read on first use.
def __getattr__(name: str):
    if name == "solve_scene":
        from reference_impl.tasks import solve_scene

        return solve_scene
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class _Version(argparse.Action):
    """``--version``: reads the installed version only when asked (importlib.metadata is slow)."""

    def __init__(
        self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None
    ):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"{parser.prog} {version()}")
        parser.exit()


def _parser(commands: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """The ``hcv`` parser; the sub-parsers of ``commands`` (None: all) in full.

    A command outside ``commands`` gets a sub-parser with its name and help only, so that
    ``hcv --help`` lists it and a mistyped name is refused, without importing its module.
    """
    p = argparse.ArgumentParser(
        prog="hcv",
        description="Verification, exact reference and benchmark gate for the hidden-harmonic "
        "theory of contact dynamics.",
    )
    p.add_argument("--version", action=_Version, help="print the installed version and exit")
    sub = p.add_subparsers(dest="command", required=True)
    for name, module, help_ in COMMANDS:
        if commands is None or name in commands:
            importlib.import_module(module).add_parser(sub)
        else:
            sub.add_parser(name, help=help_)
    return p


def _chosen(argv: Sequence[str]) -> tuple[str, ...]:
    """The command named on a command line: its first word that is not an option.

    The top-level options (``--help``, ``--version``) take no value, so the first word
    without a leading dash is what argparse reads as the command.
    """
    return next(((a,) for a in argv if not a.startswith("-")), ())


# Commands that start processes (adapters, cluster workers): run as a child subreaper so
# that a daemonised adapter is still ours to kill at the end (reference_impl._procs).
_SPAWNING = ("bench", "sweep", "report")

# Commands whose process ends as they return, with nothing of theirs left to finalise (no
# process, file or pool of theirs outlives `run`): their heap is frozen (`gc.freeze`)
# before the interpreter exits. Its final garbage collections then skip the ~10^5 objects
# numba's typing and lowering registries made, a quarter of a second of CPU of a warm
# `hcv solve` and `hcv dt-crit` on 2 cores (issue 38 goal 7, measured by
# benchmarks/bench_startup.py); objects are still freed by their reference counts, and
# atexit handlers (the private compile cache's removal) run as before. Only a process that
# ends after `main` (argv None) is frozen: a caller's own heap is left alone.
_FROZEN_AT_EXIT = ("solve", "dt-crit", "scenes")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hcv`` console script; returns the exit status.

    Run from the command line (``argv`` None), SIGTERM is handled like Ctrl-C
    (exit 143), and commands that start processes become the subreaper of their
    descendants and kill any left when they end (`reference_impl._procs`). With
    an explicit ``argv`` (tests, scripts) the caller's signals and children are
    left alone.
    """

    if argv is not None:
        try:
            args = _parser(_chosen(argv)).parse_args(argv)
        except KeyboardInterrupt:
            return interrupted()
        return run_command(args)
    with _procs.sigterm_as_interrupt():
        try:
            args = _parser(_chosen(sys.argv[1:])).parse_args(argv)
        except KeyboardInterrupt:
            return interrupted()
        spawning = args.command in _SPAWNING and _procs.become_subreaper()
        try:
            code = run_command(args)
        finally:
            if spawning:
                _procs.kill_descendants()
        if code == EXIT_INTERRUPTED and _procs.terminated() is not None:
            code = 128 + _procs.terminated()  # a command that reported the interrupt itself
        if args.command in _FROZEN_AT_EXIT:
            gc.freeze()  # the process exits next (see _FROZEN_AT_EXIT)
        return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
