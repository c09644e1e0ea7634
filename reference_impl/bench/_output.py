"""Writing the bench's JSON and JUnit files: statuses the table module does not know yet
("error": our reference failed) and the mode of a new file (not mkstemp's 0600)."""

from __future__ import annotations

import json
import os

__all__ = ["write_json", "write_junit"]


def _public_mode(path) -> None:
    """Give a written report the mode of a new file (0666 less the umask), not mkstemp's 0600."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(path, 0o666 & ~mask)


def write_json(result, path) -> None:
    """The JSON report; status "error" when only our reference failed (no metric failed)."""
    from .report import _atomic_write, result_to_dict

    doc = result_to_dict(result)
    if doc.get("status") == "pass" and result.internal_errors:
        doc["status"] = "error"
    _atomic_write(path, json.dumps(doc, indent=2) + "\n")
    _public_mode(path)


def write_junit(result, path) -> None:
    """JUnit XML; a metric our reference could not decide is an <error>, not a pass."""
    import xml.etree.ElementTree as ET

    from .report import _atomic_write, junit_tree

    tree = junit_tree(result)
    errors = {(f"hcv.bench.{m.variant}.{m.scene}", m.metric): m for m in result.internal_errors}
    root = tree.getroot()
    for suite in root.iter("testsuite"):
        n = 0
        for case in suite.iter("testcase"):
            m = errors.get((case.get("classname"), case.get("name")))
            if m is None:
                continue
            for child in list(case):
                case.remove(child)
            ET.SubElement(case, "error", message=m.explanation, type="ReferenceError")
            n += 1
        suite.set("errors", str(n))
    root.set("errors", str(len(errors)))
    ET.indent(tree)
    _atomic_write(path, ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n")
    _public_mode(path)
