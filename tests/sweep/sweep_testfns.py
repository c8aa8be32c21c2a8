"""Case functions of the ``function`` kind used by the sweep tests (importable by the
Dask workers: they are spawned with this process's sys.path)."""
import json
import os
import time


def product(p):
    """y = a * b, logged to p["log"] (one line per execution), after p["sleep"] seconds;
    raises like the core at a singular pose when a == p["fail_a"]."""
    if p.get("log"):
        with open(p["log"], "a") as f:
            f.write(json.dumps({"a": p["a"], "b": p["b"], "pid": os.getpid()}) + "\n")
    time.sleep(float(p.get("sleep", 0.0)))
    if p.get("interrupt_a") is not None and p["a"] == p["interrupt_a"]:
        raise KeyboardInterrupt  # as Ctrl-C in the serial loop
    if p.get("fail_a") is not None and p["a"] == p["fail_a"]:
        raise ArithmeticError(f"singular configuration at a = {p['a']}: the Jacobian has rank 5")
    return {"y": p["a"] * p["b"], "nested": {"sum": p["a"] + p["b"], "list": [p["a"], p["b"]]}}
