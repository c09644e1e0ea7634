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
import json
import math
import os
import sys
import time
from collections.abc import Sequence

from reference_impl.cli._run import EXIT_INTERRUPTED, EXIT_OK, interrupted, run_command
from reference_impl.errors import HCVInputError, UnsupportedError

__all__ = ["main", "run_command", "solve_scene"]  # solve_scene: re-exported from tasks


# Parsing arguments and refusing bad ones imports nothing numerical (issue 20): what a
# command runs (tasks, report, bench, sweep) is imported inside its command function, and
# the re-exported `solve_scene` on first use.
def __getattr__(name: str):
    if name == "solve_scene":
        from reference_impl.tasks import solve_scene

        return solve_scene
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

_SOLVE_ROWS = (
    ("max_penetration", "max penetration q_max [m]"),
    ("max_force", "elastic force at q_max, U'(q_max) [N]"),
    ("peak_force", "peak contact force, max(U' + C q') [N]"),
    ("dt_safe", "dt_safe, sup over [0, q_max] [s]"),
    ("dt_safe_shortcut", "dt_safe shortcut 2 m v0 / U'(q_max) [s]"),
    ("geometry", "geometry (sec. 6)"),
    ("contact_time", "contact time, end at q = 0 [s]"),
    ("returns_to_q0", "returns to q = 0"),
    ("restitution", "restitution, end at q = 0 (overlap)"),
    ("contact_time_zero_force", "contact time, end at zero force [s]"),
    ("restitution_zero_force", "restitution, end at zero force (zero-force)"),
    ("action", "action J(E) (sec. 4) [J s]"),
    ("period", "period T(E) = 4 x quarter period [s]"),
)


def _json_safe(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def _print_table(title: str, rows: list[dict], columns) -> None:
    """One row per result, one column per field."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=title)
    for _, header in columns:
        # escape: rich would read units such as "[m]" or "[s]" as markup and drop them
        table.add_column(escape(header), justify="right")
    for row in rows:
        table.add_row(*(_fmt(row.get(key)) for key, _ in columns))
    Console().print(table)


def _print_transposed(title: str, rows: list[dict], fields, key: str, key_label: str) -> None:
    """One row per field, one column per result (keeps wide result sets readable)."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=title)
    table.add_column(key_label, justify="left")
    for row in rows:
        table.add_column(_fmt(row[key]), justify="right")
    for name, label in fields:
        table.add_row(escape(label), *(_fmt(row.get(name)) for row in rows))
    Console().print(table)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.10g}"
    if isinstance(v, bool):
        return "yes" if v else "NO"
    return "—" if v is None else str(v)


