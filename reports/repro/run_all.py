"""Run every independent reproduction script and compare its numbers with results.json.

    python reports/repro/run_all.py [--results reports/results.json] [-j 2] [--json OUT]

Each script (``reports/repro/<claim>.py``, the claim id with ``-`` written ``_``) imports
only numpy, scipy and mpmath and prints one line per decisive number::

    REPRO {"name": ..., "value": ..., "ours": [path into results.json], "tol": ..., "mode": ..., "why": ...}

``mode`` says how ``value`` (theirs) is compared with the measurement at ``ours``:
``rel`` |theirs/ours - 1| <= tol; ``abs`` |theirs - ours| <= tol; ``below`` both <= tol
(round-off or integrator noise, whose digits carry no information); ``equal`` the same
value; ``self`` (no path) a check of the script's own: |theirs| <= tol. A path element that is a dict selects the list entry whose keys match it.
Prints a table (claim, number, ours, theirs, tolerance, agreement) and exits 0 when every
number agrees, 1 when one disagrees or a script fails. A number whose path is absent
from results.json (e.g. a --quick report) is "not measured": shown, never counted as
agreement.
"""
import argparse
import json
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import mpmath

HERE = Path(__file__).resolve().parent
TIMEOUT_S = 120  # each script is meant to finish in < 30 s; this only stops a hung one
mpmath.mp.dps = 50


def scripts(directory=HERE):
    """claim id -> script path, for every reproduction script in ``directory``."""
    return {p.stem.replace("_", "-"): p for p in sorted(directory.glob("*.py"))
            if p.name != "run_all.py" and not p.name.startswith("_")}


def run_script(path):
    """Run one script in a new process: (numbers, seconds, error text or None)."""
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return [], time.perf_counter() - t0, f"timed out after {TIMEOUT_S} s"
    dt = time.perf_counter() - t0
    nums = [json.loads(line[6:]) for line in p.stdout.splitlines() if line.startswith("REPRO ")]
    err = None if p.returncode == 0 and nums else f"exit {p.returncode}: {p.stderr.strip()[-800:] or 'no REPRO line'}"
    return nums, dt, err


def resolve(results, path):
    """The value at ``path`` in results.json, or KeyError when it was not measured."""
    node = results
    for key in path:
        if isinstance(key, dict):
            hits = [e for e in node if all(e.get(k) == v for k, v in key.items())]
            if not hits:
                raise KeyError(f"no entry {key}")
            node = hits[0]
        elif isinstance(node, list):
            node = node[key]
        else:
            node = node[key]
    return node


def compare(theirs, ours, tol, mode):
    """(agrees, |difference| as text) under the script's stated tolerance and mode."""
    if mode == "equal":
        return theirs == ours, "" if theirs == ours else f"{theirs!r} != {ours!r}"
    a, b, tol = mpmath.mpf(str(theirs)), mpmath.mpf(str(ours)), mpmath.mpf(str(tol))
    if mode == "below":
        return abs(a) <= tol and abs(b) <= tol, "both below" if abs(a) <= tol and abs(b) <= tol else "above"
    d = abs(a - b) if mode == "abs" else abs(a / b - 1)
    return d <= tol, mpmath.nstr(d, 3)


def check(results, outcomes):
    """Rows (claim, name, ours, theirs, tol, mode, verdict, diff) of every printed number."""
    rows = []
    for claim, (nums, _dt, err) in outcomes.items():
        if err:
            rows.append(dict(claim=claim, name="(script)", ours="", theirs="", tol="", mode="", verdict="FAILED", diff=err))
        for n in nums:
            row = dict(claim=claim, name=n["name"], theirs=n["value"], tol=n["tol"], mode=n["mode"], why=n.get("why", ""))
            if n["mode"] == "self":
                ok = abs(mpmath.mpf(str(n["value"]))) <= mpmath.mpf(str(n["tol"]))
                rows.append({**row, "ours": "–", "verdict": "agrees" if ok else "DISAGREES", "diff": "own check"})
                continue
            try:
                row["ours"] = resolve(results, n["ours"])
            except (KeyError, IndexError, TypeError):
                rows.append({**row, "ours": None, "verdict": "not measured", "diff": ""})
                continue
            ok, diff = compare(n["value"], row["ours"], n["tol"], n["mode"])
            rows.append({**row, "verdict": "agrees" if ok else "DISAGREES", "diff": diff})
    return rows


def _short(x):
    s = str(x)
    return s if len(s) <= 24 else s[:24] + "…"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=str(HERE.parent / "results.json"))
    ap.add_argument("-j", type=int, default=2, help="scripts run in parallel (default 2)")
    ap.add_argument("--json", help="write the rows and runtimes to this file")
    args = ap.parse_args(argv)
    results = json.loads(Path(args.results).read_text())
    found = scripts()
    with ThreadPoolExecutor(max(1, args.j)) as pool:
        outcomes = dict(zip(found, pool.map(run_script, found.values()), strict=True))
    rows = check(results, outcomes)
    print(f"{'claim':24} {'number':70} {'ours (results.json)':26} {'theirs (script)':26} {'tol':8} agreement")
    for r in rows:
        print(f"{r['claim']:24} {r['name'][:70]:70} {_short(r['ours']):26} {_short(r['theirs']):26} "
              f"{r['mode']} {r['tol']!s:8} {r['verdict']} {r['diff']}")
    print("\nruntime per script: " + ", ".join(f"{c} {o[1]:.1f} s" for c, o in outcomes.items()))
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "seconds": {c: o[1] for c, o in outcomes.items()}},
                                              indent=1, default=str))
    bad = [r for r in rows if r["verdict"] in ("DISAGREES", "FAILED")]
    print(f"{len(rows) - len(bad)} of {len(rows)} numbers agree or were not measured; {len(bad)} disagree or failed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
