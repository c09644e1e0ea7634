"""numba's disk cache is keyed by the package's compiled sources (`reference_impl._numba_dir`).

numba checks a cached function only against the stamp (mtime, size) of its own source
file: a compiled function in file X that calls or inlines one from file Y keeps Y's old
machine code after Y changes, as long as X is unchanged. The first test shows that of numba
alone, on a two-file package made in a temporary directory (if numba one day notices, it
fails and says so). The package therefore caches into ``numba/<key>``, the key a digest of
the versions and of the content of every compiled source (`_numba_dir._COMPILED_SOURCES`, which
the AST test below checks is complete); old keyed directories are pruned without ever
following a symbolic link out of the cache.
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from reference_impl import _numba_dir
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "reference_impl"


def _python(script: Path, env_extra: dict, pythonpath: Path) -> str:
    env = {
        k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "_HCV_NUMBA_CACHE_DIR")
    }
    env.update(env_extra, PYTHONPATH=str(pythonpath))
    r = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300
    )
    assert r.returncode == 0, f"got exit {r.returncode}: {r.stderr[-1500:]}, should be 0"
    return r.stdout.strip().splitlines()[-1]


def _edit_keeping_stamp(path: Path, old: str, new: str, keep_mtime: bool) -> None:
    """Replace ``old`` by ``new`` (same length: the size is kept), the mtime kept if asked."""
    assert len(old) == len(new)
    st = path.stat()
    path.write_text(path.read_text().replace(old, new))
    if keep_mtime:  # as a wheel with fixed mtimes leaves it
        os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))


# ----------------------------------------------------------------------------- the defect
_A = "import numba\nfrom tiny.b import g\n\n\n@numba.njit(cache=True)\ndef f():\n    return g()\n"
_B = "import numba\n\n\n@numba.njit(cache=True)\ndef g():\n    return 1.0\n"


def test_numba_alone_keeps_a_callees_old_code(tmp_path):
    """numba's own behaviour, with a fixed NUMBA_CACHE_DIR: B edited, A untouched, A() stale."""
    (tmp_path / "tiny").mkdir()
    (tmp_path / "tiny" / "__init__.py").write_text("")
    (tmp_path / "tiny" / "a.py").write_text(_A)
    (tmp_path / "tiny" / "b.py").write_text(_B)
    script = tmp_path / "run.py"
    script.write_text("from tiny.a import f\nprint(f())\n")
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    first = _python(script, env, tmp_path)
    _edit_keeping_stamp(tmp_path / "tiny" / "b.py", "1.0", "2.0", keep_mtime=False)
    second = _python(script, env, tmp_path)
    assert_true(
        (first, second) == ("1.0", "1.0"),
        got=f"A() = {first}, then {second} after B changed",
        should="1.0 then 1.0 (numba keeps B's old code inside A's cache entry); if numba now "
        "gives 2.0 it checks callees itself, and the keyed directory of reference_impl._numba_dir "
        "may be revisited",
        claim="tool",
        call="numba cache=True, A calls B, B edited",
    )


# ----------------------------------------------------------------------------- the fix
_CALLER = textwrap.dedent(
    """
    import os
    import reference_impl
    import numba
    from reference_impl._jit import _probe

    @numba.njit(cache=True)
    def caller():
        return _probe()

    print(caller(), os.environ["NUMBA_CACHE_DIR"])
    """
)
_PROBE = "\n\n@numba.njit(cache=True)\ndef _probe():\n    return 1.0\n"


@pytest.mark.parametrize("stamp", ["edited", "same size and mtime"])
def test_the_package_cache_follows_a_changed_callee(tmp_path, stamp):
    """A copy of the package whose compiled _jit.py gains ``_probe``; a caller outside it
    (never edited) is cached; ``_probe`` is changed; the caller must see the change."""
    copy = tmp_path / "pkg"
    shutil.copytree(PACKAGE, copy / "reference_impl", ignore=shutil.ignore_patterns("__pycache__"))
    jit = copy / "reference_impl" / "_jit.py"
    jit.write_text(jit.read_text() + _PROBE)
    script = tmp_path / "caller.py"
    script.write_text(_CALLER)
    env = {"HCV_CACHE_DIR": str(tmp_path / "cache")}
    first, dir1 = _python(script, env, copy).split()
    _edit_keeping_stamp(jit, "return 1.0", "return 2.0", keep_mtime=stamp != "edited")
    second, dir2 = _python(script, env, copy).split()
    assert_true(
        (first, second) == ("1.0", "2.0") and dir1 != dir2,
        got=f"caller() = {first} in {dir1}, then {second} in {dir2}",
        should="1.0, then 2.0 from another numba directory",
        claim="tool",
        call=f"a compiled callee in reference_impl changed ({stamp})",
    )


