"""The referee's erratum: what the paper prints, what the measurements establish instead.

Written from a results dict (``results.json`` of ``hcv report``): for each claim that does
not hold as printed, the printed statement (LaTeX quoted from the paper, with its section
and equation), the corrected statement where the measurements establish one, the decisive
numbers (read from the claim's measurement, never typed) and the commands that reproduce
them; one line for each claim that holds. The only text typed here is the paper's own
(`PRINTED`, checked against the .tex by the suite) and the wording around the numbers.

``python -m reference_impl.report._erratum [RESULTS] [-o OUT]`` writes it from a
results.json; `hcv report` writes ``erratum.md`` and a section of the report.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from reference_impl.report._blocks import UL, H, P
from reference_impl.report._blocks import markdown_lines as _md
from reference_impl.report._common import g

__all__ = ["PRINTED", "entries", "markdown", "blocks", "plain", "script_path"]

# claim id -> (where, equation number or None, LaTeX as printed; whitespace-normalised).
PRINTED = {
    "thm1-period": ("section 4, Theorem 1", 3, r"T(E)=2\pi\,\frac{dJ}{dE}."),
    "km-cancellation": (
        "section 5, Remark",
        None,
        r"The constants $K$ and $M$ are arbitrary; they cancel in all physically meaningful "
        r"expressions derived from the regularisation (e.g., the damping law and the stability bound).",
    ),
    "sec6-dt-safe-bound": (
        "section 6, after Eqs. (7)-(8)",
        None,
        r"The derived bound is rigorous: any physical timestep $\Delta t \le \Delta t_{\text{safe}}$ "
        r"guarantees stability for the nonlinear contact simulation.",
    ),
    "table1": (
        "section 10, Table 1",
        None,
        r"Theoretical lower bounds for the critical timestep ($\Delta t_{\text{safe}}$) evaluated at "
        r"maximum compression for the ellipsoid impact scenarios.",
    ),
    "fig1": (
        "section 10, text of Fig. 1",
        None,
        r"confirms that the Hamiltonian energy in this transformed space is conserved to machine "
        r"precision (relative error $< 3 \times 10^{-13}$)",
    ),
}
_TEX = [(r"\Delta t", "Δt"), (r"\frac{dJ}{dE}", "dJ/dE"), (r"\pi", "π"), (r"\,", " "), (r"\Delta", "Δ"), (r"\le", "≤"),
        (r"_{\text{safe}}", "_safe"), (r"\times 10^{-13}", "× 10^-13"), ("$", "")]


def plain(tex: str) -> str:
    """The LaTeX of a quote as plain text (the few macros the quotes use)."""
    for a, b in _TEX:
        tex = tex.replace(a, b)
    return re.sub(r"\s+", " ", tex).strip()


def script_path(claim_id: str) -> str:
    """The claim's independent reproduction script, relative to the checkout."""
    return f"reports/repro/{claim_id.replace('-', '_')}.py"


def _commands(c: dict, repro: str | None = None) -> str:
    """How to reproduce a claim; the script is linked only where ``repro`` says it lies
    (``repro_scripts`` of the dict being rendered, set by the writer from the directory the
    pages go to: a report written elsewhere links to no missing file)."""
    files = sorted({t.split("::")[0] for t in c.get("tests", [])})
    name = Path(script_path(c["id"])).name
    link = f", [{name}]({repro}/{name})" if repro else ""
    return (f"`python {script_path(c['id'])}` (independent{link}); `python reports/repro/run_all.py` "
            f"(compares with results.json); measurement: `hcv report`"
            + (f", `pytest {' '.join('verification/' + f for f in files)}`" if files else ""))


def _thm1(m: dict) -> tuple[str, str]:
    dev2 = max(r["abs_ratio_minus_2"] for r in m.values())
    dtc = max(r["abs_tc_over_2pi_dJdE_minus_1"] for r in m.values())
    cases = ", ".join(f"{n} {r['T_over_2pi_dJdE'][:12]}" for n, r in m.items())
    return ("T(E) = 4π dJ/dE (Eq. 3 and the last line of the proof); equivalently the contact "
            "time t_c = T/2 = 2π dJ/dE.",
            f"T/(2π dJ/dE) at 40 digits: {cases}; |ratio − 2| ≤ {g(dev2, 2)}; "
            f"|t_c/(2π dJ/dE) − 1| ≤ {g(dtc, 2)}.")


