"""Sweeps: many scenario runs, calibration trials, blind cases or index-map tiles, on Dask.

A sweep spec (TOML, ``scenarios/sweeps/*.toml``, format in docs/sweep.md) names the
*kind* of case, the *base* configuration shared by every case and the parameters to
vary: a ``[grid]`` (every combination), ``[random]`` draws with a seed, explicit
``[[cases]]``.  Each case is a plain dict of parameters; its *case id* is a hash of
that dict (:func:`case_id`), so it does not depend on the order or the number of the
other cases.  A case runs through :func:`run_case`, which calls the kind's function
(:mod:`cosim.sweep.kinds`) and returns one record: the parameters, a flat dict of
results, ``status`` (``"ok"`` or ``"error"``, with the exception's type and message:
a failing case never stops the sweep), the wall time and the worker.

:func:`run_sweep` fans the cases out over a Dask cluster (``dask.distributed``): a
``LocalCluster`` of one single-threaded worker *process* per core by default (the
core and the FMUs are C libraries called through ctypes: processes, not threads, run
them in parallel), or an existing cluster given by its scheduler address.  Records
are appended to ``<out>/results.jsonl`` (flushed and synced) as the cases finish, in
any order, so a killed sweep keeps what it finished; running it again with
``resume=True`` skips every case id already in the file.  At the end the table
``<out>/results.csv`` is written in case order.  ``workers=0`` runs the same cases
in a plain loop in this process (the serial reference).

FMU plants: the driver reads the ``.fmu`` once and scatters its bytes to the
workers; a worker writes them to a local cache keyed by their SHA-256
(:func:`materialise_fmu`) and each case instantiates its own FMU there, in the
worker process, in the thread that runs it: no FMU instance crosses a process or
thread boundary.

Example
-------
>>> from cosim.sweep import load_spec, run_sweep
>>> spec = load_spec("scenarios/sweeps/calibration_noise.toml")
>>> res = run_sweep(spec, out="results/sweeps/calibration_noise", workers=2)
>>> res.column("holdout.position_rms_calibrated")     # [m], one per case, NaN if failed
"""
from __future__ import annotations

import time
from pathlib import Path

# the family's public names are re-exported here and by the package (noqa: F401)
from .case import MAX_LIST_COLUMNS, CaseContext, flatten, run_case  # noqa: F401
from .cluster import _close, _describe, _start_client, default_workers, fan_out, run_serial
from .errors import SweepError, SweepSpecError  # noqa: F401
from .result import SweepResult, _rows, write_table
from .shipping import _sha256, fmu_cache_dir, materialise_fmu  # noqa: F401
from .spec import FORMAT, Case, SweepSpec, case_id, load_spec, spec_from_dict  # noqa: F401
from .store import META, RESULTS, TABLE, _append, _check_out, _done, _open_results, _save_arrays, _write_meta, \
    read_records  # noqa: F401

__all__ = ["SweepSpec", "SweepSpecError", "SweepError", "Case", "SweepResult", "load_spec", "spec_from_dict",
           "case_id", "run_case", "run_sweep", "read_records", "flatten", "materialise_fmu", "default_workers"]

REPO = Path(__file__).resolve().parents[2]


def _prepare(spec: SweepSpec, cases: list):
    from .kinds import get_kind

    base, fmu_path = get_kind(spec.kind).prepare(spec, cases)
    fmu = None
    if fmu_path is not None:
        fmu_path = Path(fmu_path)
        data = fmu_path.read_bytes()
        fmu = {"sha256": _sha256(data), "name": fmu_path.name, "path": str(fmu_path.resolve()), "bytes": data}
    return base, fmu


