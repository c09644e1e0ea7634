"""The names of the embedded scenes, without importing the potentials (``hcv scenes`` is instant)."""

from __future__ import annotations

from importlib import resources

__all__ = ["catalogue_rows", "embedded_scenes"]


def embedded_scenes() -> list[str]:
    """Names of the scenes shipped with the package (``load_scene(name)`` loads one)."""
    root = resources.files(__package__)
    return sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))


def catalogue_rows() -> list[dict]:
    """One summary per embedded scene (name, kind, family, mass, speeds, damping), read from
    its TOML text alone: no potential is built, so listing stays free of numerical imports.
    The files are the package's own and are validated by `load_scene` when used."""
    import tomllib

    root = resources.files(__package__)
    rows = []
    for name in embedded_scenes():
        data = tomllib.loads((root / f"{name}.toml").read_text(encoding="utf-8"))
        damping = data.get("damping", {})
        rows.append(
            {
                "name": name,
                "kind": data.get("kind", "impact"),
                "family": data.get("potential", {}).get("family", "?"),
                "mass": data.get("mass"),
                "velocities": list(data.get("velocities", [])),
                "damping": damping.get("law", "none"),
                "damping_params": {k: v for k, v in damping.items() if k != "law"},
            }
        )
    return rows
