"""``hcv bench``: the command line of the benchmark and CI gate.

    hcv bench ADAPTER [--scenes S [S ...]] [--tolerances FILE] [--steps-per-contact N]
                      [--gate [{both,implementation,delivery}]]
                      [--json FILE] [--junit FILE] [--plot FILE] [--markdown FILE]

ADAPTER is a registered name (``kratos``, ``lammps``, ``reference``, ``subprocess``), an
import path ``package.module:Class``, or ``cmd:COMMAND`` (a program speaking the
JSON protocol of docs/adapter-protocol.md); names and import paths take
constructor arguments as ``NAME[key=value,...]``.

Exit status: 0; with ``--gate`` 0 when every metric passes, 1 when any fails or
nothing was measured (every metric skipped, e.g. the code declined every scene), 3 when none fails but the suite's own reference could not decide one (an
internal error, never counted against the code); 2 for usage or configuration
errors (unknown adapter, bad scene or tolerances file, an output path that
cannot be written); a code declining scenes is never one; 130 on Ctrl-C
(the scorecard so far is printed and the files written, then "interrupted").
`add_parser` adds the subcommand to the ``hcv`` parser and `run` runs it;
``python -m reference_impl.cli.bench`` runs it stand-alone.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from reference_impl._userfiles import check_path, check_writable_dir, refuse_output_onto_input
from reference_impl.cli._run import run_command
from reference_impl.errors import HCVInputError

__all__ = ["add_parser", "main", "run"]

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


# Longest --scenes argument list accepted (characters), checked before any work.
_MAX_SCENE_ARGS = 100_000


# What --gate may name (`reference_impl.bench.scorecard._records.GATES`, repeated here: parsing the
# arguments imports nothing numerical, issue 20; verification/test_hostile_bench_usage.py checks
# the two agree).
_GATE_KINDS = ("both", "implementation", "delivery")


class _GateAction(argparse.Action):
    """``--gate [KIND]``. A value that is not a kind is the adapter written after the flag
    (``hcv bench --gate reference``, the order before --gate took a value): it is kept
    in ``gate_adapter`` and `_adapter` takes it when no adapter follows."""

    def __call__(self, parser, namespace, values, option_string=None):
        if values is None or values in _GATE_KINDS:
            setattr(namespace, self.dest, values or "both")
        else:
            setattr(namespace, self.dest, "both")
            namespace.gate_adapter = values


def _adapter(args) -> str:
    """The adapter of parsed arguments (also when written right after ``--gate``)."""
    after_gate = getattr(args, "gate_adapter", None)
    if after_gate is not None and args.adapter is not None:
        # the order on the command line is lost here (either order gives this namespace):
        # name the value and the kinds, not where to write them
        raise HCVInputError(
            f"--gate {after_gate}: {after_gate!r} is not one of "
            f"{'|'.join(_GATE_KINDS)} (or nothing, for both); the adapter is {args.adapter!r}"
        )
    adapter = args.adapter if args.adapter is not None else after_gate
    if adapter is None:
        raise HCVInputError(
            "hcv bench needs an ADAPTER (a registered name, package.module:Class or "
            "cmd:COMMAND), e.g. hcv bench reference --gate"
        )
    return adapter


def _scene_args(values: Sequence[str] | None) -> list[str] | None:
    if values is None:
        return None
    if sum(len(v) for v in values) > _MAX_SCENE_ARGS:
        raise HCVInputError(f"--scenes is longer than {_MAX_SCENE_ARGS} characters")
    out = [s.strip() for v in values for s in v.split(",") if s.strip()]
    if not out:
        raise HCVInputError(
            f"--scenes {' '.join(repr(v) for v in values)} names no scene; give "
            "scene names or TOML files, or leave --scenes out for the defaults"
        )
    return out


def check_output_file(path: str, option: str) -> None:
    """Refuse (HCVInputError) an output path that cannot be written, before any work.

    An existing regular file is overwritten; a directory, a missing or
    unwritable parent directory are refused.
    """
    p = Path(path)
    if p.is_dir():
        raise HCVInputError(f"{option} {path}: is a directory; give a file name")
    parent = p.parent
    if not parent.is_dir():
        raise HCVInputError(f"{option} {path}: directory {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise HCVInputError(f"{option} {path}: directory {str(parent)!r} is not writable")
    # Permission bits do not tell everything (root, read-only or virtual file systems).
    check_writable_dir(parent, option)
    if p.exists() and not (p.is_file() and os.access(p, os.W_OK)):
        raise HCVInputError(f"{option} {path}: exists and is not a writable regular file")


def _check_files(args, scenes: list[str] | None) -> None:
    """Every path fits the file system; outputs are writable and never an input."""
    outputs = {f"--{o}": getattr(args, o) for o in ("json", "junit", "plot", "markdown")}
    inputs = {"--tolerances": args.tolerances}
    for i, s in enumerate(scenes or ()):
        check_path(s, "--scenes")
        if os.path.isfile(s):  # a TOML file (else an embedded scene's name)
            inputs[f"--scenes {s}" if i else "--scenes"] = s
    if args.tolerances:
        check_path(args.tolerances, "--tolerances")
    for option, path in outputs.items():
        if path:
            check_path(path, option)
            check_output_file(path, option)
    refuse_output_onto_input(outputs, inputs)


def _tolerances(args):
    """``--tolerances FILE`` (or None), with ``--steps-per-contact N`` over its
    ``[run] steps_per_contact``; refused (one line naming N) by the tolerances' own rule."""
    if args.steps_per_contact is None:
        return args.tolerances
    from reference_impl.bench.scorecard.tolerances import load_tolerances

    tol = load_tolerances(args.tolerances)
    tol["run"]["steps_per_contact"] = args.steps_per_contact
    try:
        return load_tolerances(tol)
    except HCVInputError as exc:
        raise HCVInputError(f"--steps-per-contact {args.steps_per_contact}: {exc}") from None


