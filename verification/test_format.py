"""The tree is held to ruff, linter and formatter, in every test run (issue 37 item 6).

`nox -s lint` runs the same two commands over the same paths (``LINT_PATHS`` and the pinned
``RUFF`` of noxfile.py, read here from its source so the two cannot drift apart).
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from .assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]


def _noxfile_constant(name: str):
    tree = ast.parse((ROOT / "noxfile.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == name for t in node.targets
        ):
            return ast.literal_eval(node.value)
    raise AssertionError(f"noxfile.py defines no {name}")


def _ruff() -> str:
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if ruff is None:
        pytest.skip("ruff is not installed (pip install -e '.[test]')")
    return ruff


def test_the_pinned_ruff_is_the_one_installed_with_the_tests():
    """The [test] extra and noxfile.py pin the same ruff (a formatter of another release
    would reformat the tree)."""
    pin = _noxfile_constant("RUFF")
    extra = (ROOT / "pyproject.toml").read_text()
    assert_true(
        f'"{pin}"' in extra,
        got=f"noxfile RUFF = {pin!r}",
        should="the same pin in pyproject.toml's [test] extra",
        claim="meta",
        call="noxfile.py RUFF vs pyproject.toml",
    )


@pytest.mark.parametrize("command", [["check"], ["format", "--check"]], ids=["check", "format"])
def test_ruff_finds_nothing(command):
    """``ruff check`` and ``ruff format --check`` over LINT_PATHS pass."""
    ruff = _ruff()
    version = subprocess.run([ruff, "--version"], capture_output=True, text=True, timeout=60)
    pin = _noxfile_constant("RUFF").split("==")[1]
    if pin not in version.stdout:
        pytest.skip(
            f"ruff {version.stdout.strip()} is not the pinned {pin} (pip install -e '.[test]')"
        )
    paths = _noxfile_constant("LINT_PATHS")
    p = subprocess.run(
        [ruff, *command, "--no-cache", *paths],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert_true(
        p.returncode == 0,
        got=(p.stdout + p.stderr)[-1500:],
        should="no finding (run `ruff "
        + " ".join(command).replace(" --check", "")
        + "` and commit)",
        claim="meta",
        call=f"ruff {' '.join(command)} {' '.join(paths)}",
    )
