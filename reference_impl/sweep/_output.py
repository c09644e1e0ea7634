"""Sweep output: the incremental case store, results.parquet, summary.md and its figure.

Every finished case is appended at once as one JSON line to ``DIR/cases.jsonl``
(key, index, swept parameters, rows or error, seconds), so a killed sweep loses
only the cases in flight; ``--resume`` reads the keys back (a truncated last
line is ignored). `consolidate` turns the records of the current spec into the
table written to ``DIR/results.parquet``: one row per case and speed, the swept
parameters first (named by their dotted paths), then the task's fields, then
``case_key``, ``error``, ``case_seconds`` (wall) and ``case_cpu_seconds``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from pathlib import Path

import pandas as pd

from reference_impl.sweep._assembly import ensemble_rows

__all__ = ["CaseStore", "consolidate", "replacing", "write_parquet", "write_summary"]

# Rows of the table printed in summary.md (the full table is results.parquet).
_SUMMARY_ROWS = 200
# Failed cases listed by name in summary.md.
_SUMMARY_ERRORS = 20
# Longest category label on the figure's x axis (whole tables swept as values are long).
_TICK_CHARS = 28
# Figure quantity per task: column and axis label.
_Y = {
    "dt-crit": ("ratio", "Δt_crit / Δt_safe (measured / section 6 bound)"),
    "solve": ("contact_time", "contact time t_c [s]"),
    "bench": ("metrics_fail", "failed metrics (hcv bench)"),
    "calibrate": ("value", "option value delivering the target (hcv calibrate)"),
}
# Task fields shown in the summary table beside the swept parameters.
_SHOWN = {
    "dt-crit": ("v0", "dt_safe", "dt_crit", "ratio", "failure_kind", "holds"),
    "solve": ("v0", "dt_safe", "contact_time", "restitution", "max_penetration"),
    "bench": (
        "variant",
        "v0",
        "status",
        "metrics_fail",
        "failed_metrics",
        # the delivered restitution: measured, expected (asked) and error (issue 26)
        "measured.restitution",
        "asked_restitution",
        "rel_error.restitution_asked",
    ),
    "calibrate": ("param", "target", "steps_per_contact", "found", "value", "achieved"),
}
# Units of the task fields, shown in the summary table's header.
_UNITS = {
    "v0": "m/s",
    "dt_safe": "s",
    "dt_crit": "s",
    "ratio": "dt_crit / dt_safe",
    "contact_time": "s",
    "max_penetration": "m",
    "case_seconds": "s",
}
# Markers of the critical-step figure: an instability is not an accuracy limit.
_KIND_MARKERS = {
    "runaway": ("x", "tab:red", "runaway (instability)"),
    "bounded": ("s", "tab:orange", "bounded excursion"),
    "accuracy": ("o", "tab:blue", "accuracy limit"),
    "null": ("^", "tab:green", "nothing failed in range"),
}


class CaseStore:
    """Append-only record of finished cases in ``DIR/cases.jsonl``."""

    def __init__(self, out_dir):
        self.dir = Path(out_dir)
        self.path = self.dir / "cases.jsonl"
        self._ended = False

    def exists(self) -> bool:
        return self.path.exists() and self.path.stat().st_size > 0

    def load(self) -> dict[str, dict]:
        """key -> record of every complete line (later lines win)."""
        out: dict[str, dict] = {}
        if not self.path.exists():
            return out
        with self.path.open(encoding="utf-8", errors="replace") as fh:
            for line in fh:
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError:  # a line cut by a kill: that case reruns
                    continue
                if isinstance(rec, dict) and "key" in rec:
                    out[rec["key"]] = rec
        return out

    def append(self, record: dict) -> None:
        """Write one record and flush it to the OS (survives a kill of this process).

        Raises
        ------
        OSError
            The file could not be written (a full disk); its ``filename`` is the store's
            path, whatever call failed (a failed write names no file by itself).
        """
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            if not self._ended:
                # A line cut by a kill has no newline: end it, or the next record joins it.
                with self.path.open("a+b") as fh:
                    if fh.tell() > 0:
                        fh.seek(-1, 2)
                        if fh.read(1) != b"\n":
                            fh.write(b"\n")
                self._ended = True
            with self.path.open("a", encoding="utf-8") as fh:
                fh.write(json.dumps(record, default=_json_default, allow_nan=True) + "\n")
                fh.flush()
        except OSError as exc:
            # a record cut by the failure lacks its newline: end it before the next one
            self._ended = False
            raise _named(exc, self.path) from None

    def stored(self) -> int:
        """Number of complete records in the file (0 when it is missing)."""
        return len(self.load())


def _json_default(x):
    if hasattr(x, "item"):
        return x.item()
    return str(x)


def _cell(v):
    """Parameter values as table cells: lists and tables as JSON text."""
    return json.dumps(v) if isinstance(v, (list, dict)) else v


def consolidate(spec, records: dict[str, dict]) -> pd.DataFrame:
    """The results table of ``spec`` from the stored records (cases in spec order).

    Cases without a record (not run yet) are left out; a failed case is one row
    with its error and no task fields.
    """
    rows = []
    for case in spec.cases:
        rec = records.get(case.key)
        if rec is None:
            continue
        params = {k: _cell(v) for k, v in case.params.items()}
        tail = {
            "case_key": case.key,
            "error": rec.get("error") or None,
            "case_seconds": rec.get("seconds", math.nan),
            "case_cpu_seconds": rec.get("cpu_seconds", math.nan),
        }
        for r in rec.get("rows") or [{}]:
            row = dict(params)
            for k, v in r.items():
                if k in row and row[k] != v:
                    k = f"{k} (result)"  # a swept path that is also a result field
                row.setdefault(k, v)
            row.update(tail)
            rows.append(row)
    df = pd.DataFrame(rows)
    tail_cols = ["case_key", "error", "case_seconds", "case_cpu_seconds"]
    if len(df):
        df = df[[c for c in df.columns if c not in tail_cols] + tail_cols]
    return _arrow_safe(df)


def _arrow_safe(df: pd.DataFrame) -> pd.DataFrame:
    """Object columns mixing types (e.g. a parameter swept over numbers and text) as text."""
    for c in df.columns:
        if df[c].dtype != object:
            continue
        kinds = {
            type(v) for v in df[c] if v is not None and not (isinstance(v, float) and math.isnan(v))
        }
        numeric = kinds <= {int, float}
        if len(kinds) > 1 and not numeric:
            df[c] = [None if v is None else str(v) for v in df[c]]
    return df


def _named(exc: OSError, path) -> OSError:
    """``exc`` naming ``path`` (the file the user knows, not a temporary name)."""
    return OSError(exc.errno, exc.strerror or str(exc), str(path))


@contextlib.contextmanager
def replacing(path: Path):
    """Yield a temporary name beside ``path``; rename it to ``path`` when the block ends
    without error, else remove it: a failed write (a full disk) leaves the previous file
    or none, never a cut one, and raises OSError naming ``path``."""
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(exc, OSError):
            raise _named(exc, path) from None
        raise


def write_parquet(df: pd.DataFrame, path) -> None:
    """results.parquet via pyarrow (written to a temporary name, then renamed)."""
    with replacing(Path(path)) as tmp:
        df.to_parquet(tmp, index=False, engine="pyarrow")


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, bool):
        return "yes" if v else "NO"
    return str(v).replace("|", "\\|").replace("\n", " ")


def _markdown_table(df: pd.DataFrame) -> str:
    head = "| " + " | ".join(f"{c} [{_UNITS[c]}]" if c in _UNITS else c for c in df.columns) + " |"
    sep = "|" + "|".join("---" for _ in df.columns) + "|"
    body = ["| " + " | ".join(_fmt(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join([head, sep, *body])


def _key_of(v) -> str:
    return json.dumps(v, sort_keys=True, default=str)


def _short(v, width: int = _TICK_CHARS) -> str:
    text = str(v)
    return text if len(text) <= width else text[: width - 1] + "…"


def _task_family(task: str) -> str:
    if task.startswith("calibrate:"):
        return "calibrate"
    return "bench" if task.startswith("bench:") else task


def figure(spec, df: pd.DataFrame, path) -> bool:
    """Plot the task's main quantity against the varying parameters (one or two); True if drawn."""
    varying = spec.varying
    fam = _task_family(spec.task)
    ycol, ylabel = _Y[fam]
    if not 1 <= len(varying) <= 2 or ycol not in df.columns:
        return False
    ok = df[df["error"].isna()] if "error" in df.columns else df
    if not len(ok):
        return False
    from matplotlib.figure import Figure

    x = varying[0]
    xs = list(spec.sweep[x])
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xs)
    pos = {_key_of(_cell(v)): i for i, v in enumerate(xs)}  # table cells -> positions
    fig = Figure(figsize=(7.5, 4.8), dpi=110)
    ax = fig.subplots()
    groups = [varying[1]] if len(varying) == 2 else []
    if "v0" in ok.columns and ok["v0"].nunique() > 1:
        groups.append("v0")
    series = ok.groupby(groups, sort=False, dropna=False) if groups else [((), ok)]
    for name, g in series:
        xv = g[x].tolist()
        xp = xv if numeric else [pos.get(_key_of(v), math.nan) for v in xv]
        yv = pd.to_numeric(g[ycol], errors="coerce").tolist()
        pts = sorted(zip(xp, yv, strict=True))
        name = name if isinstance(name, tuple) else (name,)
        label = ", ".join(f"{k} = {_fmt(v)}" for k, v in zip(groups, name, strict=True)) or ycol
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", lw=1.4, label=label)
    if fam == "dt-crit" and "failure_kind" in ok.columns:
        # one marker per failure kind over the lines: runaways apart from accuracy limits
        for kind, (marker, color, label) in _KIND_MARKERS.items():
            g = ok[ok["failure_kind"].astype(str) == kind]
            if not len(g):
                continue
            xv = g[x].tolist()
            xp = xv if numeric else [pos.get(_key_of(v), math.nan) for v in xv]
            ax.scatter(
                xp, pd.to_numeric(g[ycol], errors="coerce"), marker=marker, color=color,
                s=46, zorder=3, label=label,
            )  # fmt: skip
        groups = groups or ["failure_kind"]  # the legend names the kinds
    if fam == "dt-crit":
        ax.axhline(1.0, color="k", lw=1.2)
        ax.text(
            0.01,
            1.0,
            " Δt_crit = Δt_safe",
            transform=ax.get_yaxis_transform(),
            va="bottom",
            fontsize=8,
        )
    if not numeric:
        ax.set_xticks(range(len(xs)), [_short(_cell(v)) for v in xs], fontsize=8)
    ax.set_xlabel(x + ("" if numeric else " (category)"))
    ax.set_ylabel(ylabel)
    ax.set_title(f"hcv sweep: {spec.task}, {len(spec.cases)} cases", fontsize=10)
    ax.grid(True, alpha=0.3)
    if groups:
        ax.legend(fontsize=8)
    fig.tight_layout()
    with replacing(Path(path)) as tmp:
        fig.savefig(tmp, format="png")
    return True


