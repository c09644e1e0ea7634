"""A stand-in for numba, written into a temporary directory at run time (measurement only).

`benchmarks/bench_startup.py` times ``hcv solve`` with numba replaced by this stand-in (its
row "numba replaced by a stand-in (measured only)" and its record's ``interpreted``): put
first on ``PYTHONPATH``, the package ``numba`` it writes makes ``import numba`` cheap and
every ``@numba.njit`` function plain Python (its ``py_func`` itself), so that the package
runs its kernels interpreted without importing numba at all: what a path free of numba
would cost and give. It is no path for users: the interpreted kernels are not bit for bit
the compiled ones everywhere, and they are slow on large inputs.

The repository holds no package named ``numba`` (a folder of that name would read, to
any tool that resolves imports by path, as the target of every ``import numba`` of the
package): the stand-in's two files live here as text (`SOURCES`) and are written, by
`write` or `standin`, into a temporary directory that is removed after the run.

Run a command with the stand-in first on its path (e.g. the frozen cases interpreted,
`docs/performance.md`): ``python -m benchmarks._numba_standin python -m pytest
verification/test_exact_frozen.py``.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["SOURCES", "VERSION", "main", "pythonpath", "standin", "write"]

# ``numba.__version__`` of the stand-in: a run can check that the stand-in, not numba,
# is what its ``import numba`` found.
VERSION = "0+stand-in"

# ``numba/__init__.py``: what the exact solver's modules use (``njit``, ``prange``,
# ``get_num_threads``, ``parallel_chunksize``), verbatim the former
# ``benchmarks/_no_numba/numba/__init__.py``: a change here changes what the bench's row
# measures. Its ``__version__`` is `VERSION` (test).
_INIT = '''"""A stand-in for numba, for measurement only (``benchmarks/bench_startup.py``).

Put first on ``PYTHONPATH``, it makes ``import numba`` cheap and every ``@numba.njit``
function plain Python (its ``py_func`` itself), so that the package runs its kernels
interpreted without importing numba at all: what a path free of numba would cost and
give. It is no path for users: the interpreted kernels are not bit for bit the compiled
ones everywhere (the benchmark records where they differ), and they are slow on large
inputs. It covers what the exact solver's modules use: ``njit``, ``prange``,
``get_num_threads``, ``parallel_chunksize`` and ``extending.overload``.
"""

from __future__ import annotations

import contextlib

__all__ = ["get_num_threads", "jit", "njit", "parallel_chunksize", "prange"]
__version__ = "0+stand-in"


def _plain(func):
    func.py_func = func  # what python_solver and _jit read from a dispatcher
    return func


def njit(*args, **options):
    """``@njit`` or ``@njit(...)``: the function itself, run by the interpreter."""
    if len(args) == 1 and callable(args[0]) and not options:
        return _plain(args[0])
    return _plain


jit = njit
prange = range


def get_num_threads() -> int:
    """One thread: the interpreter runs every loop serially."""
    return 1


@contextlib.contextmanager
def parallel_chunksize(size):
    """No parallel loops here; the chunk size is ignored."""
    yield
'''

# ``numba/extending/__init__.py``: ``overload`` registers nothing.
_EXTENDING = '''"""``numba.extending`` of the stand-in: ``overload`` registers nothing (the Python
function itself runs)."""


def overload(*args, **options):
    """A no-op decorator: interpreted code calls the Python function directly."""
    return lambda impl: impl
'''

# The stand-in's files, by their path under the directory put on ``PYTHONPATH``.
SOURCES = {"numba/__init__.py": _INIT, "numba/extending/__init__.py": _EXTENDING}


def write(directory: Path) -> Path:
    """Write the stand-in package ``numba`` under ``directory`` (created if missing).

    Parameters
    ----------
    directory : Path
        Where the package goes; put it first on ``PYTHONPATH``.

    Returns
    -------
    Path
        ``directory`` itself.
    """
    directory = Path(directory)
    for rel, text in SOURCES.items():
        path = directory / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return directory


@contextlib.contextmanager
def standin() -> Iterator[Path]:
    """A temporary directory holding the stand-in (`write`), removed on leaving."""
    with tempfile.TemporaryDirectory(prefix="hcv-numba-standin-") as tmp:
        yield write(Path(tmp))


def pythonpath(directory: Path, *rest: str) -> str:
    """``PYTHONPATH`` with the stand-in's ``directory`` first, then ``rest`` (non-empty)."""
    return os.pathsep.join((str(directory), *(p for p in rest if p)))


def main(argv: list[str] | None = None) -> int:
    """Run the command ``argv`` with the stand-in first on ``PYTHONPATH``; its exit status."""
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        print("usage: python -m benchmarks._numba_standin COMMAND [ARG ...]", file=sys.stderr)
        return 2
    root = str(Path(__file__).resolve().parents[1])  # the repository: `benchmarks` importable
    with standin() as directory:
        env = {**os.environ}
        env["PYTHONPATH"] = pythonpath(directory, root, os.environ.get("PYTHONPATH", ""))
        return subprocess.run(argv, env=env).returncode


if __name__ == "__main__":
    sys.exit(main())
