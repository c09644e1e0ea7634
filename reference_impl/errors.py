"""Exception types raised for input that violates the paper's assumptions.

Every error carries one line that names the offending value and says what to
do; the CLI prints that line and exits with status 2.
"""

from __future__ import annotations

__all__ = [
    "HCVInputError",
    "DomainError",
    "NonMonotoneError",
    "NoTurningPointError",
    "ExpressionError",
    "SceneError",
    "UnsupportedError",
    "one_line",
]


class HCVInputError(ValueError):
    """Base class: the input cannot be used (bad value, assumption violated)."""


class DomainError(HCVInputError):
    """A coordinate lies outside the domain on which the potential is defined."""


class NonMonotoneError(HCVInputError):
    """U'(q) <= 0 somewhere in (0, q_max]: assumption (3) of section 3 fails."""


class NoTurningPointError(HCVInputError):
    """U never reaches the requested energy: assumption (4) of section 3 fails."""


class ExpressionError(HCVInputError):
    """A user expression string is malformed or uses a name that is not allowed."""


class SceneError(HCVInputError):
    """A scene file is missing, malformed, or has an invalid value."""


class UnsupportedError(HCVInputError):
    """A valid input outside what the solver computes reliably: refused, never guessed."""


def one_line(exc: BaseException) -> str:
    """``Type: first line of the message`` (the type alone for an empty message): an
    exception as one line of a record or a report (the bench's workers, the sweep)."""
    text = str(exc).strip().splitlines()
    head = text[0] if text else ""
    return f"{type(exc).__name__}: {head}" if head else type(exc).__name__
