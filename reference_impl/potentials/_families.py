"""The registry of scene families: ``[potential] family = NAME`` -> its Potential class.

A family describes itself on its class (``family``, ``scene_keys``, ``label``,
``from_scene``, ``scene_params``; see `reference_impl.potentials.base.Potential`), so the
scene parser, ``hcv scenes``, the report and the adapter request read it from there. A new
family is one module whose class is decorated with `register_family`, imported once by
``reference_impl/potentials/__init__.py`` (or by the user's own code before a scene names it).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping

from reference_impl.errors import HCVInputError
from reference_impl.potentials.base import Potential

__all__ = ["FAMILIES", "register_family", "register_lazy_family", "unregister_family"]


class _Families(Mapping):
    """name -> class; a family registered lazily (its module named, not imported) is
    imported on first look-up, so that naming the families imports none of them."""

    def __init__(self) -> None:
        self._classes: dict[str, type[Potential]] = {}
        self._lazy: dict[str, str] = {}

    def __getitem__(self, name: str) -> type[Potential]:
        if name not in self._classes and name in self._lazy:
            importlib.import_module(self._lazy[name])  # its @register_family runs
        return self._classes[name]

    def __contains__(self, name) -> bool:
        return name in self._classes or name in self._lazy

    def __iter__(self) -> Iterator[str]:
        return iter(dict.fromkeys([*self._classes, *self._lazy]))

    def __len__(self) -> int:
        return len(set(self._classes) | set(self._lazy))


FAMILIES = _Families()


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
    have = FAMILIES._classes.get(name)
    if have is not None and have is not cls:
        raise HCVInputError(
            f"register_family: family {name!r} is already {have.__module__}.{have.__qualname__}"
        )
    required, optional = cls.scene_keys
    if "family" in (*required, *optional):
        raise HCVInputError(f"register_family: {cls.__name__}.scene_keys may not use 'family'")
    FAMILIES._classes[name] = cls
    FAMILIES._lazy.pop(name, None)
    return cls


def register_lazy_family(name: str, module: str) -> None:
    """Name a family whose module registers it when imported (on its first look-up)."""
    if name not in FAMILIES._classes:
        FAMILIES._lazy[name] = module


def unregister_family(name: str) -> None:
    """Remove a family (for tests that define one)."""
    FAMILIES._classes.pop(name, None)
    FAMILIES._lazy.pop(name, None)
