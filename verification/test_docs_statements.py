"""What the README, the docs and pyproject.toml state, against the files they describe
(issue 41, section 3).

Each test reads the statement and the thing it is about: the kind of each example sweep
spec the sweeps page names, the contact codes the overview lists against the built-in
adapters, the packaging metadata, and no claim that the MyST pages read on GitHub.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from reference_impl.adapters.registry import builtin_codes
from verification.assertions import assert_true

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
# The contact codes the built-in adapters drive, as the pages name them (the first word of
# each `CodeInfo.code`: "Kratos DEM" is "Kratos"), from the registry, never by hand.
CODES = tuple(info.code.split()[0] for info in builtin_codes().values())


def _paragraphs(path: Path) -> list[str]:
    """The text of ``path`` split at blank lines (fenced code left out)."""
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    return [" ".join(p.split()) for p in re.split(r"\n\s*\n", text) if p.strip()]


def test_the_sweeps_page_names_each_example_specs_kind():
    """`docs/sweeps.md` says which task each example spec runs: it is the spec's own
    (it called sweep-mujoco-dampratio.toml, a bench: spec, a calibrate: one)."""
    text = " ".join((DOCS / "sweeps.md").read_text().split())
    stated = re.findall(r"`docs/examples/([\w.-]+\.toml)` (?:is )?an? `(\w+):`", text)
    actual = {
        name: tomllib.loads((DOCS / "examples" / name).read_text())["task"].split(":")[0]
        for name, _ in stated
    }
    wrong = [(n, k, actual[n]) for n, k in stated if actual[n] != k]
    assert_true(
        bool(stated) and not wrong,
        got=f"stated {stated}; wrong (file, stated, actual): {wrong}",
        should="each named spec's kind equal to its task's prefix",
        claim="docs",
        call="docs/sweeps.md against docs/examples/*.toml",
    )


def test_the_overview_lists_every_builtin_code():
    """Where the README, the site's index or Getting started list the codes (a paragraph
    naming LAMMPS and MuJoCo), every other built-in code is in the list too."""
    missing = []
    for path in (
        ROOT / "README.md",
        *(DOCS / f for f in ("index.md", "getting-started.md", "verdicts.md")),
    ):
        for para in _paragraphs(path):
            if "LAMMPS" in para and "MuJoCo" in para:
                gone = [c for c in CODES if c not in para]
                if gone:
                    missing.append((path.name, gone, para[:100]))
    assert_true(
        len(CODES) >= 2 and not missing,
        got=f"{missing[:3]}",
        should=f"every list of codes naming {CODES} (the registry's built-in codes)",
        claim="docs",
        call="README.md, docs/index.md, docs/getting-started.md, docs/verdicts.md",
    )


def test_the_main_jobs_rewritten_files_include_the_hard_cases_figure():
    """Getting started lists what `git status` shows after the main job; on a fresh clone
    it showed figures/hard_cases.png too (issue 41), which the list left out."""
    para = next(p for p in _paragraphs(DOCS / "getting-started.md") if "git status" in p)
    assert_true(
        "hard_cases.png" in para and "results.json" in para,
        got=para[:300],
        should="the list naming figures/hard_cases.png",
        claim="docs",
        call="docs/getting-started.md",
    )


def test_no_page_claims_to_read_on_github_while_it_uses_myst_syntax():
    """MyST roles (``{doc}``) and directives (```` ```{include} ````) show raw on GitHub:
    while a page uses them, no page says the pages read there."""
    myst = sorted(
        p.name for p in DOCS.glob("*.md") if re.search(r"\{(doc|ref|include)\}", p.read_text())
    )
    claims = [
        p.name
        for p in (ROOT / "README.md", *DOCS.glob("*.md"))
        if re.search(r"read(s)? on GitHub too|read on GitHub", p.read_text())
    ]
    assert_true(
        not (myst and claims),
        got=f"claims in {claims}; MyST syntax in {myst}",
        should="no claim that the pages read on GitHub while they use MyST syntax",
        claim="docs",
        call="README.md, docs/*.md",
    )


def test_packaging_metadata_is_current():
    """The SPDX license string (the `{text = ...}` table is deprecated, setuptools warned
    12 times a CI run), a setuptools that reads it (77), and the sweep extra with what its
    summary figure needs (matplotlib: without it summary.png was silently not written)."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    requires = meta["build-system"]["requires"]
    sweep = meta["project"]["optional-dependencies"]["sweep"]
    ok = (
        meta["project"]["license"] == "MIT"
        and "setuptools>=77" in requires
        and any(d.startswith("matplotlib") for d in sweep)
    )
    assert_true(
        ok,
        got=f"license {meta['project']['license']!r}, requires {requires}, sweep {sweep}",
        should="license 'MIT', setuptools>=77, matplotlib in the sweep extra",
        claim="docs",
        call="pyproject.toml",
    )
