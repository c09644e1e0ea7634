"""The one scanner of claim marks in the test sources (used by the meta-tests and the report).

Read with `ast`, so the result does not depend on which tests a run selected. It
sees every way the suite writes a mark:

* ``@pytest.mark.claim("thm1-period")``;
* ``@pytest.mark.claim(CLAIM)`` with a module constant ``CLAIM = "..."`` or
  ``CLAIM = thm1_period.ID`` (a claim module imported from ``reference_impl.claims``);
* ``claim = pytest.mark.claim(CLAIM)`` at module level, then ``@claim``;
* ``pytestmark = pytest.mark.claim(...)`` (or a list of marks) in a module or class;
* ``pytest.param(..., marks=pytest.mark.claim(...))`` inside a decorator.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

__all__ = ["ClaimMark", "scan_claim_marks", "claim_tests"]

# verification/ next to the package (a source checkout); absent in an installed wheel.
SUITE_DIR = Path(__file__).resolve().parents[2] / "verification"
# Marker of a claim id that the scanner could not resolve to a string.
UNRESOLVED = "<unresolved>"


@dataclass(frozen=True)
class ClaimMark:
    """One claim mark: the id it names, the file and the test it marks (None: not on a test)."""

    claim: str
    file: str
    test: str | None
    line: int


def _is_claim_call(node) -> bool:
    return (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr == "claim"
        and isinstance(node.func.value, ast.Attribute)
        and node.func.value.attr == "mark"
    )


class _Resolver:
    """Module-level names of one test file: string constants, claim modules, mark variables."""

    def __init__(self, tree: ast.Module):
        self.strings: dict[str, str] = {}
        self.claim_modules: dict[
            str, str
        ] = {}  # local name -> module name in reference_impl.claims
        self.mark_vars: dict[str, str] = {}
        for node in tree.body:
            if isinstance(node, ast.ImportFrom) and node.module == "reference_impl.claims":
                for alias in node.names:
                    self.claim_modules[alias.asname or alias.name] = alias.name
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.startswith("reference_impl.claims.") and alias.asname:
                        self.claim_modules[alias.asname] = alias.name.rsplit(".", 1)[1]
            elif isinstance(node, ast.Assign):
                for tgt in node.targets:
                    if not isinstance(tgt, ast.Name):
                        continue
                    if _is_claim_call(node.value):
                        self.mark_vars[tgt.id] = self.resolve(node.value)
                    else:
                        value = self._value(node.value)
                        if value is not None:
                            self.strings[tgt.id] = value

    def _value(self, node) -> str | None:
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return node.value
        if isinstance(node, ast.Name):
            return self.strings.get(node.id)
        if (
            isinstance(node, ast.Attribute)
            and node.attr == "ID"
            and isinstance(node.value, ast.Name)
            and node.value.id in self.claim_modules
        ):
            import importlib

            name = self.claim_modules[node.value.id]
            try:
                return importlib.import_module(f"reference_impl.claims.{name}").ID
            except (ImportError, AttributeError):
                return None
        return None

    def resolve(self, call: ast.Call) -> str:
        """The claim id a ``pytest.mark.claim(...)`` call names."""
        if not call.args:
            return UNRESOLVED
        return self._value(call.args[0]) or UNRESOLVED

    def marks_in(self, node) -> list[tuple[str, int]]:
        """Claim ids named in an expression (a decorator, a pytestmark value)."""
        out = []
        for sub in ast.walk(node):
            if _is_claim_call(sub):
                out.append((self.resolve(sub), sub.lineno))
            elif isinstance(sub, ast.Name) and sub.id in self.mark_vars:
                out.append((self.mark_vars[sub.id], sub.lineno))
        return out


def _pytestmark(body, res: _Resolver) -> list[tuple[str, int]]:
    out = []
    for node in body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "pytestmark" for t in node.targets
        ):
            out += res.marks_in(node.value)
    return out


def _scan_file(path: Path) -> list[ClaimMark]:
    tree = ast.parse(path.read_text(), filename=str(path))
    res = _Resolver(tree)
    marks: list[ClaimMark] = []
    seen_lines: set[int] = set()
    module_marks = _pytestmark(tree.body, res)

    def visit(body, inherited):
        for node in body:
            if isinstance(node, ast.ClassDef) and node.name.startswith("Test"):
                cls = inherited + _pytestmark(node.body, res)
                for dec in node.decorator_list:
                    cls += res.marks_in(dec)
                visit(node.body, cls)
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name.startswith(
                "test"
            ):
                own = []
                for dec in node.decorator_list:
                    own += res.marks_in(dec)
                for cid, line in inherited + own:
                    marks.append(ClaimMark(cid, path.name, node.name, line))
                    seen_lines.add(line)

    visit(tree.body, module_marks)
    # Marks not attached to any test (e.g. a mark variable nobody uses): still checked.
    for node in ast.walk(tree):
        if _is_claim_call(node) and node.lineno not in seen_lines:
            marks.append(ClaimMark(res.resolve(node), path.name, None, node.lineno))
    return marks


def scan_claim_marks(suite_dir: Path = SUITE_DIR) -> list[ClaimMark]:
    """Every claim mark in ``suite_dir/test_*.py``; empty when the suite is absent."""
    if not Path(suite_dir).is_dir():
        return []
    marks = []
    for path in sorted(Path(suite_dir).glob("test_*.py")):
        marks += _scan_file(path)
    return marks


def claim_tests(suite_dir: Path = SUITE_DIR) -> dict[str, list[str]]:
    """claim id -> sorted ``file::test`` names of the tests that carry its mark."""
    out: dict[str, set[str]] = {}
    for mk in scan_claim_marks(suite_dir):
        if mk.test is not None:
            out.setdefault(mk.claim, set()).add(f"{mk.file}::{mk.test}")
    return {k: sorted(v) for k, v in out.items()}