def _km(m: dict) -> tuple[str, str]:
    (k1, e1), (k2, e2) = m["restitution_fixed_C0"].items()
    return ("K and M cancel when the damping is given by ζ = C0/(2√(KM)); at fixed C0, the law of "
            "Eq. (11) scales as 1/√(KM) and the restitution depends on K and M. The stability bound "
            "(Eq. 7) is independent of K and M.",
            f"C at C0 = 0.5, (K, M) = (1, 0.75) over (1, 1): {m['C_ratio_K1_M075_over_K1_M1']:.10f}; "
            f"spread of C over {len(m['KM_pairs'])} (K, M) pairs at fixed C0: "
            f"{g(m['C_fixed_C0_spread'], 4)}; at fixed ζ: {g(max(m['C_fixed_zeta_spread']), 2)}; "
            f"Δt_safe: {g(max(m['dt_safe_spread']), 2)}; restitution (paper ellipsoid, 0.99 m/s, "
            f"C0 = 0.5): {e1:.6f} at {k1}, {e2:.6f} at {k2}.")


def _sec6(m: dict, r: dict) -> tuple[str, str]:
    w, k = m.get("worst_runaway") or {}, m["per_kind"]
    lin = m.get("linear_two_sided", {})
    rows = r.get("dt_crit_map", [])
    cases = ", ".join(dict.fromkeys(x["case"] for x in rows if not x["degenerate"]))
    degenerate = ", ".join(dict.fromkeys(x["case"] for x in rows if x["degenerate"]))
    impact = next((x["criterion"] for x in rows if x["scene"] == "impact"), "")
    slow = m.get("moves_with_horizon", {})
    return ("Withdrawn as a sufficient condition. Measured instead with velocity Verlet "
            f"({w.get('criterion', '')}): the smallest runaway step found on the search grid is "
            f"{w.get('ratio', float('nan')):.4f} Δt_safe, over the {m['usable_cases']} cases with "
            f"Δt_safe > 0 ({cases}; two-sided and two-walls scenes, and single impacts); Δt_crit = {g(lin.get('ratio'), 4)} Δt_safe for the linear spring, "
            f"two-sided; single impacts: no runaway at or below Δt_safe, accuracy limit ({impact}) "
            f"from {g(m.get('impact_accuracy_min_ratio'), 3)} Δt_safe. Δt_safe = 0 (no bound) for "
            f"{degenerate or 'none'}.",
            f"at or below Δt_safe in {m['usable_cases']} cases: {k['runaway']} runaways, "
            f"{k['bounded']} bounded excursions, {k['accuracy']} impact accuracy limits; worst runaway "
            f"{w.get('ratio', float('nan')):.4f} Δt_safe ({w.get('case')}, {w.get('scene')}); "
            f"{len(slow)} runaways have a Δt_crit that moves with the confirmation horizon "
            f"({', '.join(slow)}).")


def _table1(m: dict) -> tuple[str, str]:
    cells = []
    for row in m["rows"]:
        for col, name in (("delta_max", "δmax [mm]"), ("max_force", "U'(δmax) [N]"),
                          ("dt_safe", "Δt_safe [ms]")):
            cell = row[col]
            if not cell["match"]:
                cells.append(f"v0 = {row['v0']} m/s, {name}: {cell['printed']} → "
                             f"{cell['computed_rounded']}")
    return ("Corrected cells (recomputed at 50 digits from the printed inputs, rounded to the "
            "printed decimals; every digit shown is certain): " + "; ".join(cells) + ".",
            f"{m['mismatches']} of {m['cells']} cells differ; computed to 15 digits: "
            + "; ".join(f"v0 = {row['v0']}: " + ", ".join(row[c]["computed"] for c in
                        ("delta_max", "max_force", "dt_safe")) for row in m["rows"]) + ".")


