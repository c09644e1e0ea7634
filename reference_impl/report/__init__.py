"""The report's pages, rendered from a results dict: HTML, Markdown and the erratum.

Nothing here computes: `write_pages` renders a results dict (``results.json``, schema
`SCHEMA`, documented in `reference_impl.report._schema`) and the figures beside it into

* ``index.html`` -- one self-contained page (figures embedded as data URIs);
* ``index.md`` -- the same content for a code host (figures linked);
* ``erratum.md`` -- the referee's erratum (`_erratum`), also a section of both pages.

`render_from` (``hcv report --from results.json [--out DIR]``) re-renders a written
report without running anything: it checks the file, copies it, its figures and its
codes' scorecards (``bench/*.json``) into ``DIR`` and renders the pages there. The studies
that produce the results dict run in `reference_impl.campaign` (``hcv report``).

Every number in the output comes from the results dict; the only numbers typed in the
renderer are the paper's own (quoted by the claim modules) and the wording around them.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from reference_impl.report import _erratum, _render
from reference_impl.report._files import (
    _adapter_json,
    scripts_href,
    swap_in,
    validate_report_args,
)
from reference_impl.report._inputs import read_report_file
from reference_impl.report._schema import SCHEMA, check_results, read_results

__all__ = [
    "SCHEMA",
    "bench_json_name",
    "check_results",
    "read_results",
    "render_from",
    "validate_report_args",
    "write_pages",
]


def bench_json_name(spec: str) -> str:
    """Where a report stores a code's scorecard, relative to its directory."""
    return _adapter_json(spec)


def write_pages(results: dict, out: Path, fig_dir: Path, repro: str | None = None) -> None:
    """Write index.md, erratum.md and index.html of ``results`` into ``out``.

    Parameters
    ----------
    results : dict
        A results dict of schema `SCHEMA` (JSON-ready).
    out : Path
        Directory written.
    fig_dir : Path
        Where the figures named in ``results["figures"]`` are (embedded in index.html).
    repro : str, optional
        The link from the final report directory to the referee's scripts
        (`reference_impl.report._files.scripts_href`); None: they are not there, and the
        pages name them without a link.
    """
    out = Path(out)
    # Where the scripts lie depends on the final directory, not on the results: the pages
    # get it, results.json does not (copied elsewhere, it would link wrongly).
    pages = {**results, "repro_scripts": repro}
    (out / "index.md").write_text(_render.markdown(pages))
    (out / "erratum.md").write_text(_erratum.markdown(pages))
    (out / "index.html").write_text(_render.html_page(pages, Path(fig_dir)))


def render_from(results_path, out_dir="reports", force: bool = False) -> dict:
    """Re-render a report from its results.json; nothing is run.

    Parameters
    ----------
    results_path : str or Path
        A results.json of schema `SCHEMA`; its figures (and the codes' scorecards, when
        present) are read from its directory.
    out_dir : str or Path
        Where the report is written (as ``hcv report --out``: the manifest rules of
        `reference_impl.report._files` apply, and the files move in only when complete).
        The pages link the referee's scripts only where ``out_dir`` holds them
        (``repro/``: the checkout's reports/).
    force : bool
        Write into a directory holding files the report did not write.

    Returns
    -------
    dict
        The results dict.

    Raises
    ------
    HCVInputError
        An unreadable or malformed results.json, a figure it names that is missing or not
        a regular PNG file inside its directory, a scorecard that is a link or not a
        regular file, or a bad output directory; before anything is written.
    """
    src = Path(results_path)
    results = read_results(src)  # the document and every figure it names, checked
    base = src.resolve().parent
    name = f"--from {str(src)!r}"
    out, _ = validate_report_args(out_dir, (), force=force)
    with swap_in(out) as tmp:
        (tmp / "figures").mkdir()
        shutil.copyfile(src, tmp / "results.json")
        for i, rel in enumerate(results["figures"]):
            (tmp / rel).write_bytes(read_report_file(base, rel, f"{name}: $.figures[{i}]"))
        for i, doc in enumerate(results["adapters"]):
            rel = bench_json_name(doc["adapter"])
            if os.path.lexists(base / rel):  # a scorecard is optional; a link is refused
                data = read_report_file(base, rel, f"{name}: $.adapters[{i}].adapter", png=False)
                (tmp / "bench").mkdir(exist_ok=True)
                (tmp / rel).write_bytes(data)
        write_pages(results, tmp, tmp / "figures", scripts_href(out))
    return results
