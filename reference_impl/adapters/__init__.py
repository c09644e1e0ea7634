"""Adapters: plug a contact code into the suite (contract in `reference_impl.adapters.base`).

`get_adapter` resolves a registered name ("reference", "lammps", "kratos", ...), a
``package.module:Class`` import path or a ``cmd:COMMAND`` subprocess adapter.
`AdapterDeclined` is what an adapter raises to decline a scene at run time (a
skip, not a failure). The built-in codes' classes `KratosAdapter` and
`LammpsAdapter` are importable from here; they are loaded on first use, and
loading them never imports Kratos or LAMMPS (that happens when a run starts).
"""

from reference_impl.adapters.base import (
    AdapterDeclined,
    AdapterError,
    AdapterOutputError,
    AdapterRunError,
    AdapterScene,
    ContactAdapter,
    ImplementedLaw,
    PowerDamping,
    Trajectory,
    trajectory_from_mapping,
)
from reference_impl.adapters.registry import get_adapter, register, registered

__all__ = [
    "AdapterDeclined",
    "AdapterError",
    "AdapterOutputError",
    "AdapterRunError",
    "AdapterScene",
    "ContactAdapter",
    "ImplementedLaw",
    "KratosAdapter",
    "LammpsAdapter",
    "PowerDamping",
    "Trajectory",
    "get_adapter",
    "register",
    "registered",
    "trajectory_from_mapping",
]

# Classes of the built-in codes, imported on first access (PEP 562): their modules
# are light (the codes themselves load only when a run starts), but `import
# reference_impl.adapters` need not pay for them.
_LAZY = {
    "KratosAdapter": ".kratos",
    "LammpsAdapter": ".lammps",
}


def __getattr__(name: str):
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
