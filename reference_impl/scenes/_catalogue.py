"""The names of the embedded scenes, without importing the potentials (``hcv scenes`` is instant)."""

from __future__ import annotations

from importlib import resources

__all__ = ["embedded_scenes"]


def embedded_scenes() -> list[str]:
    """Names of the scenes shipped with the package (``load_scene(name)`` loads one)."""
    root = resources.files(__package__)
    return sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))