def test_the_key_follows_compiled_sources_only(tmp_path, monkeypatch):
    copy = tmp_path / "reference_impl"
    for rel in _numba_dir._COMPILED_SOURCES:
        (copy / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(PACKAGE / rel, copy / rel)
    other = copy / "cli" / "main.py"  # not compiled, imported by no compiled module
    other.parent.mkdir()
    other.write_text("X = 1\n")
    base = _numba_dir._source_digest(copy)
    _edit_keeping_stamp(other, "X = 1", "X = 2", keep_mtime=False)
    after_other = _numba_dir._source_digest(copy)
    kernel = copy / "integrators" / "verlet_kernel.py"
    _edit_keeping_stamp(kernel, "import math", "import Math", keep_mtime=True)
    after_kernel = _numba_dir._source_digest(copy)
    key = _numba_dir.numba_key()
    monkeypatch.setattr(_numba_dir, "__version__", "999.0")
    key_new_version = _numba_dir.numba_key()
    assert_true(
        after_other == base and after_kernel != base and key_new_version != key,
        got=f"digest {base[:12]} -> {after_other[:12]} (cli) -> {after_kernel[:12]} "
        f"(verlet_kernel, same size and mtime); key {key} -> {key_new_version} (version)",
        should="unchanged by the file outside the compiled sources, changed by a compiled "
        "source's content and by the package version",
        claim="tool",
        call="_source_digest, numba_key",
    )


# ----------------------------------------------------------------------------- the list
def _module_files() -> dict[str, Path]:
    out = {}
    for p in PACKAGE.rglob("*.py"):
        parts = ("reference_impl", *p.relative_to(PACKAGE).with_suffix("").parts)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    return out


def _imports(tree: ast.AST) -> tuple[set[str], bool]:
    """Dotted names a module imports (deferred imports included) and whether numba is one."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{a.name}" for a in node.names)
    return names, any(n == "numba" or n.startswith("numba.") for n in names)


def test_compiled_sources_list_every_module_numba_code_depends_on():
    """Every module that imports numba, and every package module those import, transitively."""
    files = _module_files()
    parsed = {m: _imports(ast.parse(p.read_text(), str(p))) for m, p in files.items()}
    todo = [m for m, (_, numba) in parsed.items() if numba]
    seen: set[str] = set()
    while todo:
        m = todo.pop()
        if m not in seen:
            seen.add(m)
            todo.extend(n for n in parsed[m][0] if n in files)
    needed = {files[m].relative_to(PACKAGE).as_posix() for m in seen}
    listed = set(_numba_dir._COMPILED_SOURCES)
    assert_true(
        needed == listed,
        got=f"missing {sorted(needed - listed)}, listed but not needed {sorted(listed - needed)}",
        should="_COMPILED_SOURCES equal to the numba modules and their package imports",
        claim="tool",
        call="reference_impl._numba_dir._COMPILED_SOURCES",
    )


# ----------------------------------------------------------------------------- pruning
_HOUR = 3600.0


def test_pruning_keeps_the_recent_few_and_never_leaves_the_root(tmp_path):
    root = tmp_path / "numba"
    outside = tmp_path / "outside"
    (outside / "deep").mkdir(parents=True)
    (outside / "precious.txt").write_text("keep me")
    (outside / "deep" / "precious.txt").write_text("keep me too")
    now = 1.0e9
    made = {}

    def make(name: str, age_h: float, link_to: Path | None = None) -> Path:
        p = root / name
        if link_to is None:
            p.mkdir(parents=True)
            (p / "f.nbi").write_bytes(b"x")
        else:
            root.mkdir(exist_ok=True)
            p.symlink_to(link_to, target_is_directory=True)
        os.utime(p, (now - age_h * _HOUR,) * 2, follow_symlinks=False)
        made[name] = p
        return p

    key = "key-" + "{:024x}"
    current = make(key.format(0), 0.0)
    for i in range(1, 6):
        make(key.format(i), 1.0 + i)  # five old keyed directories, 2 to 6 hours unused
    make(key.format(9), 0.5)  # recently used by another process: kept whatever the count
    make("exact_" + "a" * 40, 48.0)  # the layout before keys
    make("notes", 48.0)  # not named as the cache names its directories
    make(key.format(7), 48.0, link_to=outside)  # a planted link named like a key
    inner = make(key.format(8), 48.0)
    (inner / "escape").symlink_to(outside, target_is_directory=True)  # a link inside an old one
    os.utime(inner, (now - 48 * _HOUR,) * 2)
    removed = {p.name for p in _numba_dir.prune_numba_dirs(root, keep=current, now=now)}
    left = {p.name for p in root.iterdir()}
    expected_removed = {key.format(i) for i in (2, 3, 4, 5, 8)} | {"exact_" + "a" * 40}
    intact = sorted(p.name for p in outside.rglob("*"))
    assert_true(
        removed == expected_removed
        and left == set(made) - expected_removed
        and intact == ["deep", "precious.txt", "precious.txt"],
        got=f"removed {sorted(removed)}, left {sorted(left)}, outside holds {intact}",
        should=f"removed {sorted(expected_removed)} (beyond the 3 newest, unused for an hour); "
        "the link, the recent one and the foreign name left; nothing outside touched",
        claim="tool",
        call="_prune_numba_dirs",
    )
