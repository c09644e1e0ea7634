"""Report section: the contact codes side by side, asked e -> delivered e (issue 28).

Rendered from results.json ``codes_side_by_side`` (measured by
`reference_impl.campaign._codes`): one table per pair of speeds (the lowest and each
other), one row per code variant, one column per asked restitution; each cell is
"e(N_fine) / e(N_coarse)" at the lowest speed, marked † where the other speed delivers
an e differing by more than the settings' ``speed_tolerance``, flagged (bold) where a
delivered e is further than ``asked_tolerance`` from the asked one; then the pull at the
end of contact and the input that delivers the asked e. The declared laws' exact e, the
marked cells' values and the variants that did not run are listed below the table.
"""

from __future__ import annotations

import math

from reference_impl.report._blocks import UL, H, P, T

__all__ = ["codes_blocks"]


def _f(x, fmt="{:.4f}") -> str:
    return fmt.format(x) if isinstance(x, (int, float)) and math.isfinite(x) else "-"


def _variants(rows) -> list[tuple[str, str]]:
    """(spec, shown name) of each variant, in the order run."""
    seen: dict[str, str] = {}
    for r in rows:
        seen.setdefault(r["spec"], f"{r['code']}: `{r['variant']}`")
    return list(seen.items())


def _calibration_cell(cal: list[dict]) -> str:
    parts = []
    for c in cal:
        if c.get("error"):
            parts.append(f"e = {c['asked']:g}: not run ({c['error']})")
        elif c.get("found"):
            parts.append(f"e = {c['asked']:g}: {c['option']} = {c['value']:.5g}")
        else:
            lo, hi = (c.get("delivered") or [None, None])[:2]
            parts.append(
                f"e = {c['asked']:g}: out of reach ({c['option']} over its range delivers "
                f"{_f(lo)} to {_f(hi)})"
            )
    return "; ".join(parts) or "-"


def _table(sec: dict, lo: float, hi: float) -> tuple[list, list, list, list[str], list[str]]:
    """One speed pair: header, rows, flags, the † notes and the declared-law notes."""
    st = sec["settings"]
    fine, coarse = max(st["steps_per_contact"]), min(st["steps_per_contact"])
    at = {(r["spec"], r["asked"], r["steps_per_contact"], r["v0"]): r for r in sec["rows"]}
    cal = sec.get("calibration") or []
    header = [
        "code: variant",
        *[f"asked e = {e:g}: e({fine}) / e({coarse})" for e in st["asked"]],
        f"largest pull, % of peak force (e = {' / '.join(f'{e:g}' for e in st['asked'])}, "
        f"N = {fine})",
        "input that delivers the asked e (calibration)",
    ]
    rows, flags, marks, declared = [], [], [], []
    for spec, name in _variants(sec["rows"]):
        cells, fl, exact = [name], [None], []
        for e in st["asked"]:
            a = [at.get((spec, e, n, lo), {}).get("delivered") for n in (fine, coarse)]
            b = [at.get((spec, e, n, hi), {}).get("delivered") for n in (fine, coarse)]
            ok = [isinstance(x, float) for x in a + b]
            cell = f"{_f(a[0])} / {_f(a[1])}"
            if all(ok) and max(abs(a[0] - b[0]), abs(a[1] - b[1])) > st["speed_tolerance"]:
                cell += " †"
                marks.append(f"{name}, asked {e:g}: {_f(b[0])} / {_f(b[1])} at {hi:g} m/s")
            off = [x for x in a if isinstance(x, float) and abs(x / e - 1) > st["asked_tolerance"]]
            cells.append(cell)
            fl.append("bad" if off else None)
            exact.append(_f(at.get((spec, e, fine, lo), {}).get("declared_exact")))
        pulls = [at.get((spec, e, fine, lo), {}).get("tensile") for e in st["asked"]]
        cells.append(
            " / ".join(_f(100 * t if isinstance(t, float) else None, "{:.1f}") for t in pulls)
        )
        mine = [c for c in cal if c["match"] == _match(sec["rows"], spec)]
        cells.append(_calibration_cell(mine) if mine else "-")
        fl += [None, None]
        rows.append(cells)
        flags.append(fl)
        declared.append(f"{name}: {' / '.join(exact)}")
    return header, rows, flags, marks, declared


