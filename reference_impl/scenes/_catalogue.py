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
        mass, vels = data.get("mass"), data.get("velocities", [])
        rows.append(
            {
                "name": name,
                "kind": data.get("kind", "impact"),
                "family": data.get("potential", {}).get("family", "?"),
                # an assembly may list a mass and a velocity per body: the striker's (first)
                "mass": mass[0] if isinstance(mass, list) else mass,
                "velocities": list(vels) if isinstance(vels, list) else [vels],
                "assembly": _assembly_summary(data),
                "damping": damping.get("law", "none"),
                "damping_params": {k: v for k, v in damping.items() if k != "law"},
            }
        )
    return rows


def _assembly_summary(data: dict) -> str | None:
    """A chain's or lattice's shape in a few words (None for a single-contact scene)."""
    kind = data.get("kind")
    bonded = " bonded" if data.get("bonded") else ""
    if kind == "chain":
        return f"n={data.get('n')} walls={data.get('walls', 'none')}{bonded}"
    if kind == "lattice":
        box = "periodic" if data.get("periodic", True) else "walled"
        extra = ""
        if data.get("tangential_ratio"):
            extra = f" kt/k={data['tangential_ratio']}" + (
                " rotation" if data.get("rotation") else ""
            )
        return f"{data.get('lattice')} cells={data.get('cells')} {box}{bonded}{extra}"
    return None
