"""The package's version: the installed distribution's, else the number in the source tree."""

from __future__ import annotations

__all__ = ["__version__", "version"]

# Used when the package runs from a source tree that is not installed (PYTHONPATH); keep
# equal to pyproject.toml's `version`.
__version__ = "0.1.0"


def version() -> str:
    """The installed distribution's version; `__version__` when it is not installed."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as _dist_version

    try:
        return _dist_version("hidden-harmonic-verification")
    except PackageNotFoundError:
        return __version__