def _match(rows, spec: str) -> str:
    """The variant key of ``spec``'s rows (the same for the calibrated spec of that variant)."""
    return next(r["match"] for r in rows if r["spec"] == spec)


def _count(n: int) -> str:
    """``n`` as a capitalised word for small counts ("Five"), else digits."""
    words = ("One", "Two", "Three", "Four", "Five", "Six", "Seven", "Eight", "Nine", "Ten")
    return words[n - 1] if 1 <= n <= len(words) else str(n)


def codes_blocks(r: dict) -> list:
    """The section's blocks; none when the results have no ``codes_side_by_side``."""
    sec = r.get("codes_side_by_side")
    if not sec or not sec.get("rows"):
        return []
    st = sec["settings"]
    fine, coarse = max(st["steps_per_contact"]), min(st["steps_per_contact"])
    speeds = sorted(st["speeds"])
    lo = speeds[0]
    c = r.get("carried")
    carried = [
        P(
            f"Not run by this report: carried from the report of {c['generated_utc']} "
            f"(commit {str(c.get('git_commit') or 'unknown')[:12]}).",
            "warn",
        )
    ] if c else []  # fmt: skip
    # The heading counts the codes the section holds (the registry grows: issue 40 §5).
    n_codes = len({row["code"] for row in sec["rows"]})
    blocks = [
        H(3, f"{_count(n_codes)} codes side by side: asked e against delivered e", "codes"),
        *carried,
        P(
            f"A sphere of m = {st['mass'] * 1e3:.4g} g on a wall: Hertz k = {st['hertz_k']:.5g} "
            f"N/m^1.5 or, for the linear variants, Hooke k = {st['hooke_k']:.3g} N/m; each code "
            "is given each asked e typed into its own input as is (e itself where the input is "
            "a restitution; the linear law's ζ, tc or dashpot of that e at q = 0 for MuJoCo's "
            "dampratio and YADE's ViscElMat), not the input that would deliver it, and run at "
            "dt = t_c / N (t_c: the exact contact time). Each cell is the "
            f"restitution delivered at q = 0 with N = {fine} / N = {coarse} steps per contact, "
            f"at v0 = {lo:g} m/s; † marks a cell where the other speed delivers an e differing "
            f"by more than {st['speed_tolerance']:g} (values below); bold: either delivered e "
            f"more than {100 * st['asked_tolerance']:g} % from the asked one. "
            "The largest pull is the largest tensile force during contact (at its end for an "
            "unclipped law), as a percentage of the peak compressive force; 0 for a code that "
            "clips tension. The calibration searches the code's input that delivers the asked "
            f"e at N = {st['calibration_steps_per_contact']} and v0 = "
            f"{st['calibration_v0']:g} m/s (`hcv calibrate`), for asked e = "
            f"{', '.join(f'{e:g}' for e in st['calibration_asked'])} only, to bound the "
            "report's cost (a search runs the code many times per asked e; its wall time is "
            'below); "-" where the variant has no calibrated input.'
        ),
    ]
    for hi in speeds[1:]:
        header, rows, flags, marks, declared = _table(sec, lo, hi)
        blocks += [
            H(4, f"v0 = {lo:g} m/s against {hi:g} m/s"),
            T(header, rows, flags),
            P(
                f"Declared law's exact e (N = {fine}, asked "
                f"{' / '.join(f'{e:g}' for e in st['asked'])}):"
            ),
            UL(declared),
        ]
        if marks:
            blocks += [P(f"† e({fine}) / e({coarse}) at {hi:g} m/s:"), UL(marks)]
    failed: dict[str, str] = {}
    for row in sec["rows"]:
        if row.get("error"):
            failed.setdefault(f"{row['code']}: `{row['variant']}`", row["error"])
    if failed:
        blocks.append(
            P("Not delivered: " + "; ".join(f"{k} ({v})" for k, v in failed.items()) + ".", "warn")
        )
    cost = sec.get("seconds") or {}
    if cost:
        blocks.append(
            P(
                "Cost of this section (wall time): "
                + "; ".join(
                    f"`{spec}` {t['table']:.0f} s"
                    + (f" + calibration {t['calibration']:.0f} s" if t["calibration"] else "")
                    for spec, t in cost.items()
                )
                + "."
            )
        )
    return blocks
