"""Sphinx configuration of the documentation site (``nox -s docs``).

The pages are Markdown (MyST), so ``adapter-protocol.md`` and the README's generated
blocks are read where they live; the API pages come from the numpydoc docstrings.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(_ROOT))  # the checkout's reference_impl, installed or not

from reference_impl import __version__  # noqa: E402
from reference_impl.theory.laws.docs_table import fill_source  # noqa: E402

project = "hidden-harmonic-verification"
author = "hidden-harmonic-verification contributors"
release = __version__
version = __version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "numpydoc",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "examples"]
# Headings become anchors (#how-the-step-is-chosen), as GitHub renders them, so the
# adapter protocol's own links work here unchanged.
myst_heading_anchors = 4
myst_enable_extensions = ["dollarmath"]

# numpydoc: the docstrings' sections as tables; no autosummary stubs of every member
# (the reference pages list what they document).
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the numpydoc Parameters section already gives type and unit

html_theme = "furo"
html_title = "hidden-harmonic-verification"
html_static_path = ["_static"]
html_css_files = ["tables.css"]
html_show_sourcelink = False


def _copy_report(app, exception) -> None:
    """Put the committed report (one self-contained HTML file) at ``report/index.html``
    of the site, so the verdict pages link to the report the checkout holds, with the
    referee's scripts its erratum links to (``repro/*.py``) beside it."""
    if exception is not None or app.builder.format != "html":
        return
    src = _ROOT / "reports"
    dest = Path(app.outdir) / "report"
    dest.mkdir(exist_ok=True)
    shutil.copy2(src / "index.html", dest / "index.html")
    shutil.copytree(
        src / "repro",
        dest / "repro",
        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"),
        dirs_exist_ok=True,
    )


def setup(app):
    # The damping-law table: every registered law's row, filled in as a page is read.
    app.connect("source-read", fill_source)
    app.connect("build-finished", _copy_report)