def _cmd_solve(args) -> int:
    from reference_impl.scenes import load_scene
    from reference_impl.tasks import restitution_spread, solve_scene

    scene = load_scene(args.scene)
    if scene.kind != "impact":
        raise HCVInputError(
            f"scene {scene.name!r} has kind = {scene.kind!r}; 'hcv solve' solves single impacts "
            "(kind = \"impact\"); use 'hcv dt-crit' for sustained scenes"
        )
    rows = solve_scene(scene)
    _require_finite(rows, scene)
    spread = restitution_spread(rows)
    if args.json:
        out = {
            "scene": scene.to_dict(),
            "end_of_contact": {
                "contact_time/restitution": "overlap end: q returns to 0 (theory; the damper may pull)",
                "contact_time_zero_force/restitution_zero_force": (
                    "zero-force end: total force U' + C q' first reaches 0 after q_max"
                ),
            },
            "forces": {
                "max_force": "elastic force U'(q_max) at maximum penetration [N]",
                "peak_force": "peak total contact force max over the contact of U' + C q' [N]",
            },
            "results": [{k: _json_safe(v) for k, v in r.items()} for r in rows],
        }
        if spread is not None:
            out["restitution_spread"] = {k: _json_safe(v) for k, v in spread.items()}
        json.dump(out, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        law_txt = (
            f"zeta = {rows[0]['zeta']:.6g}"
            if rows[0]["zeta"] is not None
            else ", ".join(f"{k} = {v}" for k, v in scene.law.to_dict().items())
        )
        _print_transposed(
            f"hcv solve: {scene.name} (m = {scene.mass} kg, {law_txt})",
            rows,
            _SOLVE_ROWS,
            "v0",
            "impact speed v0 [m/s]",
        )
        if spread is not None:
            print(
                f"restitution spread over the {len(rows)} speeds (max - min): "
                f"{spread['overlap']:.3g} at the overlap end (q = 0), "
                f"{spread['zero-force']:.3g} at the zero-force end"
            )
        print(
            "Ends of contact: 'overlap' = q back to 0 (theory); 'zero-force' = total force "
            "U' + C q' first 0 (codes that forbid tension). Forces: U'(q_max) is elastic, "
            "peak = max of U' + C q'. J, T: section 4 definitions."
        )
    return EXIT_OK


# Results that are durations, lengths, forces or actions (>= 0 by definition), and
# restitutions (in [0, 1] by definition).
_NON_NEGATIVE = (
    "max_penetration",
    "max_force",
    "peak_force",
    "dt_safe",
    "dt_safe_shortcut",
    "contact_time",
    "contact_time_zero_force",
    "action",
    "period",
)
_UNIT_INTERVAL = ("restitution", "restitution_zero_force")


def _require_finite(rows: list[dict], scene) -> None:
    """Refuse (one line) rather than print a result that is non-finite or out of its range."""
    for row in rows:
        for key, value in row.items():
            if not isinstance(value, float):
                continue
            wrong = not math.isfinite(value)
            wrong |= key in _NON_NEGATIVE and value < 0
            wrong |= key in _UNIT_INTERVAL and not 0.0 <= value <= 1.0
            if wrong:
                raise UnsupportedError(
                    f"scene {scene.name!r}, v0 = {row['v0']:g} m/s: the solver gives {key} = "
                    f"{value!r}; this scene (damping {scene.law.to_dict()}) is outside what it "
                    "computes reliably"
                )


def _check_out_dir(path: str) -> None:
    """An output directory must be a writable directory, or creatable in one."""
    from pathlib import Path

    from reference_impl._userfiles import check_path

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


# More local workers than this is a typo, not a machine (each is a process).
_MAX_REPORT_WORKERS = 256


def _cmd_report(args) -> int:
    from rich.console import Console

    from reference_impl.campaign import build_report

    _check_out_dir(args.out)
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
    print(
        f"wrote {args.out}/index.html, index.md, results.json, figures/ "
        f"in {results['timings_seconds']['total']:.0f} s"
    )
    return EXIT_OK


def _cmd_scenes(args) -> int:
    from reference_impl.scenes._catalogue import catalogue_rows

    if args.show:
        from reference_impl.scenes import scene_toml

        print(scene_toml(args.show), end="")
        return EXIT_OK
    for r in catalogue_rows():
        params = " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                          for k, v in r["damping_params"].items())  # fmt: skip
        print(
            f"{r['name']:24s} {r['kind']:10s} {r['family']:11s} m={r['mass']:.4g} kg  "
            f"v0={r['velocities']} m/s  damping {r['damping']}" + (f" {params}" if params else "")
        )
    return EXIT_OK


def _cmd_dt_crit(args) -> int:
    from reference_impl.scenes import load_scene
    from reference_impl.tasks import search_loaded_scene

    scene = load_scene(args.scene)
    # The progress bar goes to stderr, so it is shown with --json too when stderr is a terminal.
    # Any given --criterion is parsed, so an empty one is refused rather than defaulted.
    with _progress(sys.stderr.isatty()) as progress:
        results = search_loaded_scene(scene, args.criterion, progress)
    rows = [r.to_dict() for r in results]
    if args.json:
        json.dump({"scene": scene.to_dict(), "results": rows}, sys.stdout, indent=2, default=str)
        sys.stdout.write("\n")
    else:
        fields = [
            ("kind", "scene kind"),
            ("dt_safe", "dt_safe (paper, sec. 6) [s]"),
            ("dt_safe_shortcut", "dt_safe shortcut [s]"),
            ("dt_crit", "measured dt_crit (smallest failing) [s]"),
            ("ratio", "dt_crit / dt_safe"),
            ("holds", "bound holds"),
            ("failure_kind", "failure kind"),
            ("dt_bounded", "dt_bounded [s]"),
            ("dt_accuracy", "dt_accuracy [s]"),
            ("recommended_dt", "recommended dt (this suite) [s]"),
            ("criterion", "criterion"),
        ]
        _print_transposed(
            f"hcv dt-crit: {scene.name} (m = {scene.mass} kg)",
            rows,
            fields,
            "v0",
            "impact speed v0 [m/s]",
        )
        for r in rows:
            ce = r.get("counterexample")
            if ce:
                print(f"v0 = {r['v0']}: counterexample {json.dumps(ce, default=str)}")
    return EXIT_OK


class _progress:
    """Context manager giving a rich progress callback, or None when not wanted."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self._bar = None

    def __enter__(self):
        if not self.enabled:
            return None
        from rich.progress import Progress

        self._bar = Progress(transient=True)
        self._bar.__enter__()
        task = self._bar.add_task("searching", total=None)

        def update(done: float, total: float) -> None:
            self._bar.update(task, completed=done, total=total)

        return update

    def __exit__(self, *exc):
        if self._bar is not None:
            self._bar.__exit__(*exc)
        return False


class _Version(argparse.Action):
    """``--version``: reads the installed version only when asked (importlib.metadata is slow)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from reference_impl._version import version

        print(f"{parser.prog} {version()}")
        parser.exit()


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="hcv",
        description="Verification, exact reference and benchmark gate for the hidden-harmonic "
        "theory of contact dynamics.",
    )
    p.add_argument("--version", action=_Version, help="print the installed version and exit")
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("solve", help="exact impact solution for each velocity of a scene")
    s.add_argument("scene", help="scene TOML file, or the name of an embedded scene (hcv scenes)")
    s.add_argument("--json", action="store_true", help="print one JSON object with a results list")
    s.set_defaults(func=_cmd_solve)
    d = sub.add_parser("dt-crit", help="measure the Verlet critical time step and test dt_safe")
    d.add_argument("scene", help="scene TOML file, or the name of an embedded scene")
    d.add_argument("--json", action="store_true", help="print one JSON object with a results list")
    d.add_argument(
        "--criterion",
        help="failure criterion: 'factor=100,n_steps=1e5,confirm_factor=1e4,confirm_horizon=10' "
        "for two-sided / two-walls (runaway: energy growth, confirmed), "
        "'tol=0.01,n_phases=16' for a single impact (accuracy: rebound energy gain)",
    )
    d.set_defaults(func=_cmd_dt_crit)
    report_help = (
        "run every verification; write HTML, Markdown, JSON and figures (the full run was "
        "measured at 141 s wall on 2 quiet cores with --adapter lammps, kratos and mujoco: "
        "reports/results.json of 2026-11-24)"
    )
    rp = sub.add_parser("report", help=report_help, description=report_help)
    rp.add_argument("--out", default="reports", help="output directory (default: reports/)")
    rp.add_argument(
        "--quick",
        action="store_true",
        # Measured (issue 20) by benchmarks/bench_startup.py --report, each in a new process
        # on a quiet 2-core machine (reports/bench/startup.json): wall, CPU of every process.
        help="smaller study (measured on 2 quiet cores, 2026-11-24: 35 s wall and 52 s CPU "
        "once compiled, 50 s wall the first time after installing)",
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
    rp.set_defaults(func=_cmd_report)
    ls = sub.add_parser(
        "scenes",
        help="list the scene catalogue (the same names work in every command); "
        "--show NAME prints one as TOML",
    )
    ls.add_argument(
        "--show", metavar="NAME", help="print this scene's TOML (a catalogue name or a file)"
    )
    ls.set_defaults(func=_cmd_scenes)
    from reference_impl.cli.bench import add_bench_parser

    add_bench_parser(sub)
    from reference_impl.cli.sweep import add_parser as add_sweep_parser

    add_sweep_parser(sub)
    from reference_impl.cli.calibrate import add_calibrate_parser

    add_calibrate_parser(sub)
    return p


# Commands that start processes (adapters, cluster workers): run as a child subreaper so
# that a daemonised adapter is still ours to kill at the end (reference_impl._procs).
_SPAWNING = ("bench", "sweep", "report")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hcv`` console script; returns the exit status.

    Run from the command line (``argv`` None), SIGTERM is handled like Ctrl-C
    (exit 143), and commands that start processes become the subreaper of their
    descendants and kill any left when they end (`reference_impl._procs`). With
    an explicit ``argv`` (tests, scripts) the caller's signals and children are
    left alone.
    """
    from reference_impl import _procs

    if argv is not None:
        try:
            args = _parser().parse_args(argv)
        except KeyboardInterrupt:
            return interrupted()
        return run_command(args)
    with _procs.sigterm_as_interrupt():
        try:
            args = _parser().parse_args(argv)
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
        return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
