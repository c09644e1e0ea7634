"""Run every independent reproduction script and compare its numbers with results.json.

    python reports/repro/run_all.py [--results reports/results.json] [-j 2] [--json OUT]

Each script (``reports/repro/<claim>.py``, the claim id with ``-`` written ``_``) imports
only numpy, scipy and mpmath and prints one line per decisive number::

    REPRO {"name": ..., "value": ..., "ours": [path into results.json], "tol": ..., "mode": ..., "why": ...}

``mode`` says how ``value`` (theirs) is compared with the measurement at ``ours``:
``rel`` |theirs/ours - 1| <= tol; ``abs`` |theirs - ours| <= tol; ``below`` both <= tol
(round-off or integrator noise, whose digits carry no information); ``side`` both on the
same side of the threshold tol (>= tol or < tol: a verdict that rests on a printed bound);
``equal`` the same value; ``self`` (no path) a check of the script's own: |theirs| <= tol.
A path element that is a dict selects the list entry whose keys match it; the dict
``{"$max": KEY, "where": {...}}`` takes the largest KEY over the matching entries.

Prints a table (claim, number, ours, theirs, mode, tolerance, agreement). A number whose
path is absent from results.json (e.g. a --quick report) is "not measured": shown, never
counted as agreement. A disagreement listed in ``known_differences.json`` (the registry
the suite's strict xfails read) is shown as "known difference" with its cause and not
counted: only numbers no verdict rests on are listed there.

Exit status: 0 when every compared number agrees (and at least one was compared); 1 when
a number disagrees or a script fails; 2 when the results file cannot be used (unreadable,
not a results.json of ``hcv report``, holding none of the numbers, or a value at a
compared path that is not a number), with one line naming what.
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
KNOWN_FILE = HERE / "known_differences.json"
TIMEOUT_S = 120  # each script is meant to finish in < 30 s; this only stops a hung one
mpmath.mp.dps = 50
# Verdicts that fail the run; "known difference" and "not measured" do not.
FAILING = ("DISAGREES", "FAILED", "UNUSABLE")


class Unusable(ValueError):
    """A value in results.json (or printed by a script) that cannot be compared."""


def scripts(directory=HERE):
    """claim id -> script path, for every reproduction script in ``directory``."""
    return {
        p.stem.replace("_", "-"): p
        for p in sorted(directory.glob("*.py"))
        if p.name != "run_all.py" and not p.name.startswith("_")
    }


def known_differences(path=KNOWN_FILE):
    """(claim, number name) -> cause, from the registry of investigated disagreements."""
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    return {(d["claim"], d["number"]): d["cause"] for d in data["differences"]}


def run_script(path):
    """Run one script in a new process: (numbers, seconds, error text or None)."""
    t0 = time.perf_counter()
    try:
        p = subprocess.run(
            [sys.executable, str(path)],
            capture_output=True,
            text=True,
            errors="backslashreplace",
            timeout=TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        return [], time.perf_counter() - t0, f"timed out after {TIMEOUT_S} s"
    dt = time.perf_counter() - t0
    try:
        nums = [json.loads(line[6:]) for line in p.stdout.splitlines() if line.startswith("REPRO ")]
    except ValueError as exc:
        return [], dt, f"a REPRO line is not JSON ({exc})"
    err = (
        None
        if p.returncode == 0 and nums
        else f"exit {p.returncode}: {p.stderr.strip()[-800:] or 'no REPRO line'}"
    )
    return nums, dt, err


def path_text(path):
    """A path into results.json as one readable name: claims[id=fig1].measured.runs[...]."""
    out = ""
    for key in path or ():
        if isinstance(key, dict):
            out += "[" + ",".join(f"{k}={v}" for k, v in key.items()) + "]"
        elif isinstance(key, int):
            out += f"[{key}]"
        else:
            out += ("." if out else "") + str(key)
    return out


def number(x, where):
    """``x`` as an mpmath number; `Unusable` naming ``where`` when it is not one."""
    if isinstance(x, bool) or not isinstance(x, (int, float, str)):
        raise Unusable(f"{where} holds {x!r}, not a number")
    try:
        return mpmath.mpf(str(x).strip())
    except (ValueError, TypeError):
        raise Unusable(f"{where} holds {x!r}, not a number") from None


def resolve(results, path):
    """The value at ``path`` in results.json, or KeyError when it was not measured."""
    node = results
    for key in path:
        if isinstance(key, dict) and "$max" in key:
            where = key.get("where", {})
            hits = [
                e
                for e in node
                if isinstance(e, dict) and all(e.get(k) == v for k, v in where.items())
            ]
            if not hits or any(key["$max"] not in e for e in hits):
                raise KeyError(f"no entry {where} with {key['$max']}")
            values = [
                (number(e[key["$max"]], f"results.json at {path_text(path)}"), e[key["$max"]])
                for e in hits
            ]
            node = max(values, key=lambda v: v[0])[1]
        elif isinstance(key, dict):
            hits = [
                e
                for e in node
                if isinstance(e, dict) and all(e.get(k) == v for k, v in key.items())
            ]
            if not hits:
                raise KeyError(f"no entry {key}")
            node = hits[0]
        else:
            node = node[key]
    return node


def compare(theirs, ours, tol, mode, where="results.json"):
    """(agrees, |difference| as text) under the script's stated tolerance and mode.

    Raises `Unusable` (naming ``where``) when ``ours`` is not a number where one is
    compared; a script's own non-number is reported the same way, as the script's.
    """
    if mode == "equal":
        return theirs == ours, "" if theirs == ours else f"{theirs!r} != {ours!r}"
    b = number(ours, where)
    a = number(theirs, "the script's value")
    t = number(tol, "the script's tolerance")
    if mode == "below":
        ok = abs(a) <= t and abs(b) <= t
        return ok, "both below" if ok else "above"
    if mode == "side":
        side_a, side_b = (">=" if a >= t else "<"), (">=" if b >= t else "<")
        ok = side_a == side_b
        return ok, f"both {side_a} {tol}" if ok else f"theirs {side_a} {tol}, ours {side_b} {tol}"
    if mode == "abs":
        d = abs(a - b)
    elif mode == "rel":
        if b == 0:  # a relative difference to 0 is undefined: only 0 agrees with 0
            return a == 0, "" if a == 0 else "relative difference to 0 (results.json holds 0)"
        d = abs(a / b - 1)
    else:
        raise Unusable(f"unknown mode {mode!r}")
    return d <= t, mpmath.nstr(d, 3)


def check(results, outcomes, known=None):
    """Rows (claim, name, ours, theirs, tol, mode, verdict, diff) of every printed number."""
    known = known_differences() if known is None else known
    rows = []
    for claim, (nums, _dt, err) in outcomes.items():
        if err:
            rows.append(
                dict(
                    claim=claim,
                    name="(script)",
                    ours="",
                    theirs="",
                    tol="",
                    mode="",
                    verdict="FAILED",
                    diff=err,
                )
            )
        for n in nums:
            row = dict(
                claim=claim,
                name=str(n.get("name", "")),
                theirs=n.get("value"),
                tol=n.get("tol"),
                mode=n.get("mode", ""),
                why=n.get("why", ""),
            )
            if row["mode"] == "self":
                try:
                    ok = abs(number(row["theirs"], "the script's value")) <= number(
                        row["tol"], "the script's tolerance"
                    )
                except Unusable as exc:
                    rows.append({**row, "ours": "-", "verdict": "FAILED", "diff": str(exc)})
                    continue
                rows.append(
                    {
                        **row,
                        "ours": "-",
                        "verdict": "agrees" if ok else "DISAGREES",
                        "diff": "own check",
                    }
                )
                continue
            where = f"results.json at {path_text(n.get('ours'))}"
            try:
                row["ours"] = resolve(results, n["ours"])
            except (KeyError, IndexError, TypeError, AttributeError):
                rows.append({**row, "ours": None, "verdict": "not measured", "diff": ""})
                continue
            except Unusable as exc:
                rows.append({**row, "ours": None, "verdict": "UNUSABLE", "diff": str(exc)})
                continue
            try:
                ok, diff = compare(row["theirs"], row["ours"], row["tol"], row["mode"], where)
            except Unusable as exc:
                verdict = "UNUSABLE" if str(exc).startswith("results.json") else "FAILED"
                rows.append({**row, "verdict": verdict, "diff": str(exc)})
                continue
            if not ok and (claim, row["name"]) in known:
                rows.append(
                    {
                        **row,
                        "verdict": "known difference",
                        "diff": diff,
                        "cause": known[(claim, row["name"])],
                    }
                )
                continue
            rows.append({**row, "verdict": "agrees" if ok else "DISAGREES", "diff": diff})
    return rows


def outcome(rows):
    """(exit status, one summary line) of the rows: what the run concludes."""
    count = {
        v: sum(r["verdict"] == v for r in rows)
        for v in ("agrees", "known difference", "not measured", *FAILING)
    }
    # A script's own checks ("self") compare nothing with results.json.
    compared = sum(
        r["mode"] != "self" and r["verdict"] in ("agrees", "known difference", "DISAGREES")
        for r in rows
    )
    line = (
        f"{count['agrees']} of {len(rows)} numbers agree, {count['known difference']} known "
        f"differences (cause above), {count['not measured']} not measured, {count['DISAGREES']} "
        f"disagree, {count['UNUSABLE']} unusable in results.json, {count['FAILED']} failed"
    )
    if count["UNUSABLE"]:
        first = next(r for r in rows if r["verdict"] == "UNUSABLE")
        return 2, f"{line}: {first['claim']}, {first['name']}: {first['diff']}"
    if count["DISAGREES"] or count["FAILED"]:
        return 1, line
    if compared == 0:
        return 2, (
            f"nothing compared: results.json holds none of the {len(rows)} numbers the "
            "scripts print (a results.json of hcv report holds them)"
        )
    return 0, line


def _short(x):
    s = str(x)
    return s if len(s) <= 24 else s[:24] + "..."


def _load_results(name):
    """The results dict, or (None, one line saying why it cannot be used)."""
    try:
        results = json.loads(Path(name).read_text(encoding="utf-8"))
    except OSError as exc:
        return None, f"--results {name}: cannot be read ({exc.strerror or exc})"
    except ValueError as exc:
        return None, f"--results {name}: not JSON ({exc})"
    if not isinstance(results, dict):
        return (
            None,
            f"--results {name}: holds a {type(results).__name__}, should be the object hcv report writes",
        )
    if not isinstance(results.get("claims"), list) or not results["claims"]:
        return None, (
            f"--results {name}: holds no list of claims (keys {sorted(results)[:6]}); "
            "nothing to compare"
        )
    return results, None


def main(argv=None):
    # The table is ASCII; a script's name that is not is escaped rather than crash an
    # ASCII terminal (PYTHONIOENCODING=ascii).
    for stream in (sys.stdout, sys.stderr):
        if hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", default=str(HERE.parent / "results.json"))
    ap.add_argument("-j", type=int, default=2, help="scripts run in parallel (default 2)")
    ap.add_argument("--json", help="write the rows and runtimes to this file")
    args = ap.parse_args(argv)
    results, why = _load_results(args.results)
    if why:
        print(f"run_all: {why}", file=sys.stderr)
        return 2
    found = scripts()
    with ThreadPoolExecutor(max(1, args.j)) as pool:
        outcomes = dict(zip(found, pool.map(run_script, found.values()), strict=True))
    rows = check(results, outcomes)
    status, line = outcome(rows)
    if status == 2 and not any(r["verdict"] == "UNUSABLE" for r in rows):
        print(f"run_all: --results {args.results}: {line}", file=sys.stderr)
        return status
    print(
        f"{'claim':24} {'number':70} {'ours (results.json)':26} {'theirs (script)':26} {'tol':8} agreement"
    )
    for r in rows:
        print(
            f"{r['claim']:24} {r['name'][:70]:70} {_short(r['ours']):26} {_short(r['theirs']):26} "
            f"{r['mode']} {r['tol']!s:8} {r['verdict']} {r['diff']}"
        )
    causes = {}  # cause -> the numbers it explains (one cause often explains several)
    for r in rows:
        if r["verdict"] == "known difference":
            causes.setdefault((r["claim"], r["cause"]), []).append(r["name"])
    if causes:
        print(f"\nknown differences ({KNOWN_FILE.name}; no verdict rests on them):")
        for (claim, cause), names in causes.items():
            print(f"  {claim}, {'; '.join(names)}: {cause}")
    print("\nruntime per script: " + ", ".join(f"{c} {o[1]:.1f} s" for c, o in outcomes.items()))
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {"rows": rows, "seconds": {c: o[1] for c, o in outcomes.items()}},
                indent=1,
                default=str,
            )
        )
    print(line)
    return status


if __name__ == "__main__":
    sys.exit(main())
