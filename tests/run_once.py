"""A session fixture's value computed once per test run, also under pytest-xdist."""
import fcntl
import os
import pickle


def shared_once(tmp_path_factory, name: str, make):
    """``make()``, computed once per test run: under pytest-xdist the first worker to ask
    computes it (the others wait on a file lock) and leaves it pickled in the run's common
    temporary folder, where the others read it (files it names stay in that worker's
    temporary folder, kept for the run); without xdist, ``make()``."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return make()
    root = tmp_path_factory.getbasetemp().parent
    done = root / f"shared-{name}.pickle"
    with open(root / f"shared-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if done.exists():
            return pickle.loads(done.read_bytes())
        value = make()
        done.write_bytes(pickle.dumps(value))
        return value
