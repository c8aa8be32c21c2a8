"""Run an SSP archive in OSP libcosim (PyPI ``libcosimpy``), an engine not written here.

Run as its own process by ``test_ssp.py`` (a crash of a native importer must not take
pytest down):

    python ssp_driver.py <archive.ssp> <out.json> <n_steps> <step_s>

libcosim reads the archive itself (``CosimExecution.from_ssp_file``: components, their
connections and parameter values); this driver only steps it and records, after every
step, the plant's pose and joints and the controller's efforts.
"""
import json
import sys


def main(path, out_path, n, h):
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.WARNING)
    exe = CosimExecution.from_ssp_file(path, step_size=int(round(h * 1e9)))
    infos = {s.name.decode(): s.index for s in exe.slave_infos()}
    if set(infos) != {"plant", "controller"}:
        raise SystemExit(f"libcosim loaded components {sorted(infos)}, expected plant and controller")
    refs = {name: {v.name.decode(): v.reference for v in exe.slave_variables(i)} for name, i in infos.items()}
    plant_out = [k for k in refs["plant"] if k in ("x", "y", "z", "rx", "ry", "rz", "theta")]
    plant_out += sorted(k for k in refs["plant"] if k.startswith("q["))
    taus = sorted(k for k in refs["controller"] if k.startswith("tau["))
    obs = CosimObserver.create_last_value()
    exe.add_observer(obs)
    rows = []
    for k in range(n):
        if not exe.step():
            raise SystemExit(f"libcosim step {k} failed")
        rows.append(obs.last_real_values(infos["plant"], [refs["plant"][v] for v in plant_out])
                    + obs.last_real_values(infos["controller"], [refs["controller"][v] for v in taus]))
    exe.stop()
    with open(out_path, "w") as f:
        json.dump({"columns": plant_out + taus, "values": rows}, f)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
