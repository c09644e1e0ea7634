"""Scenes: validated descriptions of what to compute (see `_scene` for the file format).

Embedded scenes ship as ``*.toml`` files in this package; list them with
`embedded_scenes` and load one by name with `load_scene`.
"""

from reference_impl.scenes._scene import (
    Scene,
    embedded_scenes,
    load_scene,
    parse_scene,
    potential_to_dict,
    scene_from_dict,
    scene_toml,
)

__all__ = [
    "Scene",
    "embedded_scenes",
    "load_scene",
    "parse_scene",
    "potential_to_dict",
    "scene_from_dict",
    "scene_toml",
]
