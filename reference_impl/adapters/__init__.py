"""Adapters: plug a contact code into the suite (contract in `reference_impl.adapters.base`).

`get_adapter` resolves a registered name ("reference", "lammps", ...), a
``package.module:Class`` import path or a ``cmd:COMMAND`` subprocess adapter.
"""

from .base import (
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
from .registry import get_adapter, register, registered

__all__ = [
    "AdapterError",
    "AdapterOutputError",
    "AdapterRunError",
    "AdapterScene",
    "ContactAdapter",
    "ImplementedLaw",
    "PowerDamping",
    "Trajectory",
    "get_adapter",
    "register",
    "registered",
    "trajectory_from_mapping",
]
