"""Scenes: validated descriptions of what to compute (see `_scene` for the file format).

Embedded scenes ship as ``*.toml`` files in this package; list them with
`embedded_scenes` and load one by name with `load_scene`.
"""

from reference_impl.scenes._catalogue import embedded_scenes

# The scene parser imports the potentials (sympy); it loads on first use of its names
# (PEP 562), so listing the catalogue (`hcv scenes`) imports nothing numerical.
_FROM_SCENE = (
    "AssemblyScene",
    "Scene",
    "load_scene",
    "parse_scene",
    "potential_to_dict",
    "scene_from_dict",
    "scene_show",
    "scene_toml",
)

__all__ = [
    "AssemblyScene",
    "Scene",
    "embedded_scenes",
    "law_for_restitution",
    "load_scene",
    "parse_scene",
    "potential_to_dict",
    "scene_from_dict",
    "scene_show",
    "scene_toml",
]


def __getattr__(name: str):
    if name == "law_for_restitution":  # the one solve-to-restitution of a damping law
        from reference_impl.scenes._law_restitution import law_for_restitution

        return law_for_restitution
    if name in _FROM_SCENE:
        from reference_impl.scenes import _scene

        return getattr(_scene, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
