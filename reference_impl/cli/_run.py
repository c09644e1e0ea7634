"""How every ``hcv`` command ends: its exit statuses and the one-line error contract."""

from __future__ import annotations

import os
import sys

from reference_impl._procs import terminated
from reference_impl.errors import HCVInputError

__all__ = ["EXIT_FAIL", "EXIT_INTERRUPTED", "EXIT_OK", "EXIT_USAGE", "interrupted", "run_command"]

# Exit statuses (shared with `hcv bench --gate`, which adds 3: our reference failed).
EXIT_OK = 0
EXIT_FAIL = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT


def _joined(text) -> str:
    """The message on one line: its lines and runs of blanks joined by one space (not
    `reference_impl.errors.one_line`, which keeps the type and the first line)."""
    return " ".join(str(text).split())


def run_command(args) -> int:
    """Run a parsed command; every way out is one line on stderr and an exit status."""
    try:
        return args.func(args)
    except HCVInputError as exc:
        print(f"hcv: error: {_joined(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        return interrupted()
    except (RecursionError, OverflowError, MemoryError) as exc:
        # Sizes are bounded before work starts; this is the backstop for an input that
        # still exhausts a limit (nesting, float range, memory).
        print(
            f"hcv: error: the input is too large or too deeply nested ({type(exc).__name__})",
            file=sys.stderr,
        )
        return EXIT_USAGE
    except BrokenPipeError:
        # Output piped into e.g. `head`: stop quietly, as Unix tools do.
        sys.stderr.close()
        return EXIT_OK
    except OSError as exc:
        # Paths are checked before work starts; this is the backstop for one the file
        # system still refuses (a name too long, a permission changed meanwhile).
        where = f"{_short_path(exc.filename)}: " if exc.filename else ""
        print(f"hcv: error: {where}{exc.strerror or _joined(exc)}", file=sys.stderr)
        return EXIT_USAGE


def _short_path(name) -> str:
    text = os.fsdecode(name) if isinstance(name, (bytes, str)) else str(name)
    return text if len(text) <= 80 else text[:38] + "..." + text[-38:]


def interrupted() -> int:
    """The line and status of Ctrl-C (130) or SIGTERM handled like it (143)."""

    signum = terminated()
    if signum is not None:
        print("hcv: terminated (SIGTERM)", file=sys.stderr)
        return 128 + signum
    print("hcv: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED
