"""Registry of named adapters and resolution of adapter specs.

An adapter spec is one of

* a registered name: a built-in adapter of ``_REGISTRY`` (``reference``, ``subprocess`` and
  the contact codes, `builtin_codes`; `registered` lists them all, ``python -m
  reference_impl.adapters.registry names`` the codes), or a name a third-party package
  declares in the entry-point group
  ``hcv.adapters`` (as pytest plugins do), so that ``hcv bench mycode`` works after
  ``pip install mycode-hcv``::

      # pyproject.toml of mycode-hcv
      [project.entry-points."hcv.adapters"]
      mycode = "mycode_hcv.adapter:MyCodeAdapter"

* an import path ``package.module:Class`` of a `ContactAdapter` subclass;
* ``cmd:COMMAND``: the subprocess adapter running COMMAND (split like a shell
  does, see `reference_impl.adapters.subprocess`); ``cmd[key=value,...]:COMMAND``
  passes its other arguments (``sustained=true``, ``timeout=5``, ``label=...``).

Import paths are resolved with the current directory on the import path (as
pytest does with its rootdir), so ``my_adapter:MyCode`` finds ``./my_adapter.py``.

A name or an import path may end with constructor arguments in brackets,
``lammps[damping=tsuji,geometry=pair]``; values are read as int, float, true/
false, none, else as strings. A value an adapter lists in ``spec_values`` may be
given alone, as the scorecard prints its labels: ``kratos[hertz,verlet]`` is
``kratos[law=hertz,scheme=verlet]``, ``lammps[tsuji,limit_damping]`` is
``lammps[damping=tsuji,limit_damping=true]`` (`adapter_help` lists them). Every problem raises `HCVInputError` with one line
(the CLI exits with status 2).
"""

from __future__ import annotations

import importlib
import inspect
import os
import re
import sys
from typing import Any

from reference_impl.errors import HCVInputError


def _base():
    """`ContactAdapter`, imported on use: naming the adapters (``hcv --help``) imports none."""
    from reference_impl.adapters.base import ContactAdapter

    return ContactAdapter


__all__ = [
    "ENTRY_POINT_GROUP",
    "adapter_help",
    "apt_packages",
    "builtin_codes",
    "install_extras",
    "get_adapter",
    "parse_spec",
    "register",
    "registered",
    "resolve_class",
    "resolved_spec",
]

# The built-in adapters, in the order the report shows the codes (`builtin_codes`).
_REGISTRY: dict[str, str | type] = {
    "reference": "reference_impl.adapters.reference:ReferenceAdapter",
    "lammps": "reference_impl.adapters.lammps:LammpsAdapter",
    "liggghts": "reference_impl.adapters.liggghts:LiggghtsAdapter",
    "kratos": "reference_impl.adapters.kratos:KratosAdapter",
    "yade": "reference_impl.adapters.yade:YadeAdapter",
    "mujoco": "reference_impl.adapters.mujoco:MujocoAdapter",
    "drake": "reference_impl.adapters.drake:DrakeAdapter",
    "pybullet": "reference_impl.adapters.pybullet:PybulletAdapter",
    "subprocess": "reference_impl.adapters.subprocess:SubprocessAdapter",
}
_BUILTIN = tuple(_REGISTRY)  # names registered at import, before any `register` call
_SPEC_RE = re.compile(r"^(?P<target>[^\[\]]+?)(?:\[(?P<args>.*)\])?$", re.S)
_IMPORT_RE = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")
_NAME_RE = re.compile(r"^[A-Za-z][\w-]*$")
_CMD_RE = re.compile(r"^cmd(?:\[(?P<args>[^\]]*)\])?:")
# Longest adapter spec accepted (characters): a command line, not a file.
_MAX_SPEC = 4096


def register(name: str, target: str | type) -> None:
    """Register an adapter class (or its ``package.module:Class`` path) under ``name``."""
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise HCVInputError(f"adapter name must be letters, digits, '-' or '_', got {name!r}")
    if isinstance(target, type) and not issubclass(target, _base()):
        raise HCVInputError(f"{target!r} is not a ContactAdapter subclass")
    _REGISTRY[name] = target


ENTRY_POINT_GROUP = "hcv.adapters"


