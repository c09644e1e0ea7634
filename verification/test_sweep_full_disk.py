"""``hcv sweep`` on a full disk (issue 36 item 9).

Once, the cases ran, then "No space left on device" without a path ended the sweep with
exit status 2 (documented as "nothing run"), an empty lock left and no summary.md. The
disk is made full by the writers raising OSError(ENOSPC) (``Path.open`` of cases.jsonl
for appending, ``DataFrame.to_parquet``), as a full file system does: no file names the
path by itself. Now: one line naming the file, exit status 2 only when nothing ran, 1
once cases ran (the sweep stops; what is stored stays, ``--resume`` runs the rest), and
nothing left in DIR when nothing could be stored.

The first test runs on a real local cluster (the issue's run end to end); the others
run the cases in this process through `_serial` (the same `_call` a worker runs,
without Dask's start-up), since what they test is the client's writing, not the
cluster.
"""

from __future__ import annotations

import contextlib
import errno
import os
import pathlib

import pandas as pd
import pytest

from reference_impl.sweep import _runner

from ._sweeps import SPEC, cli, needs_dask
from .assertions import assert_true

CALL = "hcv sweep on a full disk"
ISSUE = "issue 36 item 9"
# Six valid cases (SPEC holds an invalid p = -1.0, stored as a row before any case runs).
VALID = SPEC.replace("[1.0, 1.5, -1.0, 3.0]", "[1.0, 1.5, 3.0]")


class _OneThread:
    def nthreads(self) -> dict:
        return {"this process": 1}


@pytest.fixture
def _serial(monkeypatch):
    """The sweep's cases run one by one in this process instead of on a cluster."""

    @contextlib.contextmanager
    def open_client(workers, scheduler):
        yield _OneThread()

    def iter_outcomes(client, fn, items, keys):
        for i, item in enumerate(items):
            yield _runner.Outcome(i, keys[i], *_runner._call(fn, item))

    monkeypatch.setattr(_runner, "open_client", open_client)
    monkeypatch.setattr(_runner, "iter_outcomes", iter_outcomes)


def _enospc() -> OSError:
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _full_after(monkeypatch, appends: int) -> None:
    """cases.jsonl takes ``appends`` records, then the disk is full."""
    real = pathlib.Path.open
    left = [appends]

    def open_(self, mode="r", *args, **kw):
        if self.name == "cases.jsonl" and mode == "a":
            if left[0] <= 0:
                raise _enospc()
            left[0] -= 1
        return real(self, mode, *args, **kw)

    monkeypatch.setattr(pathlib.Path, "open", open_)


def _spec(tmp_path, text: str) -> str:
    path = tmp_path / "spec.toml"
    path.write_text(text)
    return str(path)


def _one_line(err: str, needles, call: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.startswith("hcv: error")]
    ok = len(lines) == 1 and all(n in lines[0] for n in needles)
    assert_true(
        ok, got=repr(err[-400:]), should=f"one error line naming {needles}", claim=ISSUE, call=call
    )
    return lines[0]


@needs_dask
def test_nothing_stored_is_one_line_naming_the_store_and_leaves_nothing(tmp_path, capsys,
                                                                        monkeypatch):  # fmt: skip
    out = tmp_path / "out"
    _full_after(monkeypatch, 0)
    code, _, err = cli(["sweep", _spec(tmp_path, VALID), "--workers", "1", "--out", str(out)],
                       capsys)  # fmt: skip
    _one_line(err, [str(out / "cases.jsonl"), "No space left on device", "0 of 6"], CALL)
    assert_true(code == 1, got=f"exit status {code}", should="1 (cases ran, none stored)",
                claim=ISSUE, call=CALL)  # fmt: skip
    left = sorted(os.listdir(out)) if out.exists() else []
    assert_true(not out.exists(), got=f"{left} left in --out", should="no DIR (nothing stored)",
                claim=ISSUE, call=CALL)  # fmt: skip


@needs_dask
def test_a_store_that_fills_up_stops_the_sweep_and_resume_finishes_it(tmp_path, capsys,
                                                                      monkeypatch, _serial):  # fmt: skip
    out = tmp_path / "out"
    spec = _spec(tmp_path, VALID)
    with monkeypatch.context() as m:
        _full_after(m, 2)
        code, _, err = cli(["sweep", spec, "--workers", "1", "--out", str(out)], capsys)
    _one_line(err, [str(out / "cases.jsonl"), "2 of 6", "--resume"], CALL)
    assert_true(code == 1, got=f"exit status {code}", should="1 (the sweep stopped)",
                claim=ISSUE, call=CALL)  # fmt: skip
    assert (out / "summary.md").is_file(), "got no summary.md of the 2 stored cases"
    assert len(pd.read_parquet(out / "results.parquet")["case_key"].unique()) == 2
    code, _, err = cli(["sweep", spec, "--workers", "1", "--out", str(out), "--resume"], capsys)
    assert_true(code == 0, got=f"exit status {code} ({err[-200:]!r})", should="0 after --resume",
                claim=ISSUE, call="hcv sweep --resume")  # fmt: skip
    keys = pd.read_parquet(out / "results.parquet")["case_key"].unique()
    assert_true(len(keys) == 6, got=f"{len(keys)} cases in results.parquet", should="6",
                claim=ISSUE, call="hcv sweep --resume")  # fmt: skip


@needs_dask
def test_a_full_disk_before_any_case_ran_is_exit_2_and_leaves_nothing(tmp_path, capsys,
                                                                      monkeypatch, _serial):  # fmt: skip
    """SPEC's invalid case is stored (a row with its reason) before any case runs."""
    out = tmp_path / "out"
    _full_after(monkeypatch, 0)
    code, _, err = cli(["sweep", _spec(tmp_path, SPEC), "--workers", "1", "--out", str(out)],
                       capsys)  # fmt: skip
    _one_line(err, [str(out / "cases.jsonl"), "nothing run"], CALL)
    assert_true(code == 2, got=f"exit status {code}", should="2 (nothing run)", claim=ISSUE,
                call=CALL)  # fmt: skip
    left = sorted(os.listdir(out)) if out.exists() else []
    assert_true(not out.exists(), got=f"{left} left in --out", should="no DIR", claim=ISSUE,
                call=CALL)  # fmt: skip


@needs_dask
def test_results_parquet_on_a_full_disk_is_named_and_summary_still_written(tmp_path, capsys,
                                                                           monkeypatch, _serial):  # fmt: skip
    out = tmp_path / "out"

    def full(self, *args, **kw):
        raise _enospc()

    monkeypatch.setattr(pd.DataFrame, "to_parquet", full)
    code, _, err = cli(["sweep", _spec(tmp_path, VALID), "--workers", "1", "--out", str(out)],
                       capsys)  # fmt: skip
    _one_line(err, [str(out / "results.parquet"), "No space left on device", "6 of 6"], CALL)
    assert_true(code == 1, got=f"exit status {code}", should="1", claim=ISSUE, call=CALL)
    names = sorted(os.listdir(out))
    assert_true(
        "summary.md" in names and not any(n.endswith(".tmp") for n in names),
        got=f"{names} in --out",
        should="summary.md written and no temporary file left",
        claim=ISSUE,
        call=CALL,
    )
