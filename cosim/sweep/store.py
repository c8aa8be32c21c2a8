"""The results of a sweep on disk (:mod:`cosim.sweep`): ``<out>/results.jsonl`` (one record
a line, flushed and synced as the cases finish, so a killed sweep keeps what it
finished), ``<out>/arrays/<case id>.npz``, ``<out>/sweep.json`` (the spec and its
cases) and what a resume skips."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from .errors import SweepError
from .spec import FORMAT, SweepSpec, _canonical

RESULTS = "results.jsonl"
TABLE = "results.csv"
META = "sweep.json"


def read_records(out) -> list:
    """The records of ``<out>/results.jsonl`` in file order (a case run again: its last
    record wins when the table is made).  A last line cut short by a killed process is
    ignored (and cut off by :func:`_open_results` before appending)."""
    p = Path(out) / RESULTS
    if not p.exists():
        return []
    recs = []
    lines = p.read_bytes().split(b"\n")
    for i, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            recs.append(json.loads(line))
        except json.JSONDecodeError as e:
            if i == len(lines) or (i == len(lines) - 1 and not lines[-1]):
                break  # the last line, written when the process was killed
            raise SweepError(f"{p}, line {i}: not a JSON record ({e}); the results file is damaged") from None
    return recs


def _open_results(out: Path):
    """Open the results file for appending, first cutting off a partial last line."""
    p = out / RESULTS
    if p.exists():
        data = p.read_bytes()
        if data and not data.endswith(b"\n"):
            keep = data.rfind(b"\n") + 1
            with open(p, "r+b") as f:
                f.truncate(keep)
    return open(p, "a", encoding="utf-8")


def _append(f, rec: dict) -> None:
    f.write(json.dumps(_canonical(rec), allow_nan=True, separators=(",", ":")) + "\n")
    f.flush()
    os.fsync(f.fileno())


def _save_arrays(out: Path, rec: dict) -> None:
    arrays = rec.pop("arrays", None)
    if arrays is None:
        return
    d = out / "arrays"
    d.mkdir(exist_ok=True)
    tmp = d / f"{rec['case_id']}.part.npz"
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, d / f"{rec['case_id']}.npz")
    rec["arrays_file"] = f"arrays/{rec['case_id']}.npz"


def _check_out(out: Path, spec: SweepSpec, resume: bool, overwrite: bool) -> None:
    meta = out / META
    has = (out / RESULTS).exists() and (out / RESULTS).stat().st_size > 0
    if has and overwrite:
        (out / RESULTS).unlink()
        for p in (out / TABLE, meta):
            if p.exists():
                p.unlink()
        return
    if has and not resume:
        raise SweepError(f"{out} already holds results of a sweep: resume it (--resume / resume=True) or start "
                         f"again (--overwrite / overwrite=True), or choose another --out")
    if has and meta.exists():
        old = json.loads(meta.read_text())
        if old.get("fingerprint") != spec.fingerprint():
            raise SweepError(f"{out} holds results of a sweep with another kind or base configuration "
                             f"({old.get('kind')}, fingerprint {old.get('fingerprint')} vs {spec.fingerprint()}): "
                             f"its results would not be comparable; use another --out or --overwrite")


def _done(out: Path, retry_failed: bool) -> dict:
    """Case id -> its record, for the cases a resume skips (the failed ones too unless
    ``retry_failed``)."""
    done = {}
    for r in read_records(out):
        if r["status"] == "ok" or not retry_failed:
            done[r["case_id"]] = r
        else:
            done.pop(r["case_id"], None)
    return done


def _write_meta(out: Path, spec: SweepSpec, cases: list) -> None:
    meta = {"format": FORMAT, "name": spec.name, "kind": spec.kind, "fingerprint": spec.fingerprint(),
            "spec": spec.to_dict(), "spec_file": str(spec.path) if spec.path else None,
            "cases": [{"index": c.index, "case_id": c.id, "params": c.params} for c in cases]}
    (out / META).write_text(json.dumps(_canonical(meta), indent=1, allow_nan=True))