def run_sweep(spec, *, out=None, scheduler: str | None = None, workers: int | None = None, client=None,
              resume: bool = False, overwrite: bool = False, retry_failed: bool = False,
              max_cases: int | None = None, progress: bool | None = None, window: int | None = None) -> SweepResult:
    """Run the cases of a sweep on Dask (or in a loop) and gather their results.

    Parameters
    ----------
    spec : SweepSpec or str or Path
        The spec (or its TOML file).
    out : str or Path, optional
        The sweep's directory (default ``results/sweeps/<name>``).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``); its workers need
        this package and the core library (docs/sweep.md).
    workers : int, optional
        Worker processes of the LocalCluster (default: one per core); 0 runs the cases
        in a plain loop in this process.
    client : distributed.Client, optional
        Use this client (and its cluster) instead of starting one.
    resume : bool
        Skip the cases whose id is already in ``<out>/results.jsonl``.
    overwrite : bool
        Discard the results already in ``out``.
    retry_failed : bool
        With ``resume``, run again the cases recorded as failed.
    max_cases : int, optional
        Run only the first ``max_cases`` cases still to do (the others stay pending: a
        deliberate partial run, resumed later).
    progress : bool, optional
        tqdm progress bar (default: on a terminal).
    window : int, optional
        Cases in flight at once (default: 4 per worker thread, at least 8).

    Returns
    -------
    SweepResult

    Raises
    ------
    SweepError
        ``out`` holds results and neither ``resume`` nor ``overwrite`` was given, or
        they come from a spec with another kind or base.
    """
    from tqdm import tqdm

    t_start = time.perf_counter()
    if not isinstance(spec, SweepSpec):
        spec = load_spec(spec)
    out = Path(out) if out is not None else Path("results") / "sweeps" / spec.name
    out.mkdir(parents=True, exist_ok=True)
    _check_out(out, spec, resume, overwrite)
    cases = spec.case_list()
    done = _done(out, retry_failed)
    todo = [c for c in cases if c.id not in done]
    skipped = len(cases) - len(todo)
    _write_meta(out, spec, cases)
    base, fmu = _prepare(spec, todo) if todo else ({}, None)
    # a deliberate partial run: the first max_cases cases still to do, the rest stays pending
    todo_run = todo if max_cases is None else todo[:max(0, int(max_cases))]
    ran = 0
    cluster_desc, startup = "serial", 0.0
    f = _open_results(out)
    bar = tqdm(total=len(todo_run), unit="case", desc=spec.name, disable=None if progress is None
               else not progress, dynamic_ncols=True)

    def record(rec):
        nonlocal ran
        _save_arrays(out, rec)
        _append(f, rec)
        ran += 1
        bar.update(1)
        if rec["status"] != "ok":
            bar.write(f"case {rec.get('index')} [{rec['case_id']}] failed: {rec.get('error_type')}: "
                      f"{rec.get('error')}"[:400])

    own_client = own_cluster = None
    interrupted = False
    index = {}  # key of each future in flight -> its case
    try:
        if workers == 0 and client is None and scheduler is None:
            run_serial(spec.kind, base, fmu, todo_run, spec.results, record)
        elif todo_run:
            t0 = time.perf_counter()
            if client is None:
                own_client, own_cluster, cluster_desc = _start_client(scheduler, workers)
                client = own_client
            else:
                cluster_desc = _describe(client)
            startup = time.perf_counter() - t0
            fan_out(client, spec.kind, base, fmu, todo_run, spec.results, prefix=f"sweep-{spec.fingerprint()}-",
                    window=window, record=record, bar=bar, index=index)
    except KeyboardInterrupt:  # Ctrl-C: keep what finished, write the table, say how to go on
        interrupted = True
    finally:
        bar.close()
        f.close()
        _close(client, own_client, own_cluster, index)
    return _gather(spec, out, len(cases), t_start, ran=ran, skipped=skipped, startup=startup, cluster=cluster_desc,
                   interrupted=interrupted)


def _gather(spec: SweepSpec, out: Path, n_cases: int, t_start: float, **counts) -> SweepResult:
    """The result of a call: the rows of the results file in case order, the table and the
    kind's summary; ``counts`` are this call's figures (:class:`SweepResult`)."""
    from .kinds import get_kind

    records = read_records(out)
    rows = _rows(spec, records)
    res = SweepResult(spec, out, rows, records, pending=n_cases - len(rows), seconds=time.perf_counter() - t_start,
                      **counts)
    res.files["results"] = out / RESULTS
    res.files["table"] = write_table(out / TABLE, spec, rows)
    try:
        res.summary = get_kind(spec.kind).summarize(res) or ""
    except Exception as e:  # a summary is a convenience: never lose the sweep over it
        res.summary = f"(no summary: {type(e).__name__}: {e})"
    return res

