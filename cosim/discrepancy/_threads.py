"""BLAS on one thread during a diagnosis.

The engine solves many small least-squares problems; on a busy two-core machine a
multi-threaded OpenBLAS spends more time handing them between threads than solving
them (measured: 0.9 s against 0.03 s for one 8400 x 90 solve).  threadpoolctl limits
the threads for the duration of a ``with`` block and restores them after.
"""
from contextlib import nullcontext


def one_blas_thread():
    """Context manager limiting BLAS to one thread (a no-op without threadpoolctl)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl is in requirements.txt
        return nullcontext()
    return threadpool_limits(limits=1, user_api="blas")
