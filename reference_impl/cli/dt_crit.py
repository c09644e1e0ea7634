"""``hcv dt-crit SCENE [--json] [--criterion SPEC]``: measure Verlet's critical step, test dt_safe."""

from __future__ import annotations

import json
import sys
import time

from reference_impl.cli._run import EXIT_FAIL, EXIT_OK
from reference_impl.cli._tables import fmt, print_transposed, scene_title
from reference_impl.errors import HCVInputError

__all__ = ["add_parser", "run"]

# Plain progress lines of an assembly's ensembles (not a terminal): at most one per this
# many seconds within a horizon (a line at each horizon's start and at the end regardless).
_PLAIN_EVERY = 10.0

_FIELDS = (
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
)


def add_parser(subparsers) -> None:
    """Add the ``dt-crit`` subcommand to an argparse subparsers object."""
    d = subparsers.add_parser(
        "dt-crit", help="measure the Verlet critical time step and test dt_safe"
    )
    d.add_argument("scene", help="scene TOML file, or the name of an embedded scene")
    d.add_argument("--json", action="store_true", help="print one JSON object with a results list")
    d.add_argument(
        "--criterion",
        help="failure criterion: 'factor=100,n_steps=1e5,confirm_factor=1e4,confirm_horizon=10' "
        "for two-sided / two-walls (runaway: energy growth, confirmed), "
        "'tol=0.01,n_phases=16' for a single impact (accuracy: rebound energy gain)",
    )
    d.add_argument(
        "--horizons",
        help="assembly scenes (chain, lattice): steps of each ensemble, comma-separated "
        "(default 1e4,1e5,1e6; the 1e6 ensemble of a ten-body chain is ~2e10 contact updates, "
        "about ten minutes on one core)",
    )
    d.add_argument(
        "--lanes",
        type=int,
        default=32,
        help="assembly scenes: lanes per ensemble, their initial velocities differing in the "
        "last bits (default 32)",
    )
    d.add_argument(
        "--adapter",
        metavar="CODE",
        help="chain and periodic lattice scenes: run the scene in a contact code (liggghts, "
        "yade, lammps) instead: its "
        "measured dt_crit by the suite's search and criterion at --horizons steps (one value, "
        "default 2000) and a verdict on the code's own step advice",
    )
    d.add_argument(
        "--timeout",
        metavar="SECONDS",
        help="with --adapter: seconds allowed for each run of the code (a chain or lattice, or "
        "its step advice); the code's process is killed at it and hcv stops with one line "
        "(default 60, hcv bench's per-run timeout; a cmd: spec's own timeout= wins)",
    )
    d.add_argument(
        "--gate",
        action="store_true",
        help="exit 1 when the dt_safe bound fails at any speed (a step-size check for CI)",
    )
    d.set_defaults(func=run)


def run(args) -> int:
    """Search the scene's critical steps and print them (a table, or JSON with ``--json``)."""
    from reference_impl.scenes import load_scene
    from reference_impl.tasks import search_assembly_scene, search_loaded_scene

    timeout = _timeout(getattr(args, "timeout", None), getattr(args, "adapter", None))
    scene = load_scene(args.scene)
    if getattr(args, "adapter", None) is not None:
        # a contact code on a chain or lattice (issue 39 §4), in its own module: it loads the codes
        from reference_impl.cli._dt_crit_code import run_code

        return run_code(args, scene, _horizons(args.horizons), timeout)
    if scene.kind in ("chain", "lattice"):
        return _run_assembly(args, scene, search_assembly_scene)
    # The progress bar goes to stderr, so it is shown with --json too when stderr is a terminal.
    # Any given --criterion is parsed, so an empty one is refused rather than defaulted.
    with _progress(sys.stderr.isatty()) as progress:
        results = search_loaded_scene(scene, args.criterion, progress)
    rows = [r.to_dict() for r in results]
    if args.json:
        json.dump({"scene": scene.to_dict(), "results": rows}, sys.stdout, indent=2, default=str)
        sys.stdout.write("\n")
    else:
        print_transposed(
            scene_title("dt-crit", scene), rows, _FIELDS, "v0", "impact speed v0 [m/s]"
        )
        for r in rows:
            if r.get("counterexample"):
                print("\n".join(counterexample_lines(r["v0"], r["counterexample"])))
    if getattr(args, "gate", False):
        return gate_status(rows, to=sys.stderr if args.json else sys.stdout)
    return EXIT_OK


