"""What the hostile results-file tests share (issue 36): the committed document trimmed,
a report directory holding a document, ``hcv report --from`` run on it with the files it
opens recorded, and the check of a one-line refusal.

Used by ``test_hostile_report.py`` (links, markup and the schema) and
``test_hostile_report_paths.py`` (figure and scorecard paths).
"""

from __future__ import annotations

import contextlib
import copy
import json
import os
import shutil
import sys
from pathlib import Path

import pytest

from reference_impl.cli import main
from verification.assertions import assert_true

__all__ = [
    "BASE",
    "CLAIM",
    "COMMITTED",
    "REPORTS",
    "committed_copy",
    "opened_outside",
    "recording",
    "refused",
    "run_from",
    "source",
]

REPORTS = Path(__file__).resolve().parents[1] / "reports"
CLAIM = "report"

# ----------------------------------------------------------------------------------
# What the process opens (audit hook "open": open(), os.open(), io; inert unless recording)
# ----------------------------------------------------------------------------------
_OPENED: list[tuple[str, bool]] | None = None


def _audit(event: str, args) -> None:
    """Record (path, follows its last link) of each open: open(), io, os.open."""
    if _OPENED is not None and event == "open" and isinstance(args[0], (str, bytes, os.PathLike)):
        flags = args[2] if len(args) > 2 and isinstance(args[2], int) else 0
        _OPENED.append((os.fsdecode(args[0]), not flags & os.O_NOFOLLOW))


sys.addaudithook(_audit)


@contextlib.contextmanager
def recording():
    """The list of (path, follows its last link) opened inside the ``with`` block."""
    global _OPENED
    _OPENED = opened = []
    try:
        yield opened
    finally:
        _OPENED = None


def opened_outside(opened, outside: list[str]) -> list[str]:
    """The absolute paths opened that are, or lie in, one of ``outside``: the links of the
    path resolved, its last one too unless opened with O_NOFOLLOW (which refuses a link).

    A path opened relative to a directory descriptor (the report's own reads) is relative
    to a directory opened, and checked here, before it."""
    roots = {os.path.realpath(p) for p in outside} | set(outside)
    hits = []
    for p, follows in opened:
        if not os.path.isabs(p):
            continue
        head, tail = os.path.split(p)
        where = os.path.realpath(p) if follows else os.path.join(os.path.realpath(head), tail)
        if any(c == r or c.startswith(r.rstrip("/") + "/") for c in (p, where) for r in roots):
            hits.append(p)
    return hits


def _trimmed(doc: dict) -> dict:
    """The committed document with every list cut to its first 3 items (the claims and
    the figures whole: the renderer looks claims up by id and figures by name), so that a
    case validates and renders in milliseconds; it is a valid document all the same."""

    def cut(x):
        if isinstance(x, dict):
            return {k: cut(v) for k, v in x.items()}
        return [cut(v) for v in x[:3]] if isinstance(x, list) else x

    return {k: (v if k in ("claims", "figures") else cut(v)) for k, v in doc.items()}


COMMITTED = REPORTS / "results.json"
BASE = _trimmed(json.loads(COMMITTED.read_text())) if COMMITTED.is_file() else {"schema": "x"}


def committed_copy() -> dict:
    """A fresh copy of the (trimmed) committed results (the test skips without them)."""
    if not COMMITTED.is_file():
        pytest.skip("reports/results.json not generated")
    return copy.deepcopy(BASE)


def source(tmp_path: Path, doc: dict) -> Path:
    """A report directory ``in/`` holding ``doc`` as results.json and the committed figures."""
    src = tmp_path / "in"
    (src / "figures").mkdir(parents=True)
    listed = doc["figures"] if isinstance(doc.get("figures"), list) else []
    # Each name once: a document listing one figure 1e5 times needs one copy of it (the
    # copies took ~45 s), and the document itself still lists it 1e5 times.
    for rel in dict.fromkeys(x for x in listed if isinstance(x, str)):
        if (REPORTS / rel).is_file() and rel.startswith("figures/"):
            shutil.copyfile(REPORTS / rel, src / rel)
    (src / "results.json").write_text(json.dumps(doc))
    return src


def run_from(src: Path, out: Path, capsys) -> tuple[int, list[str], list[str]]:
    """``hcv report --from src/results.json --out out``: exit status, stderr lines, files opened."""
    with recording() as opened:
        code = main(["report", "--from", str(src / "results.json"), "--out", str(out)])
    return code, capsys.readouterr().err.strip().splitlines(), opened


def refused(code, err, out: Path, needle: str, opened, outside, call: str) -> None:
    """Assert one refusal: exit 2, one stderr line holding ``needle``, no ``out`` written,
    nothing in ``outside`` among the paths ``opened``."""
    leaked = opened_outside(opened, outside)
    assert_true(
        code == 2 and len(err) == 1 and needle in err[0] and not out.exists() and not leaked,
        got=f"exit {code}, stderr {err}, output written: {out.exists()}, opened outside: {leaked}",
        should=f"exit 2, one line naming {needle!r}, nothing written, nothing outside opened",
        claim=CLAIM,
        call=call,
    )
