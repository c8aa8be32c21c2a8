"""Drive the plant FMU with OSP libcosim (PyPI ``libcosimpy``), an FMI importer not written here.

Run as its own process by ``test_libcosim.py`` (a crash of a native importer must not take
pytest down):

    python libcosim_driver.py <fmu> <out.json> <n_steps> <step_s> [tau0 (JSON)] [outputs (JSON)]

The FMU runs as a Co-Simulation slave; the actuator efforts change at every step (held
over the step by libcosim, as by any FMI master) through an override manipulator, and a
last-value observer reads the outputs after every step.  The input sequence is
``input_sequence`` below, shared with the fmpy side of the test.
"""
import json
import sys

import numpy as np


def input_sequence(tau0, n, h, scale=0.05):
    """Actuator efforts [N or N m] held over step k = 0..n-1: a gentle sweep around tau0
    (``scale`` times a fixed pattern per joint)."""
    t = np.arange(n) * h
    w = np.array([1.0, -0.7, 0.4, 0.8, -0.5, 0.3])[:len(tau0)]
    return tau0[None, :] + scale * np.sin(2 * np.pi * 5.0 * t)[:, None] * w[None, :]


OUTPUTS = ["x", "y", "z", "rx", "ry", "rz", "q[1]", "q[2]", "q[3]", "q[4]", "q[5]", "q[6]", "zd"]


def main(fmu_path, out_path, n, h):
    from fmpy import read_model_description
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    md = read_model_description(fmu_path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    start = {v.name: float(v.start) for v in md.modelVariables if v.causality == "input"}
    tau_names = [f"tau[{i}]" for i in range(1, len(start) + 1)]
    tau0 = np.array(json.loads(sys.argv[5])) if len(sys.argv) > 5 else np.array([start[n] for n in tau_names])
    outputs = json.loads(sys.argv[6]) if len(sys.argv) > 6 else OUTPUTS
    scale = float(sys.argv[7]) if len(sys.argv) > 7 else 0.05
    taus = input_sequence(tau0, n, h, scale)

    step_ns = int(round(h * 1e9))
    exe = CosimExecution.from_step_size(step_ns)
    slave = CosimLocalSlave(fmu_path=fmu_path, instance_name="plant")
    idx = exe.add_local_slave(slave)
    if idx < 0:
        raise SystemExit("libcosim could not load the FMU")
    man = CosimManipulator.create_override()
    exe.add_manipulator(man)
    obs = CosimObserver.create_last_value()
    exe.add_observer(obs)
    out_refs = [vr[n] for n in outputs]
    tau_refs = [vr[n] for n in tau_names]

    rows = []
    for k in range(n):
        if not man.slave_real_values(idx, tau_refs, taus[k].tolist()):
            raise SystemExit(f"libcosim refused the input at step {k}")
        if not exe.step():
            raise SystemExit(f"libcosim step {k} failed")
        rows.append(obs.last_real_values(idx, out_refs))
    exe.stop()
    with open(out_path, "w") as f:
        json.dump({"outputs": outputs, "tau": taus.tolist(), "values": rows}, f)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
