"""Adapters: plug a contact code into the suite (contract in `reference_impl.adapters.base`).

`get_adapter` resolves a registered name ("reference", "lammps", "kratos", ...), a
``package.module:Class`` import path or a ``cmd:COMMAND`` subprocess adapter.
`AdapterDeclined` is what an adapter raises to decline a scene at run time (a
skip, not a failure). The built-in codes' classes `KratosAdapter` and
`LammpsAdapter`, `MujocoAdapter` are importable from here; they are loaded on first use, and
loading them never imports Kratos, LAMMPS or MuJoCo (that happens when a run starts).
"""

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
    "MujocoAdapter",
    "PowerDamping",
    "LawDamping",
    "implemented_law_from_table",
    "Trajectory",
    "get_adapter",
    "register",
    "registered",
    "trajectory_from_mapping",
]

# Every name loads on first access (PEP 562): `import reference_impl.adapters.registry`
# (the names of the adapters, for ``hcv --help``) must not import numpy through the
# contract in `base`, and the built-in codes' modules load only when asked for.
_LAZY = {
    **dict.fromkeys(
        (
            "AdapterDeclined",
            "AdapterError",
            "AdapterOutputError",
            "AdapterRunError",
            "AdapterScene",
            "ContactAdapter",
            "ImplementedLaw",
            "PowerDamping",
            "Trajectory",
            "trajectory_from_mapping",
        ),
        ".base",
    ),
    **dict.fromkeys(("get_adapter", "register", "registered"), ".registry"),
    **dict.fromkeys(("LawDamping", "implemented_law_from_table"), ".law_damping"),
    "KratosAdapter": ".kratos",
    "LammpsAdapter": ".lammps",
    "MujocoAdapter": ".mujoco",
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