def _fig1(m: dict) -> tuple[str, str]:
    cons = [x for x in m["runs"] if x["C0"] == 0]
    diss = [x for x in m["runs"] if x["C0"] > 0]
    ident = max(x["identity_err"] for x in m["runs"])
    return ("M x'²/2 + K x²/2 equals m q'²/2 + U(q) identically (Theorem 2, proof); its drift in a "
            "conservative run measures the integrator, not the harmonic structure. With C0 = 0.5 it "
            "is not conserved: it decays to e² at separation.",
            "C0 = 0, RK45 at RelTol = AbsTol = 1e-13: max |H/H0 − 1| = "
            + ", ".join(f"{g(x['drift'], 2)} (v0 = {x['v0']:g})" for x in cons)
            + f", printed bound {g(m['claimed'])}; C0 = 0.5: H_end/H0 = "
            + ", ".join(f"{x['H_end_over_H0']:.6f}" for x in diss)
            + f", e = {diss[0]['restitution']:.6f}; |H/E_phys − 1| ≤ {g(ident, 2)}.")


_CORRECTED = {"thm1-period": _thm1, "km-cancellation": _km, "table1": _table1, "fig1": _fig1}


def entries(results: dict) -> list[dict]:
    """One entry per claim: id, verdict, section, printed quote, corrected, numbers, commands."""
    out = []
    for c in results["claims"]:
        e = {"id": c["id"], "verdict": c["verdict"], "section": c["section"],
             "script": script_path(c["id"]), "commands": _commands(c, results.get("repro_scripts")), "headline": c["headline"]}
        if c["verdict"] != "verified":
            where, eq, tex = PRINTED.get(c["id"], (c["section"], None, c["statement"]))
            e["printed"] = f"{where}{f', Eq. ({eq})' if eq else ''}: “{plain(tex)}”"
            if c["id"] == "sec6-dt-safe-bound":
                e["corrected"], e["numbers"] = _sec6(c["measured"], results)
            elif c["id"] in _CORRECTED:
                e["corrected"], e["numbers"] = _CORRECTED[c["id"]](c["measured"])
            else:
                e["corrected"], e["numbers"] = "None established.", c["evidence"]
        out.append(e)
    return out


def blocks(results: dict, level: int = 2) -> list:
    """The erratum as report blocks (heading, one list per claim)."""
    es = entries(results)
    bad = [e for e in es if e["verdict"] != "verified"]
    out = [H(level, "Erratum", "erratum"),
           P(f"{len(bad)} of {len(es)} claims do not hold as printed. Numbers from the run of "
             f"{results['generated_utc']} ({results['mode']}); each claim's independent script "
             "(numpy, scipy, mpmath only) is named with it.")]
    for e in bad:
        out.append(H(level + 1, f"{e['id']} ({e['section']}): {e['verdict']}"))
        out.append(UL([f"Printed: {e['printed']}", f"Corrected: {e['corrected']}",
                       f"Measured: {e['numbers']}", f"Reproduce: {e['commands']}"]))
    out.append(H(level + 1, "Claims that hold"))
    out.append(UL([f"{e['id']} ({e['section']}): verified: {e['headline']}; script `{e['script']}`"
                   for e in es if e["verdict"] == "verified"]))
    return out


def markdown(results: dict) -> str:
    """reports/erratum.md."""

    out = ["# Erratum: " + results["title"].split(": ", 1)[-1] + "\n"]
    _md(blocks(results, level=2)[1:], out)
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    import json

    ap = argparse.ArgumentParser(description="write the erratum from a results.json")
    ap.add_argument("results", nargs="?", default="reports/results.json")
    ap.add_argument("-o", "--out", help="output file (default: stdout)")
    a = ap.parse_args(argv)
    results = json.loads(Path(a.results).read_text())
    if a.out:  # the scripts are linked only when they lie beside the file written
        from reference_impl.report._files import scripts_href

        results["repro_scripts"] = scripts_href(Path(a.out).absolute().parent)
    text = markdown(results)
    if a.out:
        Path(a.out).write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
