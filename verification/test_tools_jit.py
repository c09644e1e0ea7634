"""Tool tests of `reference_impl._jit.specialise`: two bindings never share compiled code.

numba's disk cache is keyed by a function's module, qualified name and source file, not
by its globals, so copies of one function bound to different callees must carry different
qualified names. The subprocess test compiles two copies in one order, then loads them from
the disk cache in a new process in the other order, which is where a shared entry would
hand one copy the other's machine code.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from reference_impl._jit import binding_name, specialise
from verification.assertions import assert_true

_MODULE = textwrap.dedent(
    """
    import numba
    from reference_impl._jit import specialise

    _EV = None

    @numba.njit(cache=True)
    def plus_one(x):
        return x + 1.0

    @numba.njit(cache=True)
    def plus_two(x):
        return x + 2.0

    def apply(x):
        return _EV(x)
    """
)

_SCRIPT = textwrap.dedent(
    """
    import sys
    import jitmod
    order = sys.argv[1].split(",")
    fns = {{name: getattr(jitmod, name) for name in ("plus_one", "plus_two")}}
    out = []
    for name in order:
        f = jitmod.specialise(jitmod.apply, True, _EV=fns[name])
        out.append(f"{{name}}={{f(1.0)}}")
    print(" ".join(out))
    """
)


def test_two_bindings_never_share_a_cached_kernel(tmp_path):
    (tmp_path / "jitmod.py").write_text(_MODULE)
    (tmp_path / "run.py").write_text(_SCRIPT.format())
    env = dict(
        os.environ,
        NUMBA_CACHE_DIR=str(tmp_path / "cache"),
        PYTHONPATH=os.pathsep.join([str(tmp_path), os.getcwd(), os.environ.get("PYTHONPATH", "")]),
    )
    got = []
    for order in ("plus_one,plus_two", "plus_two,plus_one"):  # second run loads from disk
        r = subprocess.run(
            [sys.executable, str(tmp_path / "run.py"), order],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert r.returncode == 0, r.stderr
        got.append(set(r.stdout.split()))
    expect = {"plus_one=2.0", "plus_two=3.0"}
    assert_true(
        got == [expect, expect],
        got=got,
        should=[expect, expect],
        claim="tool",
        call="specialise(apply, cache=True, _EV=...) in two processes",
    )
    index_files = [p.name for p in (tmp_path / "cache").rglob("*.nbi") if "apply" in p.name]
    assert_true(
        len(index_files) == 2,
        got=index_files,
        should="one cache index per binding",
        claim="tool",
        call="numba cache of specialise copies",
    )


def test_binding_names_differ_and_unnamed_bindings_are_not_cached():
    import numba

    @numba.njit
    def local(x):  # a closure-like local function: no stable name across processes
        return x

    def apply(x):
        return x

    assert binding_name(apply, {"_EV": len}) != binding_name(apply, {"_EV": abs})
    with pytest.raises(ValueError, match="cannot cache"):
        specialise(apply, True, _EV=local)
    assert specialise(apply, False, _EV=local)(3.0) == 3.0