def _entry_points() -> dict[str, str]:
    """name -> ``module:attr`` of the installed packages' ``hcv.adapters`` entry points.

    Read at each call (cheap: metadata only, nothing imported), so a package installed
    while a process runs is seen. A name that a built-in adapter already has is ignored:
    built-ins cannot be replaced by an installed package.
    """
    from importlib.metadata import entry_points

    found = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name not in _REGISTRY and _NAME_RE.match(ep.name) and _IMPORT_RE.match(ep.value):
            found.setdefault(ep.name, ep.value)
    return found


def registered() -> list[str]:
    """The registered adapter names (built-in, `register`-ed and entry points), sorted."""
    return sorted({*_REGISTRY, *_entry_points()})


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
    if len(spec) > _MAX_SPEC:
        raise HCVInputError(f"adapter spec of {len(spec)} characters; at most {_MAX_SPEC}")
    spec = spec.strip()
    cmd = _CMD_RE.match(spec)
    if cmd:
        command = spec[cmd.end() :].strip()
        if not command:
            raise HCVInputError("adapter spec 'cmd:' needs a command, e.g. 'cmd:python my_code.py'")
        kwargs = _kwargs(cmd.group("args") or "", spec)
        if "command" in kwargs:
            raise HCVInputError(f"adapter spec {spec!r}: the command goes after 'cmd[...]:'")
        return "subprocess", {"command": command, **kwargs}
    m = _SPEC_RE.match(spec)
    if not m:
        raise HCVInputError(
            f"adapter spec {spec!r} is malformed; use NAME, NAME[key=value,...], "
            "package.module:Class or cmd:COMMAND"
        )
    return m.group("target").strip(), _kwargs(m.group("args") or "", spec, bare_ok=True)


# Key under which `parse_spec` hands bare values (no "=") to `get_adapter`.
_BARE = "__bare__"


def _kwargs(text: str, spec: str, bare_ok: bool = False) -> dict[str, Any]:
    """``key=value,...`` as keyword arguments (a repeated key is refused); with
    ``bare_ok`` values without a key are kept under `_BARE` for `get_adapter`."""
    kwargs: dict[str, Any] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        key, sep, val = part.partition("=")
        key = key.strip()
        if not sep and bare_ok and key:
            kwargs.setdefault(_BARE, []).append(key)
            continue
        if not sep or not key.isidentifier():
            raise HCVInputError(f"adapter argument {part!r} in {spec!r} must be key=value")
        if key in kwargs:
            raise HCVInputError(f"adapter argument {key!r} repeats in {spec!r}")
        kwargs[key] = _value(val)
    return kwargs


def _import(path: str) -> type:
    mod_name, _, cls_name = path.partition(":")
    cwd = os.getcwd()
    if cwd not in sys.path and "" not in sys.path:  # as pytest's rootdir: ./my_adapter.py
        sys.path.insert(0, cwd)
    try:
        module = importlib.import_module(mod_name)
    except ImportError as exc:
        raise HCVInputError(
            f"adapter {path!r}: cannot import module {mod_name!r} ({exc}); the "
            f"current directory {cwd} is on the import path, else set "
            "PYTHONPATH"
        ) from None
    cls = getattr(module, cls_name, None)
    if cls is None:
        raise HCVInputError(f"adapter {path!r}: module {mod_name!r} has no attribute {cls_name!r}")
    if not (isinstance(cls, type) and issubclass(cls, _base())):
        raise HCVInputError(
            f"adapter {path!r} is not a ContactAdapter subclass "
            "(see reference_impl.adapters.base for the contract)"
        )
    return cls


def resolve_class(target: str) -> type:
    """The adapter class of a registered name or an import path."""
    if target in _REGISTRY:
        entry = _REGISTRY[target]
        return _import(entry) if isinstance(entry, str) else entry
    plugin = _entry_points().get(target)
    if plugin is not None:
        return _import(plugin)
    if _IMPORT_RE.match(target):
        return _import(target)
    raise HCVInputError(
        f"unknown adapter {target!r}; registered: {', '.join(registered())}; "
        "or give package.module:Class or cmd:COMMAND"
    )


def resolved_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """``(target, kwargs)`` of a spec with its bare values mapped to their keys
    (``mujoco[timeconst,Euler]`` -> ``{"solref": "timeconst", "integrator": "Euler"}``)."""
    target, kwargs = parse_spec(spec)
    if _BARE in kwargs:
        _resolve_bare(resolve_class(target), kwargs, spec)
    return target, kwargs