def _criterion_text(crit: dict) -> str:
    if not crit:
        return ""
    texts = set(crit.values())
    if len(texts) == 1:
        return f", criterion `{texts.pop()}`"
    return ", criterion " + ", ".join(f"`{v}` ({k})" for k, v in crit.items())


def write_summary(
    spec, df: pd.DataFrame, out_dir, *, seconds: float, where: str, interrupted: bool = False
) -> Path:
    """DIR/summary.md (counts, failed cases, a table) and DIR/summary.png when 1-2 parameters vary."""
    out_dir = Path(out_dir)
    fam = _task_family(spec.task)
    n_cases = len(spec.cases)
    errors = df.drop_duplicates("case_key") if len(df) else df
    failed = errors[errors["error"].notna()] if len(errors) else errors
    lines = [
        f"# hcv sweep: {Path(spec.source).name}",
        "",
        f"- task: `{spec.task}`" + _criterion_text(spec.criterion),
        "- swept: " + ", ".join(f"`{k}` ({len(v)} values)" for k, v in spec.sweep.items()),
        f"- cases: {n_cases}; finished {len(errors)} ({len(errors) - len(failed)} ran, "
        f"{len(failed)} failed to run); {len(df)} rows in results.parquet",
        f"- ran on {where} in {seconds:.1f} s" + (" (interrupted)" if interrupted else ""),
    ]
    if fam == "bench" and "status" in df.columns and len(df):
        ran = df[df["error"].isna()].drop_duplicates(["case_key", "variant"])
        bad = ran[ran["status"] != "pass"]
        lines.append(
            f"- scorecards: {len(ran) - len(bad)} of {len(ran)} (case, variant) passed; "
            + (
                ", ".join(f"{n} {s}" for s, n in bad["status"].value_counts().items())
                if len(bad)
                else "none failed"
            )
            + " (exit status 1 when any did not pass)"
        )
    if fam == "dt-crit" and "failure_kind" in df.columns and len(df):
        kinds = df["failure_kind"].astype(str).value_counts()
        lines.append(
            "- failure kinds: " + ", ".join(f"{n} {k}" for k, n in kinds.items())
            + " (runaway: an instability; accuracy: a tolerance limit that moves with tol)"
        )  # fmt: skip
    lines.append("")
    if fam == "dt-crit" and "lane" in df.columns and len(df):
        # Assembly scenes: the lanes of each ensemble, run in groups, gathered again.
        lines += [
            "## Ensembles (chain and lattice scenes)",
            "",
            "Per scene and horizon: lanes found, the 5 / 50 / 95 % points of Δt_crit [s] "
            "and of Δt_crit / Δt_safe (paper) over the lanes.",
            "",
            _markdown_table(ensemble_rows(df, list(spec.sweep))),
            "",
        ]
    drawn = False
    if len(df):
        try:
            drawn = figure(spec, df, out_dir / "summary.png")
        except ImportError:  # matplotlib is an extra: the table is still written
            drawn = False
    if drawn:
        lines += [f"![{_Y[fam][1]} against {', '.join(spec.varying)}](summary.png)", ""]
    if len(failed):
        lines += ["## Failed cases", ""]
        for _, r in failed.head(_SUMMARY_ERRORS).iterrows():
            params = ", ".join(f"{k} = {_fmt(r[k])}" for k in spec.sweep)
            lines.append(f"- {params}: {r['error']}")
        if len(failed) > _SUMMARY_ERRORS:
            lines.append(f"- ... and {len(failed) - _SUMMARY_ERRORS} more (see results.parquet)")
        lines.append("")
    if len(df):
        cols = [c for c in (*spec.sweep, *_SHOWN[fam], "error") if c in df.columns]
        cols = list(dict.fromkeys(cols))
        lines += ["## Results", ""]
        lines.append(_markdown_table(df[cols].head(_SUMMARY_ROWS)))
        if len(df) > _SUMMARY_ROWS:
            lines.append(f"\n(first {_SUMMARY_ROWS} of {len(df)} rows; all in results.parquet)")
    path = out_dir / "summary.md"
    with replacing(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
