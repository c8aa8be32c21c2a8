"""The Dask side of a sweep (:mod:`cosim.sweep`): a ``LocalCluster`` of single-threaded
worker processes or an existing scheduler, and the cases fanned out over it a window at
a time."""
from __future__ import annotations

import os
from itertools import islice

from .case import run_case
from .errors import SweepError

def default_workers() -> int:
    """One worker process per core this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def _start_client(scheduler, workers):
    import logging
    import signal
    import threading

    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="5s")
        except (OSError, TimeoutError) as e:
            raise SweepError(f"no Dask scheduler answers at {scheduler} within 5 s ({e.__class__.__name__}): start "
                             f"one (dask scheduler) or leave out --scheduler for a local cluster") from None
        n = sum(client.nthreads().values())
        return client, None, f"scheduler {scheduler} ({len(client.nthreads())} workers, {n} threads)"
    n = int(workers or default_workers())
    # one thread per process: the core and the FMUs hold the GIL in ctypes calls and an
    # FMU instance must stay in the thread that made it
    # ctrl-C in a terminal reaches the whole process group: the worker processes are
    # started with SIGINT ignored (inherited, and Python then installs no handler), so only
    # this process stops, keeps what finished and closes the cluster, with no worker
    # printing a KeyboardInterrupt traceback
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread else None
    try:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
    finally:
        if main_thread:
            signal.signal(signal.SIGINT, previous)
    return Client(cluster), cluster, f"LocalCluster ({n} worker processes, 1 thread each)"


def _describe(client) -> str:
    return f"client {client.scheduler.address} ({len(client.nthreads())} workers)"


def run_serial(kind: str, base: dict, fmu: dict | None, cases: list, patterns: dict, record) -> None:
    """The cases one after the other in this process (``workers=0``: the serial reference);
    ``record`` receives each record."""
    fmu_arg = {k: v for k, v in fmu.items() if k != "bytes"} if fmu else None
    for c in cases:
        rec = run_case(kind, base, c.params, c.id, fmu_arg, None, patterns)
        rec["index"] = c.index
        record(rec)


def fan_out(client, kind: str, base: dict, fmu: dict | None, cases: list, patterns: dict, *, prefix: str,
            window: int | None, record, bar, index: dict) -> None:
    """The cases on the client's workers, ``window`` in flight at once (default: 4 per
    worker thread, at least 8); ``record`` receives each record as it comes back.

    ``index`` (key of each future in flight -> its case and future) is the caller's, so
    that it can cancel what is still in flight when this is interrupted.  A case the
    cluster cancels stays pending (``bar`` says so); a case whose worker died is
    recorded as failed.
    """
    from distributed import CancelledError, as_completed

    nthreads = max(1, sum(client.nthreads().values()))
    win = window or max(8, 4 * nthreads)
    fmu_arg = fmu_data = None
    if fmu:
        fmu_arg = {k: v for k, v in fmu.items() if k != "bytes"}
        # one copy per worker, not one per task; workers write it to their cache
        fmu_data = client.scatter(fmu["bytes"], broadcast=True, hash=False)
    # hash=False: a key of its own per call, so that the release of a previous
    # call's copy (same content) cannot delete the data this call depends on
    base_f = client.scatter([base], broadcast=True, hash=False)[0]

    def submit(c):
        fut = client.submit(run_case, kind, base_f, c.params, c.id, fmu_arg, fmu_data, patterns,
                            key=prefix + c.id, retries=0)
        index[fut.key] = (c, fut)
        return fut

    it = iter(cases)
    ac = as_completed([submit(c) for c in islice(it, win)])
    for fut in ac:
        c, _ = index.pop(fut.key)
        try:
            rec = fut.result()
        except CancelledError as e:  # not the case's doing: leave it pending for a resume
            bar.write(f"case {c.index} [{c.id}] was cancelled by the cluster ({e}); it stays pending")
            fut.release()
            nxt = next(it, None)
            if nxt is not None:
                ac.add(submit(nxt))
            continue
        except Exception as e:  # the worker died while running it (a crash in a C library...)
            rec = {"case_id": c.id, "params": c.params, "status": "error", "results": {},
                   "error_type": type(e).__name__, "error": f"the case did not come back from its worker: {e}",
                   "seconds": None, "worker": None}
        fut.release()
        rec["index"] = c.index
        record(rec)
        nxt = next(it, None)
        if nxt is not None:
            ac.add(submit(nxt))


def _close(client, own_client, own_cluster, index: dict) -> None:
    """Cancel what is still in flight on a caller's client (interrupted: its cluster should
    not go on with them); close the client and cluster this call started."""
    if index and client is not None and own_client is None:
        client.cancel([fu for _, fu in index.values()])
    if own_client is not None:
        own_client.close()
    if own_cluster is not None:
        own_cluster.close()