def get_adapter(spec):
    """Build the adapter for a spec (or return an adapter instance unchanged)."""
    if isinstance(spec, _base()):
        return spec
    target, kwargs = parse_spec(spec)
    cls = resolve_class(target)
    _resolve_bare(cls, kwargs, spec)
    missing = _missing_arguments(cls, kwargs)
    if missing:
        hint = (
            "; use cmd:COMMAND, e.g. cmd:./my_code"
            if "command" in missing
            else f"; give {target}[{'=...,'.join(missing)}=...]"
        )
        raise HCVInputError(f"adapter {target!r} needs the argument(s) {', '.join(missing)}{hint}")
    try:
        return cls(**kwargs)
    except HCVInputError:
        raise
    except TypeError as exc:
        raise HCVInputError(f"adapter {spec!r}: bad arguments ({exc})") from None


def _resolve_bare(cls: type, kwargs: dict, spec: str) -> None:
    """Map values given alone (``kratos[hertz,verlet]``) to their keys (``spec_values``)."""
    values = getattr(cls, "spec_values", {}) or {}
    for v in kwargs.pop(_BARE, []):
        keys = [
            k
            for k, allowed in values.items()
            if (allowed is True and v == k) or (allowed is not True and v in allowed)
        ]
        if len(keys) != 1:
            known = "; ".join(_values_text(k, a) for k, a in values.items())
            raise HCVInputError(
                f"adapter argument {v!r} in {spec!r} must be key=value"
                + (f" or one of the values {known}" if known else "")
                + (f" ({v!r} is a value of several keys)" if len(keys) > 1 else "")
            )
        key = keys[0]
        if key in kwargs:
            raise HCVInputError(f"adapter argument {key!r} repeats in {spec!r}")
        kwargs[key] = True if values[key] is True else v


def _values_text(key: str, allowed) -> str:
    return f"{key} (flag)" if allowed is True else f"{key} = {' | '.join(map(str, allowed))}"


def adapter_help() -> str:
    """One line per registered adapter: its keys and the values they take (``--help``)."""
    lines = []
    for name in registered():
        try:
            cls = resolve_class(name)
        except HCVInputError:
            continue
        values = getattr(cls, "spec_values", {}) or {}
        keys = "; ".join(_values_text(k, a) for k, a in values.items())
        lines.append(f"  {name}: {keys}" if keys else f"  {name}")
    lines.append(
        "  cmd[sustained=true,persistent=true,timeout=S,label=NAME,cwd=DIR,"
        "time_scheme=S,claimed_order=N,scheme_rtol=R,assembly=chain+lattice,advice=true,"
        "OPTION=V]:COMMAND"
    )
    return "\n".join(lines)


def _missing_arguments(cls: type, kwargs: dict) -> list[str]:
    """Required constructor parameters of ``cls`` not in ``kwargs``."""
    try:
        params = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):
        return []
    return [
        p.name
        for p in params
        if p.default is inspect.Parameter.empty
        and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
        and p.name not in kwargs
    ]


def builtin_codes() -> dict:
    """name -> `CodeInfo` of every built-in adapter of a contact code (contract item 13).

    The one list of the codes: the report's side-by-side variants, the install lines of
    CI and nox, and the test that every code has its test module, marker and docs row
    are all made from it. Imports the adapters' modules (never the codes themselves).
    """
    out = {}
    for name in _BUILTIN:
        info = getattr(resolve_class(name), "code_info", None)
        if info is not None:
            out[name] = info
    return out


def install_extras() -> list[str]:
    """The pip extras that install the built-in codes (``.ci/run``, ``noxfile.py``)."""
    return [i.extra for i in builtin_codes().values() if i.extra]


def apt_packages() -> list[str]:
    """The Debian packages that install the built-in codes (``.ci/run``)."""
    return [i.apt for i in builtin_codes().values() if i.apt]


if __name__ == "__main__":  # ``python -m reference_impl.adapters.registry extras|apt|names``
    _what = {"extras": install_extras, "apt": apt_packages, "names": lambda: list(builtin_codes())}
    if len(sys.argv) != 2 or sys.argv[1] not in _what:
        sys.exit(f"usage: python -m reference_impl.adapters.registry {'|'.join(_what)}")
    print(" ".join(_what[sys.argv[1]]()))
