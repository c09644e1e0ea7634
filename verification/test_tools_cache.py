"""Tool tests of the compile cache (`reference_impl._cache`, issue 20).

An unusable cache directory (read-only, not a directory, full) is never an error: one
warning, then code is compiled for the process only. Entries are written atomically (several
processes writing one entry all import a whole file), keyed by their canonical form, and
bounded (least recently used first out, with their numba files).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from reference_impl import _cache, _expr_cache
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent

# Runs in a new process: the package's import configures the cache (HCV_CACHE_DIR from the
# environment); then a cached numba function is compiled, which must work (in a private
# directory) when the cache is unusable; prints what happened as JSON.
_DEGRADE = textwrap.dedent(
    """
    import json, sys, warnings
    warnings.simplefilter("always")  # count every warning, not Python's once-per-place
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        import reference_impl
        from reference_impl import _cache, _expr_cache
        if len(sys.argv) > 1:  # "full": the same directory, but too little free space
            _cache.MIN_FREE_BYTES = 2**62
            _cache._state["usable"] = None
            import os; os.environ.pop("NUMBA_CACHE_DIR", None)
        usable = _cache.configure_numba_cache()
        usable_again = _cache.configure_numba_cache()
        module = _expr_cache.expression_module("probe", "canonical", "X = 1\\n")
        import numba

        @numba.njit(cache=True)
        def twice(x):
            return 2.0 * x

        value = twice(1.5)
    print(json.dumps({
        "usable": usable, "usable_again": usable_again, "module": module is not None,
        "value": value,
        "warnings": [str(w.message) for w in caught if w.category is _cache.CacheWarning],
    }))
    """
)


def _degrade(tmp_path, cache_dir: str, *extra: str) -> dict:
    script = tmp_path / "degrade.py"  # a file, so that numba has a source to key its cache by
    script.write_text(_DEGRADE)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(HCV_CACHE_DIR=cache_dir, PYTHONPATH=str(ROOT))
    r = subprocess.run(
        [sys.executable, str(script), *extra], capture_output=True, text=True, env=env, timeout=300
    )
    assert r.returncode == 0, f"got exit {r.returncode}: {r.stderr[-2000:]}, should be 0"
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("kind", ["not a directory", "read-only", "full"])
def test_unusable_cache_degrades_with_one_warning(tmp_path, kind):
    extra = ()
    if kind == "not a directory":
        target = tmp_path / "a-file"
        target.write_text("")
    elif kind == "read-only":
        target = tmp_path / "ro"
        target.mkdir()
        target.chmod(0o555)
        if os.access(target, os.W_OK):  # root: permissions do not stop writes
            target = Path("/proc/hcv-cache")  # procfs: creating a directory there fails
    else:
        target = tmp_path / "full"
        extra = ("full",)
    out = _degrade(tmp_path, str(target), *extra)
    assert_true(
        not out["usable"]
        and not out["usable_again"]
        and not out["module"]
        and out["value"] == 3.0
        and len(out["warnings"]) == 1,
        got=json.dumps(out),
        should="unusable, no module, the compiled function working, exactly one CacheWarning",
        claim="tool",
        call=f"HCV_CACHE_DIR {kind}",
    )


def test_usable_cache_gives_no_warning(tmp_path):
    out = _degrade(tmp_path, str(tmp_path / "cache"))
    assert_true(
        out["usable"] and out["module"] and out["value"] == 3.0 and not out["warnings"],
        got=json.dumps(out),
        should="usable, a module, no warning",
        claim="tool",
        call="HCV_CACHE_DIR writable",
    )


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("HCV_CACHE_DIR", str(tmp_path / "x"))
    assert _cache.cache_dir() == tmp_path / "x"
    monkeypatch.delenv("HCV_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert _cache.cache_dir() == tmp_path / "xdg" / "hidden-harmonic-verification"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert _cache.cache_dir() == Path.home() / ".cache" / "hidden-harmonic-verification"


def test_entries_are_keyed_by_their_canonical_form(monkeypatch, tmp_path):
    monkeypatch.setenv("HCV_CACHE_DIR", str(tmp_path))
    a = _expr_cache.expression_module("keytest", "Symbol('q')", "VALUE = 'a'\n")
    a_again = _expr_cache.expression_module("keytest", "Symbol('q')", "VALUE = 'a'\n")
    b = _expr_cache.expression_module("keytest", "Pow(Symbol('q'), Integer(2))", "VALUE = 'b'\n")
    assert_true(
        a is a_again and a is not b and (a.VALUE, b.VALUE) == ("a", "b"),
        got=f"{a.__name__}, {a_again.__name__}, {b.__name__}",
        should="one module per canonical form, the same one when asked again",
        claim="tool",
        call="expression_module",
    )


_WRITER = textwrap.dedent(
    """
    import sys
    from reference_impl import _expr_cache
    m = _expr_cache.expression_module("race", "one entry", "DATA = 'x' * 200000\\n")
    print(len(m.DATA))
    """
)


def test_processes_writing_one_entry_all_import_a_whole_file(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(HCV_CACHE_DIR=str(tmp_path), PYTHONPATH=str(ROOT))
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _WRITER],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=env,
            text=True,
        )
        for _ in range(4)
    ]
    outs = [p.communicate(timeout=300) for p in procs]
    codes = [p.returncode for p in procs]
    leftovers = sorted(
        p.name for p in (tmp_path / "expressions").iterdir() if p.name.endswith(".tmp")
    )
    assert_true(
        codes == [0] * 4 and all(o.strip() == "200000" for o, _ in outs) and not leftovers,
        got=f"exits {codes}, outputs {[o.strip() for o, _ in outs]}, temporary files {leftovers}",
        should="every process imports the whole entry, no temporary file left",
        claim="tool",
        call="expression_module from 4 processes",
    )


class _FakeDispatcher:
    """What `record_files` reads of a numba dispatcher: its cache path and Python function."""

    def __init__(self, cache_path: Path, py_func):
        self._cache = type("C", (), {"_cache_path": str(cache_path)})()
        self.py_func = py_func


def _numba_file_of(entry: str, numba_dir: Path) -> Path:
    f = numba_dir / f"{entry}.kernel-1.py311.nbi"
    f.write_bytes(b"x" * 100)
    return f


def test_least_recently_used_entries_are_evicted_with_their_numba_files(monkeypatch, tmp_path):
    monkeypatch.setenv("HCV_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("HCV_CACHE_MAX_MB", str(2500 / 2**20))  # room for about two entries
    numba_dir = tmp_path / "fake-numba"
    numba_dir.mkdir()
    mods = []
    for i in range(4):
        m = _expr_cache.expression_module("lru", f"entry {i}", f"PAD = {'1' * 1000!r}\n")
        stem = Path(m.__file__).stem

        def kernel():
            pass

        kernel.__code__ = kernel.__code__.replace(co_filename=str(numba_dir / f"{stem}.py"))
        kernel.__qualname__ = "kernel"
        extra = _numba_file_of(stem, numba_dir)
        _expr_cache.record_files(stem, [_FakeDispatcher(numba_dir, kernel)])
        mods.append((m, extra))
        os.utime(m.__file__, (1e9 + i, 1e9 + i))  # entry i used at time i
    alive = [Path(m.__file__).is_file() for m, _ in mods]
    numba_alive = [f.is_file() for _, f in mods]
    assert_true(
        alive == [False, False, True, True] and numba_alive == alive,
        got=f"modules kept {alive}, numba files kept {numba_alive}",
        should="the two most recent kept, the others gone with their numba files",
        claim="tool",
        call="expression_module eviction",
    )
