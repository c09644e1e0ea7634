"""Writing a benchmark's JSON record: whole or not at all, numpy scalars as numbers.

Every `benchmarks/bench_*.py --json FILE` writes through `write_json`, so a record is never
half written (a crash or Ctrl-C leaves the previous one) and its parent folder is made.
"""

from __future__ import annotations

import json

import numpy as np

from reference_impl._atomic import atomic_write

__all__ = ["write_json"]


def _numbers(x):
    """JSON form of the numpy scalars and arrays a record holds; anything else is an error."""
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON: {x!r}")


def write_json(path, record, *, default=_numbers) -> None:
    """Write ``record`` to ``path`` as indented JSON, atomically (`atomic_write`).

    Parameters
    ----------
    path : str or os.PathLike
        The record's file; its parent folder is created when missing.
    record : dict
        The benchmark's result.
    default : callable, optional
        ``json.dumps``'s ``default`` for values JSON does not know (numpy scalars and
        arrays by default).
    """
    atomic_write(path, json.dumps(record, indent=2, default=default) + "\n")
