"""``hcv solve SCENE [--json] [--rtol R]``: the exact impact solution for each velocity of a scene.

``--rtol`` asks the solver for a relative error bound R on each time instead of its full
accuracy (`reference_impl.exact._rtol`); a bad R is one line, exit status 2, before the
scene is read.

A result that is non-finite or outside its range (a negative time, a restitution
outside [0, 1]) is refused with one line and exit status 2, never printed.
"""

from __future__ import annotations

import json
import math
import sys

from reference_impl.cli._run import EXIT_OK
from reference_impl.cli._tables import print_transposed, scene_title
from reference_impl.errors import HCVInputError, UnsupportedError

__all__ = ["add_parser", "run"]

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


def add_parser(subparsers) -> None:
    """Add the ``solve`` subcommand to an argparse subparsers object."""
    s = subparsers.add_parser("solve", help="exact impact solution for each velocity of a scene")
    s.add_argument("scene", help="scene TOML file, or the name of an embedded scene (hcv scenes)")
    s.add_argument("--json", action="store_true", help="print one JSON object with a results list")
    s.add_argument(
        "--rtol",
        metavar="R",
        help="relative error bound asked of each time, 0 < R <= 0.1 (default: full accuracy)",
    )
    s.set_defaults(func=run)


def _rtol(text):
    """The ``--rtol`` value as a float, or None (full accuracy); its range is checked by
    `reference_impl.tasks.solve_scene` before any impact is solved."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        raise HCVInputError(f"hcv solve: --rtol = {text!r} is not a number") from None


def _json_safe(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def run(args) -> int:
    """Solve the scene's impacts and print them (a table, or JSON with ``--json``)."""
    from reference_impl.scenes import load_scene
    from reference_impl.tasks import restitution_spread, solve_scene

    rtol = _rtol(getattr(args, "rtol", None))
    scene = load_scene(args.scene)
    if scene.kind != "impact":
        raise HCVInputError(
            f"scene {scene.name!r} has kind = {scene.kind!r}; 'hcv solve' solves single impacts "
            "(kind = \"impact\"); use 'hcv dt-crit' for sustained scenes"
        )
    rows = solve_scene(scene, rtol=rtol)
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
        print_transposed(
            scene_title("solve", scene),
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