# Longest --timeout accepted (s): a day, the bound of hcv bench's [run] timeout.
_MAX_TIMEOUT_S = 86400.0


def _timeout(text: str | None, adapter: str | None) -> float | None:
    """``--timeout`` in seconds (None: the default of `reference_impl.bench._code_worker`);
    refused in one line, before the scene is read, when it is not a number in (0, 1 day]
    or is given without ``--adapter`` (it would bound nothing)."""
    if text is None:
        return None
    if adapter is None:
        raise HCVInputError(
            f"--timeout {text!r} bounds the runs of a code: it needs --adapter CODE"
        )
    try:
        v = float(text)
    except ValueError:
        raise HCVInputError(f"--timeout: {text.strip()!r} is not a number of seconds") from None
    if not 0.0 < v <= _MAX_TIMEOUT_S:  # nan fails the test
        raise HCVInputError(f"--timeout: {text.strip()!r} is not in (0, 86400] seconds")
    return v


def _horizons(text: str | None) -> list[int] | None:
    """``--horizons`` as integers (steps), or None for the default; one line on bad input."""
    if text is None:
        return None
    out = []
    for part in text.split(","):
        try:
            v = float(part)
        except ValueError:
            raise HCVInputError(f"--horizons: {part.strip()!r} is not a number of steps") from None
        if not 1 <= v <= 10_000_000 or v != int(v):  # nan fails the first test
            raise HCVInputError(f"--horizons: {part.strip()!r} is not an integer in [1, 1e7] steps")
        out.append(int(v))
    return out


def _run_assembly(args, scene, search_assembly_scene) -> int:
    """``hcv dt-crit`` on a chain or lattice: the ensemble's distribution, per horizon
    (``search_assembly_scene``: `reference_impl.tasks.search_assembly_scene`)."""
    horizons = _horizons(args.horizons)
    labels = sorted(set(horizons)) if horizons else None
    with _EnsembleProgress(sys.stderr.isatty(), labels, args.lanes) as progress:
        rep = search_assembly_scene(scene, horizons, args.lanes, args.criterion, progress)
    if args.json:
        json.dump({"scene": scene.to_dict(), "assembly": rep}, sys.stdout, indent=2, default=str)
        sys.stdout.write("\n")
    else:
        print(f"dt-crit: {scene.name} ({scene.kind}, {rep['n_bodies']} bodies, "
              f"{rep['n_contacts']} contacts, Z = {fmt(rep['coordination'])}, "
              f"{rep['n_lanes']} lanes)")  # fmt: skip
        for k, v in rep["dt_safe"].items():
            print(f"  dt_safe ({k}) [s]: {fmt(v)}")
        for r in rep["by_horizon"]:
            q = r["dt_crit_quantiles"]
            ratio = r["dt_crit_over_dt_safe"]
            print(f"  horizon {r['horizon']} steps: dt_crit 5/50/95 % [s] = {fmt(q['5'])}, "
                  f"{fmt(q['50'])}, {fmt(q['95'])}; over dt_safe {fmt(ratio['5'])}, "
                  f"{fmt(ratio['50'])}, {fmt(ratio['95'])}; tangent step [s] "
                  f"{fmt(r['dt_tangent'])}")  # fmt: skip
        print(f"  horizon dependent: {rep['horizon_dependent']}; dt_safe <= dt_crit (5 %) at "
              f"every horizon: {rep['holds']}; factor {fmt(rep['factor'])}")  # fmt: skip
    if getattr(args, "gate", False):
        to = sys.stderr if args.json else sys.stdout
        if not rep["holds"]:
            print(f"gate: FAIL (dt_crit 5 % point / dt_safe = {fmt(rep['factor'])})", file=to)
            return EXIT_FAIL
        print("gate: pass (dt_safe <= dt_crit 5 % point at every horizon)", file=to)
    return EXIT_OK