class _Lines:
    """Progress as plain lines on stderr (no terminal: CI logs), at most one per step."""

    def __init__(self, adapter: str):
        self.adapter, self.t0 = adapter, time.perf_counter()

    def __call__(self, done: float, total: float) -> None:
        print(
            f"hcv bench {self.adapter}: {done:.0f} of {total:.0f} scene runs done "
            f"({time.perf_counter() - self.t0:.0f} s)",
            file=sys.stderr,
            flush=True,
        )


_EPILOG = (
    "adapters and their arguments (NAME[key=value,...]; a value alone, e.g. "
    "kratos[hertz,verlet] or lammps[tsuji], names its key):\n{adapters}"
    "\n\ntheir other options (NAME[key=value,...], e.g. mujoco[dampratio=0.25] or "
    "yade[tc=1e-4]):\n{options}"
    "\n\nexit status: 0 pass (or no --gate); 1 a metric failed (of the verdict --gate "
    "names: both by default, or implementation / delivery), or nothing was "
    "measured (every metric skipped, e.g. every scene declined: one SKIPPED line each); 2 usage or configuration error (also a law "
    "the adapter declares that no reference can be computed for); 3 no metric failed but "
    "our reference could not decide one; "
    "130 interrupted (Ctrl-C); 143 terminated (SIGTERM, handled as Ctrl-C)."
)


def _option_text(param) -> str:
    """``key=X`` (a number), ``key=true|false`` (a flag) or ``key=TEXT``, from the
    constructor parameter's annotation."""
    kind = str(param.annotation)
    if "bool" in kind:
        return f"{param.name}=true|false"
    if "float" in kind or "int" in kind:
        return f"{param.name}=X"
    return f"{param.name}=TEXT"


def _options_help() -> str:
    """One line per registered adapter: its constructor options that are not variant keys
    (those are listed above with their values), read from the class's signature."""
    import inspect

    from reference_impl.adapters.registry import registered, resolve_class

    named = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    lines = []
    for name in registered():
        try:
            cls = resolve_class(name)
            params = inspect.signature(cls).parameters.values()
        except (HCVInputError, TypeError, ValueError):  # a plug-in that does not load
            continue
        keys = set(getattr(cls, "spec_values", {}) or {})
        opts = [_option_text(p) for p in params if p.kind in named and p.name not in keys]
        if opts:
            lines.append(f"  {name}: {', '.join(opts)}")
    return "\n".join(lines)


