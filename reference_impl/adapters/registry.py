"""Registry of named adapters and resolution of adapter specs.

An adapter spec is one of

* a registered name: ``reference``, ``lammps``, ``subprocess`` (see `registered`);
* an import path ``package.module:Class`` of a `ContactAdapter` subclass;
* ``cmd:COMMAND``: the subprocess adapter running COMMAND (split like a shell
  does, see `reference_impl.adapters.subprocess`).

A name or an import path may end with constructor arguments in brackets,
``lammps[damping=tsuji,geometry=pair]``; values are read as int, float, true/
false, none, else as strings. Every problem raises `HCVInputError` with one line
(the CLI exits with status 2).
"""

from __future__ import annotations

import importlib
import re
from typing import Any

from ..errors import HCVInputError
from .base import ContactAdapter

__all__ = ["get_adapter", "parse_spec", "register", "registered", "resolve_class"]

_REGISTRY: dict[str, str | type] = {
    "reference": "reference_impl.adapters.reference:ReferenceAdapter",
    "lammps": "reference_impl.adapters.lammps:LammpsAdapter",
    "kratos": "reference_impl.adapters.kratos:KratosAdapter",
    "subprocess": "reference_impl.adapters.subprocess:SubprocessAdapter",
}
_SPEC_RE = re.compile(r"^(?P<target>[^\[\]]+?)(?:\[(?P<args>.*)\])?$", re.S)
_IMPORT_RE = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")
_NAME_RE = re.compile(r"^[A-Za-z][\w-]*$")


def register(name: str, target: str | type) -> None:
    """Register an adapter class (or its ``package.module:Class`` path) under ``name``."""
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise HCVInputError(f"adapter name must be letters, digits, '-' or '_', got {name!r}")
    if isinstance(target, type) and not issubclass(target, ContactAdapter):
        raise HCVInputError(f"{target!r} is not a ContactAdapter subclass")
    _REGISTRY[name] = target


def registered() -> list[str]:
    """The registered adapter names, sorted."""
    return sorted(_REGISTRY)


def _value(text: str) -> Any:
    t = text.strip()
    low = t.lower()
    if low in ("true", "yes"):
        return True
    if low in ("false", "no"):
        return False
    if low in ("none", "null"):
        return None
    for conv in (int, float):
        try:
            return conv(t)
        except ValueError:
            pass
    return t


def parse_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """Split ``target[key=value,...]`` into the target and keyword arguments."""
    if not isinstance(spec, str) or not spec.strip():
        raise HCVInputError(f"adapter spec must be a non-empty string, got {spec!r}")
    spec = spec.strip()
    if spec.startswith("cmd:"):
        command = spec[4:].strip()
        if not command:
            raise HCVInputError("adapter spec 'cmd:' needs a command, e.g. 'cmd:python my_code.py'")
        return "subprocess", {"command": command}
    m = _SPEC_RE.match(spec)
    if not m:
        raise HCVInputError(f"adapter spec {spec!r} is malformed; use NAME, NAME[key=value,...], "
                            "package.module:Class or cmd:COMMAND")
    kwargs: dict[str, Any] = {}
    for part in filter(None, (p.strip() for p in (m.group("args") or "").split(","))):
        key, sep, val = part.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise HCVInputError(f"adapter argument {part!r} in {spec!r} must be key=value")
        kwargs[key] = _value(val)
    return m.group("target").strip(), kwargs


def _import(path: str) -> type:
    mod_name, _, cls_name = path.partition(":")
    try:
        module = importlib.import_module(mod_name)
    except ImportError as exc:
        raise HCVInputError(f"adapter {path!r}: cannot import module {mod_name!r} ({exc})") from None
    cls = getattr(module, cls_name, None)
    if cls is None:
        raise HCVInputError(f"adapter {path!r}: module {mod_name!r} has no attribute {cls_name!r}")
    if not (isinstance(cls, type) and issubclass(cls, ContactAdapter)):
        raise HCVInputError(f"adapter {path!r} is not a ContactAdapter subclass "
                            "(see reference_impl.adapters.base for the contract)")
    return cls


def resolve_class(target: str) -> type:
    """The adapter class of a registered name or an import path."""
    if target in _REGISTRY:
        entry = _REGISTRY[target]
        return _import(entry) if isinstance(entry, str) else entry
    if _IMPORT_RE.match(target):
        return _import(target)
    raise HCVInputError(f"unknown adapter {target!r}; registered: {', '.join(registered())}; "
                        "or give package.module:Class or cmd:COMMAND")


def get_adapter(spec: str | ContactAdapter) -> ContactAdapter:
    """Build the adapter for a spec (or return an adapter instance unchanged)."""
    if isinstance(spec, ContactAdapter):
        return spec
    target, kwargs = parse_spec(spec)
    cls = resolve_class(target)
    try:
        return cls(**kwargs)
    except HCVInputError:
        raise
    except TypeError as exc:
        raise HCVInputError(f"adapter {spec!r}: bad arguments ({exc})") from None