def counterexample_lines(v0, ce: dict) -> list[str]:
    """A counterexample as labelled lines (one per field; a nested table on one line)."""
    lines = [f"counterexample at v0 = {fmt(v0)} m/s:"]
    for k, v in ce.items():
        label = _CE_LABELS.get(k, k)
        if isinstance(v, dict):
            v = ", ".join(f"{kk}: {fmt(vv)}" for kk, vv in v.items())
        lines.append(f"  {label}: {fmt(v)}")
    return lines


# Labels (with units) of the counterexample's fields; others are shown by their key.
_CE_LABELS = {
    "dt": "dt [s]",
    "dt_over_dt_safe": "dt / dt_safe",
    "steps": "steps run",
    "E0": "E_0 [J]",
    "E_max_over_E0": "max E_n / E_0",
    "E_end_over_E0": "E_end / E_0",
    "max_E_over_E0_by_step": "max E_n / E_0 by step n",
}


def gate_status(rows: list[dict], to=None) -> int:
    """``--gate``: 1 when the bound fails (``holds`` false) at any speed, with one line
    (on ``to``, default stdout; stderr under ``--json``, whose stdout is the document)."""
    to = to if to is not None else sys.stdout
    failed = [r for r in rows if r.get("holds") is False]
    if failed:
        speeds = ", ".join(f"{fmt(r['v0'])} m/s (dt_crit / dt_safe = {fmt(r.get('ratio'))})"
                           for r in failed)  # fmt: skip
        print(f"gate: FAIL (the dt_safe bound fails at v0 = {speeds})", file=to)
        return EXIT_FAIL
    print(f"gate: pass (the dt_safe bound holds at all {len(rows)} speeds)", file=to)
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


class _EnsembleProgress:
    """Progress of an assembly's ensembles, per horizon and per round of the lanes' searches.

    The callback gets ``(completed, total)`` from `assembly_report`: ``total`` horizons,
    the integer part of ``completed`` the horizon running and its fraction the share of
    that horizon's search done (updated after each round and between the kernel's calls
    within a round, so a long horizon shows its progress too). On a terminal a rich bar
    whose text names the horizon; else plain stderr lines: one as each horizon starts, then
    at most one per `_PLAIN_EVERY` seconds, and one at the end.
    """

    def __init__(self, tty: bool, horizons: list[int] | None, lanes: int):
        self.tty, self.horizons, self.lanes = tty, horizons, lanes
        self.bar, self.k, self.t0, self.last = None, -1, time.monotonic(), 0.0

    def __enter__(self):
        if self.tty:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(
                TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(),
                console=Console(stderr=True), transient=True,
            )  # fmt: skip
            self.bar.__enter__()
            self.task = self.bar.add_task("dt-crit", total=None)
        return self.update

    def _name(self, k: int, n: int) -> str:
        steps = f" ({self.horizons[k]:,} steps)" if self.horizons and k < len(self.horizons) else ""
        return f"horizon {k + 1} of {n}{steps}, {self.lanes} lanes"

    def update(self, done: float, total: float) -> None:
        n = max(int(total), 1)
        k = min(int(done), n - 1)
        now = time.monotonic()
        share = 1.0 if done >= total else done - k
        if self.bar is not None:
            self.bar.update(self.task, completed=done, total=total,
                            description=f"dt-crit: {self._name(k, n)}")  # fmt: skip
            return
        if k != self.k or done >= total or now - self.last >= _PLAIN_EVERY:
            what = "done" if done >= total else f"{100 * share:.0f} % of its search"
            if done >= total:
                line = f"dt-crit: all {n} horizon{'s' if n > 1 else ''} done"
            else:
                line = f"dt-crit: {self._name(k, n)}: {what}"
            if done >= total and self.k == n:  # the end, already said
                return
            print(f"{line} ({now - self.t0:.0f} s)", file=sys.stderr, flush=True)
            self.k, self.last = (n if done >= total else k), now

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.__exit__(*exc)
        return False
