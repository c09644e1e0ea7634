"""Every built-in code is declared once, in its adapter, and everything else follows
(issue 37, item 3): the registry (`builtin_codes`) gives the report's side-by-side
variants, CI's and nox's install lines and the code names; a registered built-in adapter
whose test module, pytest marker, install line or docs row is missing fails here.

On main the lists were hand-written in six places (bench/codes.py, .ci/run, noxfile.py,
the pytest plugin's help and two test modules) and nothing checked them.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from reference_impl.adapters import registry
from reference_impl.adapters.base import CodeInfo, ContactAdapter
from reference_impl.adapters.registry import builtin_codes, parse_spec
from reference_impl.bench import codes as bench_codes

from .assertions import assert_true

ROOT = Path(__file__).resolve().parent.parent
_CALL = "builtin_codes()"
_CLAIM = "issue 37 item 3"


def _missing(name: str, info: CodeInfo) -> list[str]:
    """What a built-in code lacks: its test module (using its marker), the marker in
    pyproject.toml, an install line (a pip extra of pyproject.toml or a Debian package,
    and .ci/run installing the registry's lists), a row in docs/crosswalk.md, report
    variants of its own adapter."""
    py = tomllib.loads((ROOT / "pyproject.toml").read_text())
    markers = [m.split(":", 1)[0] for m in py["tool"]["pytest"]["ini_options"]["markers"]]
    extras = py["project"]["optional-dependencies"]
    ci = (ROOT / ".ci" / "run").read_text()
    out = []
    test = ROOT / info.test_module if info.test_module else None
    if test is None or not test.is_file():
        out.append(f"test module {info.test_module!r}")
    elif not re.search(rf"pytest\.mark\.{re.escape(info.marker)}\b", test.read_text()):
        out.append(f"marker {info.marker!r} in {info.test_module}")
    if not info.marker or info.marker not in markers:
        out.append(f"marker {info.marker!r} in pyproject.toml")
    if not ((info.extra and info.extra in extras) or info.apt):
        out.append(f"install extra {info.extra!r} in pyproject.toml (or an apt package)")
    if not ("adapters.registry extras" in ci and "adapters.registry apt" in ci):
        out.append(".ci/run installing the registry's extras and apt packages")
    if f"**{info.code}**" not in (ROOT / "docs" / "crosswalk.md").read_text():
        out.append(f"a **{info.code}** row in docs/crosswalk.md")
    if not info.report_variants or any(parse_spec(s)[0] != name for s, _ in info.report_variants):
        out.append(f"report variants of {name} ({info.report_variants!r})")
    return out


def test_registry_names_the_codes():
    got = list(builtin_codes())
    want = ["lammps", "liggghts", "kratos", "yade", "mujoco", "drake", "pybullet"]
    assert_true(got == want, got=got, should=want, claim=_CLAIM, call=_CALL)


@pytest.mark.parametrize("name", list(builtin_codes()))
def test_every_builtin_code_has_its_test_marker_install_and_docs_row(name):
    lacks = _missing(name, builtin_codes()[name])
    assert_true(not lacks, got=lacks, should="nothing missing", claim=_CLAIM, call=name)


def test_a_builtin_code_missing_its_parts_fails(monkeypatch):
    """The check above can fail: a code registered without any of its parts."""

    class Bare(ContactAdapter):
        name = "bare"
        code_info = CodeInfo(
            code="Bare", restitution_input="e", report_variants=(("bare[x]", 1.0),),
            extra="bare", marker="bare", test_module="verification/test_bare.py",
        )  # fmt: skip

    monkeypatch.setitem(registry._REGISTRY, "bare", Bare)
    monkeypatch.setattr(registry, "_BUILTIN", (*registry._BUILTIN, "bare"))
    lacks = _missing("bare", builtin_codes()["bare"])
    for part in ("test module", "pyproject.toml", "install extra", "crosswalk"):
        assert_true(any(part in x for x in lacks), got=lacks, should=f"names the missing {part}",
                    claim=_CLAIM, call="_missing(bare)")  # fmt: skip


def test_side_by_side_variants_come_from_the_registry():
    want = tuple((i.code, s, p) for i in builtin_codes().values() for s, p in i.report_variants)
    assert_true(bench_codes.CODES == want, got=bench_codes.CODES, should=want, claim=_CLAIM,
                call="bench.codes.CODES")  # fmt: skip


def test_install_lists_from_the_registry():
    extras, apt = registry.install_extras(), registry.apt_packages()
    assert_true(extras == ["lammps", "kratos", "mujoco", "drake", "pybullet"] and apt == ["liggghts", "yade"],
                got=(extras, apt), should="(lammps kratos mujoco drake pybullet, liggghts yade)", claim=_CLAIM,
                call="install_extras(), apt_packages()")  # fmt: skip
    nox = (ROOT / "noxfile.py").read_text()
    for name in builtin_codes():
        assert_true(f'"{name}"' not in nox and f"'{name}'" not in nox, got=f"{name!r} in noxfile.py",
                    should="no hand-written code names (the registry's)", claim=_CLAIM,
                    call="noxfile.py")  # fmt: skip
