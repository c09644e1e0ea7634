"""Tool tests of the table store (`reference_impl._stored`, issue 20).

A table read back from the disk is bit for bit the one computed; an entry that is damaged,
of the wrong length or not ours is computed afresh; an unwritable store only means the
table is not kept; the store is bounded; and the key changes with what the table depends on.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from reference_impl import _stored
from reference_impl.exact._branches import _jacobi_pair, _jacobi_rules
from verification.assertions import assert_true

CALLS: list[tuple] = []


def _table(a: float, n: int) -> list[float]:
    CALLS.append((a, n))
    return [a / (k + 3.0) for k in range(n)]


def _other_formula(a: float, n: int) -> list[float]:
    CALLS.append((a, n))
    return [a / (k + 7.0) for k in range(n)]


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("HCV_CACHE_DIR", str(tmp_path))
    CALLS.clear()
    return tmp_path / "tables"


def test_read_back_is_bit_for_bit_and_computed_once(store):
    first = _stored.stored_floats("t", (0.1, 9), _table, 9)
    second = _stored.stored_floats("t", (0.1, 9), _table, 9)
    assert_true(
        first == second == _table(0.1, 9) and len(CALLS) == 2 and len(list(store.iterdir())) == 1,
        got=f"{len(CALLS) - 1} computations, {len(list(store.iterdir()))} files",
        should="one computation and one file, equal values",
        claim="tool",
        call="stored_floats twice",
    )


@pytest.mark.parametrize(
    "content", ["", "[1, 2", '["0x1p+0"]', '{"a": 1}', json.dumps(["nan"] * 9), "\x00\xff"]
)
def test_a_damaged_or_foreign_entry_is_computed_afresh(store, content):
    _stored.stored_floats("t", (0.1, 9), _table, 9)
    (entry,) = store.iterdir()
    entry.write_text(content, encoding="latin-1")
    got = _stored.stored_floats("t", (0.1, 9), _table, 9)
    assert_true(
        got == _table(0.1, 9) and len(CALLS) == 3,
        got=f"{got[:2]}..., {len(CALLS) - 1} computations",
        should="the computed values, computed again",
        claim="tool",
        call=f"stored_floats over an entry {content[:12]!r}",
    )


def test_a_planted_large_entry_is_not_read_whole(store):
    _stored.stored_floats("t", (0.1, 9), _table, 9)
    (entry,) = store.iterdir()
    with entry.open("w") as fh:  # 50 MB of valid-looking JSON where 9 values belong
        fh.write("[" + ", ".join(['"0x1p+0"'] * 5_000_000) + "]")
    got = _stored.stored_floats("t", (0.1, 9), _table, 9)
    assert_true(
        got == _table(0.1, 9) and len(CALLS) == 3,
        got=f"{got[:2]}..., {len(CALLS) - 1} computations",
        should="the table computed afresh (the entry is too long to be ours)",
        claim="tool",
        call="stored_floats over a 50 MB entry",
    )


def test_an_unwritable_store_still_returns_the_table(store):
    store.parent.mkdir(exist_ok=True)
    store.write_text("a file where the directory should be")
    got = _stored.stored_floats("t", (0.1, 9), _table, 9)
    assert got == _table(0.1, 9), f"got {got}, should be the computed table [tool, stored_floats]"


def test_the_key_follows_the_arguments_and_the_formula(store):
    _stored.stored_floats("t", (0.1, 9), _table, 9)
    _stored.stored_floats("t", (float(np.nextafter(0.1, 1.0)), 9), _table, 9)  # next float
    c = _stored.stored_floats("t", (0.1, 9), _other_formula, 9)
    assert_true(
        len(CALLS) == 3 and c == _other_formula(0.1, 9) and len(list(store.iterdir())) == 3,
        got=f"{len(CALLS)} computations, {len(list(store.iterdir()))} files",
        should="three computations and entries (other argument, other formula)",
        claim="tool",
        call="stored_floats with changed arguments and formula",
    )


def test_the_store_is_bounded(store, monkeypatch):
    monkeypatch.setattr(_stored, "MAX_ENTRIES", 5)
    for i in range(12):
        _stored.stored_floats("t", (float(i), 3), _table, 3)
    n = len(list(store.glob("*.json")))
    assert_true(
        n <= 5,
        got=f"{n} entries",
        should="at most MAX_ENTRIES = 5",
        claim="tool",
        call="stored_floats of 12 tables",
    )


def test_a_wrong_computation_is_refused_not_stored(store):
    with pytest.raises(ValueError, match="expected 4 finite values"):
        _stored.stored_floats("t", (0.1, 3), _table, 4)
    assert not store.exists() or not list(store.iterdir())


@pytest.mark.parametrize("beta", [-0.5, -0.2, 0.0, 1.0 / 3.0, 1.7])
def test_gauss_jacobi_rules_from_the_store_equal_the_computed_ones(store, beta):
    """The solver's rules, computed (first call) or read back (a new lru entry): bit for
    bit `_jacobi_rules` (mpmath, correctly rounded), and scipy's roots_jacobi within its
    own accuracy (an independent check that they are the Gauss-Jacobi rules)."""
    from scipy.special import roots_jacobi

    sizes = (16, 24)
    _jacobi_pair.cache_clear()
    computed = _jacobi_pair(beta, sizes)
    _jacobi_pair.cache_clear()
    read = _jacobi_pair(beta, sizes)
    flat = _jacobi_rules(beta, sizes)
    u, w = np.array(flat[:40]), np.array(flat[40:])
    ok = all(
        np.array_equal(x[0], u)
        and np.array_equal(x[1][:16, 0], w[:16])
        and np.array_equal(x[1][16:, 1], w[16:])
        and not x[1][16:, 0].any()
        and not x[1][:16, 1].any()
        for x in (computed, read)
    )
    y0, w0 = roots_jacobi(16, 0.0, beta)
    y1, w1 = roots_jacobi(24, 0.0, beta)
    u_sp = np.concatenate([(1 + y0) / 2, (1 + y1) / 2])
    w_sp = np.concatenate([w0, w1]) / 2.0 ** (beta + 1.0)
    # scipy's rules: nodes within 1.1e-14 and weights within 1.8e-13 relative (measured
    # for beta in [-0.5, 0], issue 38), so 1e-12 tells a wrong rule from scipy's error.
    near = np.allclose(u, u_sp, rtol=1e-12, atol=0) and np.allclose(w, w_sp, rtol=1e-12, atol=0)
    assert_true(
        ok and near and len(flat) == 2 * sum(sizes),
        got=f"rules that differ (stored = computed: {ok}, near scipy's: {near})",
        should="bit for bit _jacobi_rules, within 1e-12 of scipy's roots_jacobi",
        claim="tool",
        call=f"_jacobi_pair({beta}, {sizes})",
    )
