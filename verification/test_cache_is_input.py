"""The cache is input (issue 29): what lies in the cache directory never changes a result
and never stops a run.

* a stored table (``tables/``) edited by hand is detected by its checksum: the table is
  computed afresh, with one `CacheWarning`, and the answer is the one computed;
* a damaged numba file (a truncated ``.nbc``, a garbage ``.nbi``) is removed and the
  function compiled afresh, with one `CacheWarning`, where it raised on every later run;
* numba's cache format is pickle, so whoever can write the cache can run code in hcv: the
  cache directory is created 0700, and one owned by another user or writable by group or
  others is refused (one warning; a private temporary cache for the process).

Each test runs in its own cache directory (``HCV_CACHE_DIR``); the numba tests run a new
process, as a user's next run would.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

from reference_impl import _cache, _numba_dir, _stored
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent


# ----------------------------------------------------------------------------- tables
@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("HCV_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_stored, "_warned", set())
    return tmp_path / "tables"


def _cache_warnings(caught) -> list[str]:
    return [str(w.message) for w in caught if issubclass(w.category, _cache.CacheWarning)]


def test_an_edited_gauss_jacobi_table_is_recomputed_with_one_warning(store):
    """The issue's case: the weights of a stored Gauss-Jacobi rule scaled by 1.001 (the
    file's other fields left as they were, as a hand edit leaves them)."""
    from reference_impl.exact._branches import _jacobi_pair, _jacobi_rules

    beta, sizes = 0.5, (16, 24)
    _jacobi_pair.cache_clear()
    first = _jacobi_pair(beta, sizes)
    (entry,) = store.glob("*.json")
    data = json.loads(entry.read_text())
    n = sum(sizes)  # nodes, then weights
    data["v"][n:] = [(float.fromhex(h) * 1.001).hex() for h in data["v"][n:]]
    entry.write_text(json.dumps(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _jacobi_pair.cache_clear()
        again = _jacobi_pair(beta, sizes)
        _jacobi_pair.cache_clear()
        third = _jacobi_pair(beta, sizes)  # rewritten: read back without a warning
    _jacobi_pair.cache_clear()
    w0 = np.array(_jacobi_rules(beta, sizes)[n : n + 16])  # the rule computed afresh
    msgs = _cache_warnings(caught)
    same = all(np.array_equal(a, b) for x in (again, third) for a, b in zip(first, x, strict=True))
    assert_true(
        same and np.array_equal(first[1][:16, 0], w0),
        got="the edited weights used",
        should="the rule computed afresh, bit for bit _jacobi_rules",
        claim="tool",
        call="_jacobi_pair over an edited entry",
    )
    assert_true(
        len(msgs) == 1 and str(entry) in msgs[0],
        got=f"{len(msgs)} CacheWarnings {msgs}",
        should="one naming the entry",
        claim="tool",
        call="_jacobi_pair over an edited entry",
    )


@pytest.mark.parametrize(
    "edit",
    ["truncated", "checksum of other values", "moved from another name", "wrong length"],
)
def test_a_damaged_table_entry_is_never_used(store, edit):
    def table(a, n):
        return [a / (k + 3.0) for k in range(n)]

    expected = _stored.stored_floats("t", (0.1, 9), table, 9)
    (entry,) = store.glob("*.json")
    text = entry.read_text()
    data = json.loads(text)
    if edit == "truncated":
        entry.write_text(text[: len(text) // 2])
    elif edit == "checksum of other values":
        data["v"][0] = (2.0).hex()
        data["sha256"] = _stored._checksum(entry, data["v"][:1] + data["v"][1:])[::-1]
        entry.write_text(json.dumps(data))
    elif edit == "moved from another name":
        other = _stored.stored_floats("t", (0.2, 9), table, 9)
        (moved,) = [p for p in store.glob("*.json") if p != entry]
        entry.write_text(moved.read_text())
        assert other != expected
    else:
        data["v"] = data["v"][:-1]
        data["sha256"] = _stored._checksum(entry, data["v"])
        entry.write_text(json.dumps(data))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = _stored.stored_floats("t", (0.1, 9), table, 9)
    msgs = _cache_warnings(caught)
    assert_true(
        got == expected and len(msgs) == 1,
        got=f"{got[:2]}..., {len(msgs)} warnings",
        should="the computed values and one CacheWarning",
        claim="tool",
        call=f"stored_floats over an entry {edit}",
    )


def test_an_entry_of_the_format_before_checksums_is_rewritten_silently(store):
    def table(a, n):
        return [a / (k + 3.0) for k in range(n)]

    expected = _stored.stored_floats("t", (0.1, 9), table, 9)
    (entry,) = store.glob("*.json")
    entry.write_text(json.dumps([v.hex() for v in expected]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = _stored.stored_floats("t", (0.1, 9), table, 9)
    assert got == expected and not _cache_warnings(caught), _cache_warnings(caught)
    assert "sha256" in json.loads(entry.read_text()), "got the old entry kept, should be rewritten"


# ----------------------------------------------------------------------------- numba files
# Runs in a new process: the package's import configures the cache (HCV_CACHE_DIR from the
# environment) and guards numba's loader; then a cached numba function (in a file, so that
# numba can key its cache) is called; prints the value, the CacheWarnings and the directory.
_RUN = textwrap.dedent(
    """
    import json, os, sys, warnings
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        import reference_impl
        from reference_impl import _cache
        import numba

        @numba.njit(cache=True)
        def twice(x):
            return 2.0 * x

        value = twice(1.5)
    print(json.dumps({
        "value": value,
        "numba_cache_dir": os.environ.get("NUMBA_CACHE_DIR"),
        "warnings": [str(w.message) for w in caught if w.category is _cache.CacheWarning],
    }))
    """
)


def _run(tmp_path: Path, cache: Path, **extra: str) -> dict:
    script = tmp_path / "cached.py"
    script.write_text(_RUN)
    env = {
        k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "_HCV_NUMBA_CACHE_DIR")
    }
    env.update(HCV_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT), **extra)
    r = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300
    )
    assert r.returncode == 0, (
        f"got exit {r.returncode}: {r.stderr[-1500:]}, should be 0 [issue 29, the cache is input]"
    )
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("damage", ["truncated .nbc", "garbage .nbi"])
def test_a_damaged_numba_file_is_recompiled_with_one_warning(tmp_path, damage):
    cache = tmp_path / "cache"
    first = _run(tmp_path, cache)
    suffix = damage.split()[-1]
    (victim,) = [p for p in (cache / "numba").rglob(f"*{suffix}") if "cached" in p.name]
    raw = victim.read_bytes()
    victim.write_bytes(
        raw[: len(raw) // 3]
        if damage.startswith("truncated")
        else b"\x80\x04garbage" + os.urandom(64)
    )
    second = _run(tmp_path, cache)
    third = _run(tmp_path, cache)  # the entry was rewritten: no warning now
    assert_true(
        first["value"] == second["value"] == third["value"] == 3.0
        and len(second["warnings"]) == 1
        and victim.name in second["warnings"][0]
        and not third["warnings"],
        got=f"values {first['value']}, {second['value']}, {third['value']}; warnings "
        f"{second['warnings']} then {third['warnings']}",
        should="3.0 each time; one CacheWarning naming the file, then none",
        claim="tool",
        call=f"a cached numba function over a {damage}",
    )


# ----------------------------------------------------------------------------- ownership
def test_a_new_cache_directory_is_private(tmp_path):
    cache = tmp_path / "a" / "cache"
    old = os.umask(0o022)
    try:
        assert _cache._unusable(cache) is None
    finally:
        os.umask(old)
    mode = stat.S_IMODE(cache.stat().st_mode)
    assert mode == 0o700, f"got mode {oct(mode)}, should be 0o700 [issue 29, cache dir]"


def test_a_cache_directory_others_can_write_is_refused(tmp_path):
    """A new process over a group-writable HCV_CACHE_DIR: one warning, a private cache."""
    cache = tmp_path / "shared"
    cache.mkdir()
    os.chmod(cache, 0o770)
    got = _run(tmp_path, cache)
    assert_true(
        got["value"] == 3.0
        and len(got["warnings"]) == 1
        and "writable by" in got["warnings"][0]
        and not str(got["numba_cache_dir"]).startswith(str(cache))
        and not (cache / "numba").exists(),
        got=f"{got}",
        should="one CacheWarning, a private temporary cache, nothing written in the directory",
        claim="tool",
        call="HCV_CACHE_DIR writable by its group",
    )


@pytest.mark.parametrize(
    ("sub", "mode"),
    [("", 0o707), ("", 0o720), ("numba", 0o777), ("tables", 0o770), ("expressions", 0o702)],
)
def test_a_cache_writable_by_others_is_untrusted(tmp_path, sub, mode):
    cache = tmp_path / "cache"
    (cache / sub).mkdir(parents=True, exist_ok=True)
    os.chmod(cache, 0o700)
    os.chmod(cache / sub, mode)
    why = _cache._unusable(cache)
    assert_true(
        why is not None and "writable by group or others" in why and str(cache / sub) in why,
        got=repr(why),
        should=f"refused, naming {cache / sub}",
        claim="tool",
        call=f"_unusable with {sub or 'the directory'} mode {oct(mode)}",
    )


def test_a_cache_directory_of_another_user_is_refused(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("needs root to give a directory to another user (chown)")
    import pwd

    nobody = pwd.getpwnam("nobody")
    cache = tmp_path / "theirs"
    cache.mkdir(mode=0o755)
    os.chown(cache, nobody.pw_uid, nobody.pw_gid)
    got = _run(tmp_path, cache)
    assert_true(
        got["value"] == 3.0
        and len(got["warnings"]) == 1
        and "owned by" in got["warnings"][0]
        and not str(got["numba_cache_dir"]).startswith(str(cache)),
        got=f"{got}",
        should="one CacheWarning, a private temporary cache",
        claim="tool",
        call="HCV_CACHE_DIR owned by nobody",
    )


def test_a_keyed_numba_directory_others_can_write_is_refused(tmp_path):
    """numba's files go to ``numba/<key>`` (`_numba_dir.numba_key`): that directory is checked too."""
    cache = tmp_path / "cache"
    keyed = cache / "numba" / _numba_dir.numba_key()  # the key a new process of this tree computes
    keyed.mkdir(parents=True)
    os.chmod(cache, 0o700)
    os.chmod(cache / "numba", 0o700)
    os.chmod(keyed, 0o777)
    got = _run(tmp_path, cache)
    assert_true(
        got["value"] == 3.0
        and len(got["warnings"]) == 1
        and "writable by" in got["warnings"][0]
        and str(keyed) in got["warnings"][0]
        and not str(got["numba_cache_dir"]).startswith(str(cache))
        and not any(keyed.iterdir()),
        got=f"{got}",
        should=f"one CacheWarning naming {keyed}, a private temporary cache, nothing written there",
        claim="tool",
        call="numba/<key> writable by all",
    )


@pytest.mark.parametrize("whose", ["the user's", "inherited from an hcv parent"])
def test_numba_cache_dir_of_the_user_is_left_alone(tmp_path, whose):
    """A NUMBA_CACHE_DIR the user set is used as it is (numba's own rule, file stamps only:
    the docs say so); one an hcv process set for its children is replaced by the key's."""
    cache, theirs = tmp_path / "cache", tmp_path / "theirs"
    extra = {"NUMBA_CACHE_DIR": str(theirs)}
    if whose != "the user's":
        extra["_HCV_NUMBA_CACHE_DIR"] = str(theirs)
    got = _run(tmp_path, cache, **extra)
    if whose == "the user's":
        expected = str(theirs)
    else:
        expected = str(cache / "numba" / _numba_dir.numba_key())
    assert_true(
        got["value"] == 3.0 and got["numba_cache_dir"] == expected and not got["warnings"],
        got=f"{got}",
        should=f"NUMBA_CACHE_DIR {expected}, no warning",
        claim="tool",
        call=f"NUMBA_CACHE_DIR {whose}",
    )
