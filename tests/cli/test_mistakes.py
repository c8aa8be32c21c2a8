"""User mistakes on the command line: each ends with exit code 2 and an error that names
what is wrong and where (file, field, parameter, choices), never a traceback."""
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCEN = REPO / "scenarios"


def _scenario(tmp, name, body):
    p = tmp / name
    p.write_text(body)
    return str(p)


STEP = 'robot = "6pus"\nduration = 0.5\n[controller]\ntype = "pd"\nkp = 300\nkd = 30\n[reference]\ntype = "step"\n'


def _recording_variants(tmp):
    """Copies of a valid recording with one thing wrong each: binary content, a bad
    parameter or a unit field in the sidecar, positions in mm."""
    import csv
    import json
    import shutil

    src = SCEN / "calibration_6pus_campaign"
    out = {}
    for name in ("binary", "badpar", "units", "mm"):
        shutil.copy(src.with_suffix(".csv"), tmp / f"{name}.csv")
        shutil.copy(src.with_suffix(".json"), tmp / f"{name}.json")
        out[name] = str(tmp / f"{name}.csv")
    (tmp / "binary.csv").write_bytes(b"\x82\x00\xff\x01\n\x02\n")
    for name, change in (("badpar", lambda m: m.setdefault("parameters", {}).update({"leg[9].L": 0.1})),
                         ("units", lambda m: m.update({"units": {"q": "mm"}}))):
        meta = json.loads((tmp / f"{name}.json").read_text())
        change(meta)
        (tmp / f"{name}.json").write_text(json.dumps(meta))
    rows = list(csv.reader(open(src.with_suffix(".csv"))))
    idx = [rows[0].index(c) for c in ("x", "y", "z")]
    with open(tmp / "mm.csv", "w", newline="") as f:
        csv.writer(f).writerows([rows[0]] + [[str(float(v) * 1000) if i in idx else v for i, v in enumerate(r)]
                                             for r in rows[1:]])
    return out


