"""Hostile results files, their paths: the report embeds only its own figures (issue 36).

A results.json is the file users share, and ``hcv report`` carries the previous one's
code sections, so it may come from anyone (a pull request). A figure that is not
``figures/NAME.png`` inside the report, a regular file (not a link), at most 20 MiB, with
the PNG signature (``/proc/self/environ``, ``/dev/zero``, ``../x.png``, absolute paths,
links out, a text file named .png, an oversized file, a FIFO), and a scorecard linked out,
through ``hcv report --from`` and through the carry: each refused in one line naming the
JSON path of the field, exit status 2, nothing written, and no file outside the report
opened. Links, markup and the schema: ``test_hostile_report.py``.

Fast: nothing is measured; each case renders the committed results at most once.
"""

from __future__ import annotations

import copy
import json
import os
import shutil
import socket
from pathlib import Path

import pytest

from reference_impl.campaign import _carry
from reference_impl.report._inputs import MAX_BYTES, PNG_SIGNATURE
from verification._hostile_report_cases import (
    CLAIM,
    committed_copy,
    opened_outside,
    recording,
    refused,
    run_from,
    source,
)
from verification.assertions import assert_true


@pytest.fixture
def committed():
    """A fresh copy of the (trimmed) committed results."""
    return committed_copy()


@pytest.fixture
def outside(tmp_path_factory):
    """A directory outside every report, holding a secret PNG and a secret scorecard."""
    d = tmp_path_factory.mktemp("outside")
    (d / "secret.png").write_bytes(PNG_SIGNATURE + b"SECRET-PNG")
    (d / "secret.json").write_text('{"SECRET": 1}')
    return d


# ----------------------------------------------------------------------------------
# 1. paths
# ----------------------------------------------------------------------------------
def _steps_index(doc, name="steps_lammps.png") -> int:
    return doc["figures"].index(f"figures/{name}")


def _poison(case: str, doc: dict, src: Path, outside: Path) -> str:
    """Make ``case`` in the document or the files; return the needle the refusal must name."""
    steps = "$.steps_per_contact[0].figure"
    figure = {
        "steps figure /proc/self/environ": "/proc/self/environ",
        "steps figure /dev/zero": "/dev/zero",
        "steps figure ../x.png": "../x.png",
        "steps figure absolute": str(outside / "secret.png"),
        "steps figure not listed": "steps_nowhere.png",
        "steps figure with a final newline": "steps_lammps.png\n",
    }
    if case in figure:
        doc["steps_per_contact"][0]["figure"] = figure[case]
        return steps
    if case == "figures entry absolute":
        doc["figures"].append(str(outside / "secret.png"))
        return f"$.figures[{len(doc['figures']) - 1}]"
    i = _steps_index(doc)
    target = src / "figures" / "steps_lammps.png"
    if case == "figure a link out":
        target.unlink()
        target.symlink_to(outside / "secret.png")
        return f"$.figures[{i}]"
    if case == "figures/ a link out":
        shutil.copytree(src / "figures", outside / "figs")
        shutil.rmtree(src / "figures")
        (src / "figures").symlink_to(outside / "figs")
        return "$.figures[0]"
    if case == "text file named .png":
        target.write_text("SECRET text, not an image")
        return "no PNG signature"
    if case == "oversized figure":
        with open(target, "r+b") as f:  # sparse: cheap to make, 1 byte over the bound
            f.truncate(MAX_BYTES + 1)
        return "over the bound"
    if case == "FIFO as a figure":
        target.unlink()
        os.mkfifo(target)
        return "not a regular file"
    if case == "a directory as a figure":
        target.unlink()
        target.mkdir()
        return f"$.figures[{i}]: 'figures/steps_lammps.png' is not a regular file"
    if case == "a socket as a figure":
        target.unlink()
        sock = socket.socket(socket.AF_UNIX)  # closed with the test; the name stays bound
        sock.bind(str(target))
        sock.close()
        return f"$.figures[{i}]: 'figures/steps_lammps.png' is not a regular file"
    if case == "scorecard a link out":
        (src / "bench").mkdir()
        (src / "bench" / f"{doc['adapters'][0]['adapter']}.json").symlink_to(
            outside / "secret.json"
        )
        return "$.adapters[0].adapter"
    raise AssertionError(case)


PATH_CASES = [
    "steps figure /proc/self/environ",
    "steps figure /dev/zero",
    "steps figure ../x.png",
    "steps figure absolute",
    "steps figure not listed",
    "steps figure with a final newline",
    "figures entry absolute",
    "figure a link out",
    "figures/ a link out",
    "text file named .png",
    "oversized figure",
    "FIFO as a figure",
    "a directory as a figure",  # was "hcv: error: 4: Is a directory" (os.fdopen's message)
    "a socket as a figure",  # was "... No such device or address" (open's ENXIO)
    "scorecard a link out",
]


@pytest.mark.parametrize("case", PATH_CASES)
def test_a_path_outside_the_rule_is_refused_and_nothing_outside_is_read(
    committed, tmp_path, outside, capsys, case
):
    if not committed["steps_per_contact"]:
        pytest.skip("the committed report has no contact codes")
    doc = copy.deepcopy(committed)
    src = source(tmp_path, doc)
    needle = _poison(case, doc, src, outside)
    (src / "results.json").write_text(json.dumps(doc))
    out = tmp_path / "out"
    code, err, opened = run_from(src, out, capsys)
    targets = [str(outside), "/proc/self/environ", f"/proc/{os.getpid()}/environ", "/dev/zero"]
    refused(code, err, out, needle, opened, targets, f"hcv report --from ({case})")


@pytest.mark.parametrize("case", ["steps figure /proc/self/environ", "figure a link out"])
def test_a_poisoned_previous_report_is_not_carried(committed, tmp_path, outside, case):
    """The carry reads the previous results.json as --from does: nothing is carried (so
    nothing is embedded in the next report), and the line says which field."""
    if not committed["adapters"]:
        pytest.skip("the committed report has no contact codes")
    doc = copy.deepcopy(committed)
    out = source(tmp_path, doc)
    needle = _poison(case, doc, out, outside)
    (out / "results.json").write_text(json.dumps(doc))
    with recording() as opened:
        data, note = _carry(out, [])
    leaked = opened_outside(
        opened, [str(outside), "/proc/self/environ", f"/proc/{os.getpid()}/environ"]
    )
    assert_true(
        data is None and needle in note and "\n" not in note and not leaked,
        got=f"carried {None if data is None else sorted(data)}; note {note!r}; opened {leaked}",
        should=f"nothing carried, the note naming {needle!r}, nothing outside opened",
        claim=CLAIM,
        call=f"campaign._carry ({case})",
    )
