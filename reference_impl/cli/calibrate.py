"""``hcv calibrate``: the parser and the printout of `reference_impl.bench.calibration.calibrate`."""

from __future__ import annotations

import argparse
import json
import sys

from reference_impl.cli._run import run_command
from reference_impl.errors import HCVInputError

# The names of `reference_impl.theory.damping.RESTITUTION_ENDS`, not imported from there so
# that parsing imports nothing numerical (verification/test_startup.py checks they agree).
_ENDS = ("overlap", "zero-force")

__all__ = ["add_parser", "main", "run"]


def _target(text: str) -> tuple[str, float]:
    name, sep, val = str(text).partition("=")
    if not sep:
        raise HCVInputError(f"--target {text!r}: give QUANTITY=VALUE, e.g. restitution=0.5")
    try:
        num = float(val)
    except ValueError:
        raise HCVInputError(f"--target {text!r}: {val!r} is not a number") from None
    return name.strip(), num


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``calibrate`` subcommand to an argparse subparsers object."""
    p = subparsers.add_parser(
        "calibrate",
        help="find the value of a code's option that delivers a target restitution",
        description="Bracketed root search over an adapter option for the value at which "
        "the code delivers the target, at the given resolution (steps per contact).",
    )
    p.add_argument("adapter", help="adapter spec with one variant, e.g. mujoco[solref=direct,"
                   "impedance=constant,integrator=Euler]")  # fmt: skip
    p.add_argument("--scene", required=True, help="scene name or TOML file (an impact)")
    p.add_argument("--target", required=True, help="QUANTITY=VALUE, e.g. restitution=0.5")
    p.add_argument(
        "--param",
        required=True,
        help="adapter option searched (e.g. dampratio), or the scene law's strength (e.g. alpha)",
    )
    p.add_argument("--end", default="overlap", choices=_ENDS,
                   help="end of contact the restitution is read at (default: overlap)")  # fmt: skip
    p.add_argument("--steps-per-contact", type=int, default=200, metavar="N",
                   help="dt = exact contact time of the scene / N (default 200)")  # fmt: skip
    p.add_argument("--v0", type=float, help="impact speed, m/s (default: the middle speed)")
    p.add_argument("--range", type=float, nargs=2, metavar=("LO", "HI"),
                   help="search range of the option (default: the adapter's)")  # fmt: skip
    p.add_argument("--isolate", action="store_true",
                   help="run each evaluation in a worker process (slower, crash-safe)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=run)
    return p


def _fmt(x) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)


def run(args) -> int:
    """Run ``hcv calibrate``; exit 0 found, 1 out of reach, 2 bad input."""
    from reference_impl.bench.calibration.calibrate import EXIT_OK, EXIT_UNREACHABLE, calibrate

    quantity, target = _target(args.target)
    res = calibrate(
        args.adapter,
        args.scene,
        param=args.param,
        target=target,
        quantity=quantity,
        end=args.end,
        steps_per_contact=args.steps_per_contact,
        v0=args.v0,
        bracket=args.range,
        isolate=args.isolate,
    )
    if args.json:
        print(json.dumps(res.to_dict(), indent=2, default=str))
        return EXIT_OK if res.found else EXIT_UNREACHABLE
    print(res.message)
    if not res.found:
        return EXIT_UNREACHABLE
    for note in res.notes:  # runs without rebound (counted as 0), declined or failed values
        print(f"  note: {note}")
    m = res.metrics
    print(f"  adapter {res.adapter}, scene {res.scene}, dt = {res.dt:.6g} s")
    if "declared_law" in m:
        print(f"  declared law: {m['declared_law']['description']}")
    rows = [("quantity", "measured", "declared law", "error", "scene as asked", "error")]
    for k in ("restitution", "restitution_zero_force", "contact_time", "max_penetration"):
        rows.append(
            (
                {
                    "restitution": "restitution (q = 0 end)",
                    "restitution_zero_force": "restitution (zero-force end)",
                    "contact_time": "contact time, s",
                    "max_penetration": "max penetration, m",
                }[k],  # fmt: skip
                _fmt(m["measured"].get(k)),
                _fmt(m.get("declared_law", {}).get(k)),
                _fmt(m.get("error_vs_declared_law", {}).get(k)),
                _fmt(m["scene_as_asked"].get(k)),
                _fmt(m.get("error_vs_scene_as_asked", {}).get(k)),
            )
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print("  " + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))
    print(f"  ({res.evaluations} runs; errors are relative)")
    return EXIT_OK


def main(argv=None) -> int:  # pragma: no cover - thin wrapper
    p = argparse.ArgumentParser(prog="hcv")
    add_parser(p.add_subparsers(dest="command", required=True))
    return run_command(p.parse_args(["calibrate", *(sys.argv[1:] if argv is None else argv)]))
