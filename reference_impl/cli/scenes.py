"""``hcv scenes [--show NAME | --laws]``: the scene catalogue, one scene as TOML, or the
damping laws a scene may name (the registry, `reference_impl.theory.laws`)."""

from __future__ import annotations

from reference_impl.cli._run import EXIT_OK
from reference_impl.scenes._catalogue import catalogue_rows

__all__ = ["add_parser", "run"]


def add_parser(subparsers) -> None:
    """Add the ``scenes`` subcommand to an argparse subparsers object."""
    ls = subparsers.add_parser(
        "scenes",
        help="list the scene catalogue (the same names work in every command); "
        "--show NAME prints one as TOML",
    )
    which = ls.add_mutually_exclusive_group()
    which.add_argument(
        "--show",
        metavar="NAME",
        help="print this scene's TOML (a catalogue name or a file), and the strength solved "
        "for a restitution asked at a speed",
    )
    which.add_argument(
        "--laws",
        action="store_true",
        help="list the damping laws a scene's [damping] law may name, with their parameters",
    )
    ls.set_defaults(func=run)


def run(args) -> int:
    """Print the catalogue, one scene a line, or with ``--show`` one scene's TOML (and,
    for a law solved from a restitution at a speed, a ``# solved:`` line after it)."""

    if getattr(args, "laws", False):
        from reference_impl.theory.laws import LAWS

        for fam in LAWS.values():
            name, params, formula, how = (c.replace("`", "") for c in fam.docs_row())
            print(f"{name:14s} C = {formula}; parameters: {params or 'none'}; {how}")
        return EXIT_OK
    if args.show:
        from reference_impl.scenes import scene_show

        print(scene_show(args.show), end="")
        return EXIT_OK
    for r in catalogue_rows():
        params = " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                          for k, v in r["damping_params"].items())  # fmt: skip
        print(
            f"{r['name']:24s} {r['kind']:10s} {r['family']:11s} m={r['mass']:.4g} kg  "
            f"v0={r['velocities']} m/s  damping {r['damping']}"
            + (f" {params}" if params else "")
            + (f"  [{r['assembly']}]" if r.get("assembly") else "")
        )
    return EXIT_OK
