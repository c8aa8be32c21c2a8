"""What a sweep leaves (:mod:`cosim.sweep`): :class:`SweepResult`, one row per case in
case order, and the table ``<out>/results.csv``."""
from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .spec import SweepSpec

@dataclass
class SweepResult:
    """What :func:`run_sweep` leaves: one row per case of the spec that has a result.

    Attributes
    ----------
    spec : SweepSpec
    out : Path
        The sweep's directory (``results.jsonl``, ``results.csv``, ``sweep.json``).
    rows : list of dict
        Flat rows in case order: ``case_id``, ``index``, ``status``, the parameters, the
        results, ``error_type``, ``error``, ``seconds``, ``worker``.
    records : list of dict
        The raw records (with ``raw`` data of the kinds that return some).
    ran, skipped, pending : int
        Cases run by this call, found already done, left without a result.
    seconds : float
        Wall time of this call (cluster start-up included).
    startup : float
        Time to start (or reach) the cluster.
    interrupted : bool
        The call was stopped by Ctrl-C (KeyboardInterrupt); what finished is kept.
    cluster : str
        Where the cases ran ("serial", the LocalCluster or the scheduler address).
    summary : str
        The kind's summary (blind benchmark scores, best index poses...).
    """

    spec: SweepSpec
    out: Path
    rows: list
    records: list
    ran: int = 0
    skipped: int = 0
    pending: int = 0
    seconds: float = 0.0
    startup: float = 0.0
    cluster: str = "serial"
    interrupted: bool = False
    summary: str = ""
    files: dict = field(default_factory=dict)

    @property
    def ok(self) -> list:
        return [r for r in self.rows if r["status"] == "ok"]

    @property
    def failed(self) -> list:
        return [r for r in self.rows if r["status"] != "ok"]

    def column(self, name: str) -> np.ndarray:
        """One column as a float array (NaN where a row has no number)."""
        out = np.full(len(self.rows), np.nan)
        for i, r in enumerate(self.rows):
            v = r.get(name)
            if isinstance(v, (int, float)):
                out[i] = float(v)
        return out

    def text(self) -> str:
        L = [f"sweep {self.spec.name} ({self.spec.kind}): {len(self.rows)} of {len(self.spec.case_list())} cases "
             f"have a result: {len(self.ok)} ok, {len(self.failed)} failed; this call ran {self.ran} "
             f"({self.skipped} already done, {self.pending} left) on {self.cluster} in {self.seconds:.1f} s"]
        for r in self.failed[:10]:
            p = ", ".join(f"{k} = {_show(r.get(k))}" for k in self.spec.param_names() if k in r)
            L.append(f"  FAILED case {r['index']} [{r['case_id']}] ({p}): {r.get('error_type')}: {r.get('error')}")
        if len(self.failed) > 10:
            L.append(f"  ... {len(self.failed) - 10} more failed cases in the table")
        if self.interrupted:
            L.append(f"  interrupted: {self.pending} case(s) pending; run again with --resume (resume=True)")
        if self.summary:
            L += ["", self.summary]
        for k, p in self.files.items():
            L.append(f"{k}: {p}")
        return "\n".join(L)


def _show(v):
    return f"{v:.6g}" if isinstance(v, float) else json.dumps(v) if isinstance(v, (list, dict)) else str(v)


def _rows(spec: SweepSpec, records: list) -> list:
    last = {}
    for r in records:
        last[r["case_id"]] = r
    names = set(spec.param_names())
    rows = []
    for c in spec.case_list():
        r = last.get(c.id)
        if r is None:
            continue
        row = {"case_id": c.id, "index": c.index, "status": r["status"]}
        row.update(c.params)
        for k, v in r.get("results", {}).items():
            row[f"result.{k}" if k in names or k in row else k] = v
        for k in ("error_type", "error", "where"):
            if k in r:
                row[k] = r[k]
        if r.get("warnings"):
            row["warnings"] = " | ".join(r["warnings"])
        row["seconds"], row["worker"] = r.get("seconds"), r.get("worker")
        rows.append(row)
    return rows


def write_table(path, spec: SweepSpec, rows: list) -> Path:
    """The rows as CSV: ids and status, the parameters, the results (union of the
    columns, first seen first), the error and timing columns; empty cells where a row
    has no value; lists and tables of parameters as JSON."""
    head = ["case_id", "index", "status"] + spec.param_names()
    tail = ["error_type", "error", "where", "warnings", "seconds", "worker"]
    cols = list(head)
    for r in rows:
        for k in r:
            if k not in cols and k not in tail:
                cols.append(k)
    cols += tail
    path = Path(path)
    tmp = path.with_suffix(".csv.part")
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow(["" if r.get(c) is None else json.dumps(r[c]) if isinstance(r.get(c), (list, dict))
                        else r[c] for c in cols])
    os.replace(tmp, path)
    return path
