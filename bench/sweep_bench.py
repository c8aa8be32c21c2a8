"""Speed-up of 2 local Dask workers over the serial loop on a 100-case sweep.

Usage: .venv/bin/python bench/sweep_bench.py [--cases 100] [--kind calibration|scenario|both]
(the same as ``cosim sweep --bench``; the code is in cosim/sweep/bench.py).
"""
import sys

from cosim.sweep.bench import main

if __name__ == "__main__":  # the guard matters: Dask's worker processes are spawned and re-import this file
    sys.exit(main())