_ADAPTER_HELP = (
    "registered name ({names}; installed packages add theirs through the hcv.adapters "
    "entry-point group), package.module:Class or cmd:COMMAND (cmd[sustained=true]:COMMAND "
    "for two-walls); NAME[key=value,...] passes arguments"
)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``bench`` subcommand to an argparse subparsers object.

    The epilog lists each adapter's keys, read from the adapter classes: it is written
    when the help is printed, so that parsing (and refusing) arguments imports no adapter.
    """
    b = subparsers.add_parser(
        "bench",
        help="benchmark a contact code against the exact solution (CI gate)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        # ADAPTER is required (`_adapter`); argparse's own usage would show it optional
        usage="%(prog)s ADAPTER [--scenes SCENE [SCENE ...]] [--tolerances FILE]\n"
        "       [--steps-per-contact N]\n"
        "       [--gate [{both,implementation,delivery}]] [--json FILE] [--junit FILE]\n"
        "       [--plot FILE] [--markdown FILE] [--show-skipped]",
        description="Run scenes through a contact code's adapter and through the exact "
        "solution; print the scorecard; with --gate exit 1 when a metric fails.",
    )
    plain_format_help = b.format_help

    def format_help() -> str:
        from reference_impl.adapters.registry import adapter_help, registered

        # Filled in at print time: listing the names reads every installed package's
        # entry points (20 ms), which no other command should pay (issue 20).
        adapter.help = _ADAPTER_HELP.format(names=", ".join(registered()))
        b.epilog = _EPILOG.format(adapters=adapter_help(), options=_options_help())
        return plain_format_help()

    b.format_help = format_help
    plain_parse_known_args = b.parse_known_args

    def parse_known_args(args=None, namespace=None):
        # An option bench does not know is refused here, with bench's usage; argparse
        # would hand it back to the top-level parser, which prints hcv's usage instead.
        namespace, extra = plain_parse_known_args(args, namespace)
        if extra:
            b.error(f"unrecognized arguments: {' '.join(extra)}")
        return namespace, extra

    b.parse_known_args = parse_known_args
    # optional to argparse only so that `hcv bench --gate ADAPTER` parses (`_adapter`)
    adapter = b.add_argument(
        "adapter", nargs="?", help=_ADAPTER_HELP.format(names="see hcv bench --help")
    )
    b.add_argument(
        "--scenes",
        nargs="+",
        action="extend",
        metavar="SCENE",
        help="scene names or TOML files (space or comma separated; repeatable, all are run); "
        "default: hertz, hertz-damped, hooke-damped, hertz-walls",
    )
    b.add_argument(
        "--tolerances", metavar="FILE", help="TOML file overriding the default tolerances"
    )
    b.add_argument(
        "--steps-per-contact",
        type=int,
        metavar="N",
        help="main runs at dt = exact contact time of the scene / N (default: the "
        "tolerances' [run] steps_per_contact, 200), as hcv calibrate's option",
    )
    b.add_argument(
        "--gate",
        nargs="?",
        action=_GateAction,
        metavar="{both,implementation,delivery}",
        help="exit 1 when a metric of the verdict(s) named fails (0 when all pass); "
        "plain --gate = both: implementation (against the declared law's exact solution) "
        "and delivery (against what the scene asks); hcv bench --gate ADAPTER works too",
    )
    b.add_argument("--json", metavar="FILE", help="write the JSON report here")
    b.add_argument("--junit", metavar="FILE", help="write JUnit XML here")
    b.add_argument("--plot", metavar="FILE", help="write the speed-against-error plot (PNG)")
    b.add_argument("--markdown", metavar="FILE", help="write the scorecard as markdown")
    b.add_argument("--show-skipped", action="store_true", help="list skipped metrics too")
    b.set_defaults(func=run)
    return b


def run(args) -> int:
    """Run the benchmark for parsed ``hcv bench`` arguments; returns the exit status."""
    from rich.console import Console

    from reference_impl.bench.scorecard.report import (
        plot_speed_error,
        render_scorecard,
        render_speed_error,
        write_markdown,
    )
    from reference_impl.bench.scorecard.runner import run_bench

    args.adapter = _adapter(args)
    scenes = _scene_args(args.scenes)
    _check_files(args, scenes)
    tolerances = _tolerances(args)
    if sys.stderr.isatty():
        from rich.progress import Progress

        with Progress(transient=True, console=Console(stderr=True)) as bar:
            task = bar.add_task(f"bench {args.adapter}", total=None)
            result = run_bench(
                args.adapter,
                scenes=scenes,
                tolerances=tolerances,
                json_path=args.json,
                junit_path=args.junit,
                progress=lambda d, t: bar.update(task, completed=d, total=t),
            )
    else:
        result = run_bench(
            args.adapter,
            scenes=scenes,
            tolerances=tolerances,
            json_path=args.json,
            junit_path=args.junit,
            progress=_Lines(args.adapter),
        )
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
        write_markdown(result, args.markdown)
    written = [p for p in (args.json, args.junit, args.plot, args.markdown) if p]
    if written:
        print("written: " + ", ".join(written))
    if result.interrupted:  # the results so far are out; the CLI says "interrupted", 130
        raise KeyboardInterrupt
    status = result.exit_status(args.gate)
    if args.gate:
        from reference_impl.bench.scorecard.report import gate_lines

        print("\n".join(gate_lines(result, args.gate)))
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m reference_impl.cli.bench ADAPTER ...`` (same options as ``hcv bench``)."""
    parser = argparse.ArgumentParser(prog="hcv")
    sub = parser.add_subparsers(dest="command", required=True)
    add_parser(sub)
    args = parser.parse_args(["bench", *(sys.argv[1:] if argv is None else argv)])
    return run_command(args)


if __name__ == "__main__":
    sys.exit(main())
