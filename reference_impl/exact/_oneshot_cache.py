"""What a one-shot call plans once per (potential, law) instead of once per call (issue 38).

Measured (2026-11-29, one process, Hertz k = 1e6, m = 0.1, warm): a one-shot
`solve_law_impact` with a linear dashpot spent ~12 us of ~38 us planning (reading the law's
table into a `DampingLaw`, its kernel arrays, the creep test, the linear case), work
that depends on (potential, m, law, rtol) and never on the speed. The caches here keep
that work, bounded and thread-safe, so that a loop of distinct speeds through the
one-shot calls pays it once:

* `cached_law`: a law's table (a dict, the form users and scenes give) read into its
  `DampingLaw`, keyed by the table's exact value (`value_key`);
* `BoundedCache`: a least-recently-used map under a lock, for the general-law plans
  (`reference_impl.exact.general_law`).

A key is the exact value of what the result depends on, never an approximation: floats by
their bits (two floats one ulp apart are different keys; equal floats have the same bits
but for the sign of zero, so a float is keyed by its value and a zero by `float.hex`:
-0.0 and 0.0 are different keys; a NaN matches only itself, the same object),
the type beside every value (1, 1.0 and True are different keys: the law's checks may
refuse one of them), and the law's registered family class (a law unregistered and
registered again is planned again). Only successes are kept; a refused input raises its
one-line error every time. A value that has no such key (an object, a numpy array) is
not cached: it is planned each call, as before.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

from reference_impl.exact._law_table import fast_law
from reference_impl.theory.laws import DampingLaw, law_from_dict
from reference_impl.theory.laws._registry import LAWS

__all__ = ["BoundedCache", "cached_law", "law_key", "value_key"]

# Laws and plans kept: a program alternates between a few laws and potentials; 64 keeps
# them all while bounding the memory (each entry a few hundred bytes, a plan also holds
# its potential alive until it is evicted).
KEPT = 64

_SCALARS = (int, str, bool, type(None))


def value_key(value):
    """A hashable key equal only for values the checks and the solvers read the same, or
    None when ``value`` has none (then it is not cached).

    Floats (Python and numpy) by type and bits, ints, strings, bools and None by type and
    value, tuples and lists by type and their items' keys, dicts by their (key, value key)
    pairs in their order (the order a law's table is read in; string keys only).
    """
    if isinstance(value, float):
        # By value (equal floats, zeros aside, have equal bits): float.hex was ~1/5 of a
        # one-shot call's planning with a new law each call.
        return (type(value), value) if value else (type(value), float.hex(value))
    t = type(value)
    if t in _SCALARS:
        return (t, value)
    if t is tuple or t is list:
        items = tuple(value_key(v) for v in value)
        return None if None in items else (t, items)
    if t is dict:
        items = []
        for k, v in value.items():
            if type(k) is not str:
                return None
            tv = type(v)
            # Inline for the common str -> float or str entry (a law's table; ~2x faster).
            vk = (tv, v) if (tv is float and v) or tv is str else value_key(v)
            if vk is None:
                return None
            items.append((k, vk))
        return (t, tuple(items))
    return None


def law_key(law):
    """The key of a damping law given as a table or a `DampingLaw` (None: not cached).

    A `DampingLaw` is keyed by its name, checked parameters and family class, so that the
    fresh instance `reference_impl.exact._route.route` builds on every call finds the plan
    of an equal law; a table by its exact value and the family registered under its name.
    """
    if isinstance(law, DampingLaw):
        params = value_key(law.params)
        if params is None:
            return None
        return (DampingLaw, law.name, LAWS._classes.get(law.name), params)
    if type(law) is not dict:
        return None
    table = value_key(law)
    if table is None:
        return None
    name = law.get("law", "none")
    return (dict, LAWS._classes.get(name) if type(name) is str else None, table)


class BoundedCache:
    """A least-recently-used map of at most ``size`` entries, safe to share between threads.

    `get` and `put` hold one lock for their few dict operations; a value is built outside
    it, so two threads missing the same key may both build it (the same value: the key is
    the whole input) and the second `put` keeps one.
    """

    __slots__ = ("_size", "_data", "_lock")

    def __init__(self, size: int = KEPT):
        self._size = size
        self._data: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key):
        """The value kept for ``key`` (marked most recently used), or None."""
        with self._lock:
            value = self._data.get(key)
            if value is not None:
                self._data.move_to_end(key)
            return value

    def put(self, key, value) -> None:
        """Keep ``value`` for ``key``, evicting the least recently used beyond the size."""
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self._size:
                self._data.popitem(last=False)

    def clear(self) -> None:
        """Forget every entry (tests)."""
        with self._lock:
            self._data.clear()

    def __len__(self) -> int:
        return len(self._data)


_LAWS = BoundedCache()


def cached_law(law, *, where: str = "damping") -> DampingLaw:
    """`law_from_dict(law, where=where)`, the table read once per exact value (`law_key`).

    Raises
    ------
    HCVInputError
        As `law_from_dict` (nothing is kept for a refused table).
    """
    if isinstance(law, DampingLaw):
        return law
    key = law_key(law)
    if key is None:
        return law_from_dict(law, where=where)
    got = _LAWS.get(key)
    if got is None:
        # the plain table without the generic layers, equal; law_from_dict builds or refuses the rest
        got = fast_law(law) or law_from_dict(law, where=where)
        _LAWS.put(key, got)
    return got
