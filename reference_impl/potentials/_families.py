"""The registry of scene families: ``[potential] family = NAME`` -> its Potential class.

A family describes itself on its class (``family``, ``scene_keys``, ``label``,
``from_scene``, ``scene_params``; see `reference_impl.potentials.base.Potential`), so the
scene parser, ``hcv scenes``, the report and the adapter request read it from there. A new
family is one module whose class is decorated with `register_family`, imported once by
``reference_impl/potentials/__init__.py`` (or by the user's own code before a scene names it).
"""

from __future__ import annotations

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential

__all__ = ["FAMILIES", "register_family", "unregister_family"]

FAMILIES: dict[str, type[Potential]] = {}


def register_family(cls: type[Potential]) -> type[Potential]:
    """Class decorator: make ``cls`` the scene family ``cls.family``.

    Raises
    ------
    HCVInputError
        ``cls`` is not a Potential subclass, names no family, or takes a name already
        registered by another class.
    """
    if not (isinstance(cls, type) and issubclass(cls, Potential)):
        raise HCVInputError(f"register_family: {cls!r} is not a Potential subclass")
    name = getattr(cls, "family", None)
    if not (isinstance(name, str) and name.strip()):
        raise HCVInputError(f"register_family: {cls.__name__}.family must name the family")
    have = FAMILIES.get(name)
    if have is not None and have is not cls:
        raise HCVInputError(
            f"register_family: family {name!r} is already {have.__module__}.{have.__qualname__}"
        )
    required, optional = cls.scene_keys
    if "family" in (*required, *optional):
        raise HCVInputError(f"register_family: {cls.__name__}.scene_keys may not use 'family'")
    FAMILIES[name] = cls
    return cls


def unregister_family(name: str) -> None:
    """Remove a family (for tests that define one)."""
    FAMILIES.pop(name, None)