def _cases(tmp):
    garbage = tmp / "garbage.csv"
    garbage.write_bytes(b"\x82\x00\xff not a recording\n")
    bad = _recording_variants(tmp)
    return [
        (["diagnose", bad["binary"]], "is not a text CSV file (byte 0x82"),
        (["calibrate", bad["binary"]], "is not a text CSV file"),
        (["diagnose", bad["badpar"], "--no-replay", "--no-figures"], "badpar.json: parameters: 6pus has no parameter"),
        (["diagnose", bad["units"], "--no-replay", "--no-figures"], "units.q = 'mm'"),
        (["calibrate", bad["mm"]], "column 'x': values up to"),
        (["params", "hexapod"], "unknown robot 'hexapod' (known: 6pus"),
        (["params", "no/such/robot.toml"], "cannot read robot description no/such/robot.toml"),
        (["params", "6pus", "--set", "nope"], "no parameter set 'nope' (known: default)"),
        (["params", "quattro", "--set", "appendix_b"], "known: default, appendix_a"),
        (["run", str(tmp / "missing.toml")], "scenario file not found"),
        (["run", _scenario(tmp, "kp.toml", STEP.replace("kp = 300", 'kp = "300"')
                           + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.09, 0, 0, 0]\n")],
         "controller.kp: must be a number"),
        (["run", _scenario(tmp, "mm.toml", STEP + "from = [0, 0, 85, 0, 0, 0]\nto = [0, 0, 90, 0, 0, 0]\n")],
         "was it given in mm?"),
        (["run", _scenario(tmp, "deg.toml", STEP + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.085, 0, 0, 30]\n")],
         "was it given in degrees?"),
        (["run", _scenario(tmp, "far.toml", STEP + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.5, 0, 0, 0]\n")],
         "leg 1 cannot reach the pose"),
        (["run", _scenario(tmp, "ctl.toml", STEP.replace('type = "pd"', 'type = "pid2"')
                           + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.09, 0, 0, 0]\n")],
         "controller.type: must be"),
        (["run", _scenario(tmp, "nodur.toml", STEP.replace("duration = 0.5\n", "")
                           + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.09, 0, 0, 0]\n")], "duration: missing"),
        (["run", _scenario(tmp, "noto.toml", STEP + "from = [0, 0, 0.085, 0, 0, 0]\n")], "reference.to: missing"),
        (["run", _scenario(tmp, "bot.toml", STEP.replace('"6pus"', '"hexapod"')
                           + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.09, 0, 0, 0]\n")], "unknown robot 'hexapod'"),
        (["run", str(SCEN / "6pus_step_pd.toml"), "--plant", "banana"], "invalid choice: 'banana'"),
        (["run", str(SCEN / "6pus_step_pd.toml"), "--duration", "-1"], "must be a positive number of seconds"),
        (["diagnose", str(garbage)], "garbage.csv"),
        (["diagnose", str(tmp / "missing.csv")], "file not found"),
        (["calibrate", str(tmp / "missing.csv")], "file not found"),
        (["calibrate", str(garbage)], "garbage.csv"),
        (["calibrate", str(SCEN / "calibration_6pus_campaign.csv"), "--holdout", "2"], "holdout fraction"),
        (["quattro", "map", "--index", "alpha_x", "--out", str(tmp / "q")], "invalid choice: 'alpha_x'"),
        (["quattro", "cycle", "--out", str(tmp / "q"), "--set", "nope"], "unknown parameter set 'nope'"),
        (["discrepancy-demo", "--effect", "friction"], "it can hide: coulomb"),
        (["blind-case", "--robot", "quattro", "--effect", "nope", "--seed", "1"], "it can hide: coulomb"),
        (["sweep", str(tmp / "missing.toml")], "sweep spec not found"),
        (["export-ssp", str(SCEN / "6pus_letter_m_ct.toml"), "--out", str(tmp / "x.ssp")], "set-point"),
        (["export-ssp", str(tmp / "missing.toml"), "--out", str(tmp / "x.ssp")], "scenario file not found"),
        (["bench", "nope"], "invalid choice: 'nope'"),
        (["nosuchcommand"], "invalid choice: 'nosuchcommand'"),
        (["calibrate", str(SCEN / "calibration_6pus_campaign.csv"), "--solver", "bogus"], "invalid choice: 'bogus'"),
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--window", "-1"], "window = -1.0 must be"),
        (["sweep", str(SCEN / "sweeps" / "pd_gains.toml"), "--scheduler", "tcp://127.0.0.1:9", "--out",
          str(tmp / "sw")], "no Dask scheduler answers at tcp://127.0.0.1:9"),
        (["run", _scenario(tmp, "unit.toml", STEP.replace('type = "step"\n', 'type = "step"\nangle_unit = "grad"\n')
                           + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.09, 0, 0, 0]\n")],
         "reference.angle_unit: must be 'rad' or 'deg'"),
    ]


def test_every_mistake_is_one_error_with_exit_code_2(tmp_path):
    bad = []
    for argv, expect in _cases(tmp_path):
        p = subprocess.run([sys.executable, "-m", "cosim", *argv], cwd=REPO, capture_output=True, text=True,
                           timeout=120)
        err = p.stderr.strip()
        last = err.splitlines()[-1] if err else ""
        if p.returncode != 2 or "Traceback" in err or expect not in last or len(err.splitlines()) != 1:
            bad.append(f"cosim {' '.join(argv)}: exit {p.returncode}, stderr: {err[-400:]!r}")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("n", [37])
def test_the_corpus_is_large(tmp_path, n):
    assert len(_cases(tmp_path)) >= n


def test_a_reader_that_stops_early_gets_no_traceback():
    # `cosim params 6pus | head -1`: the pipe is closed before the table is written.
    cosim = Path(sys.executable).parent / "cosim"
    p = subprocess.Popen([str(cosim), "params", "6pus"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=60) == 0, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err
