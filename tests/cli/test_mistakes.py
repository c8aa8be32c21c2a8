"""User mistakes on the command line: each ends with exit code 2 and one line that names what
is wrong and where (file, field, column, parameter, choices), never a traceback.

The corpus runs in this process through the CLI's ``main`` (fast); a few cases run as the
installed ``cosim`` command, to see the exit code and stderr a shell sees."""
import contextlib
import csv
import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.cli.common import COMMANDS
from cosim.cli.main import main

REPO = Path(__file__).resolve().parents[2]
SCEN = REPO / "scenarios"
EMPS = REPO / "data" / "emps"
ROOT = os.geteuid() == 0

STEP = 'robot = "6pus"\nduration = 0.5\n[controller]\ntype = "pd"\nkp = 300\nkd = 30\n[reference]\ntype = "step"\n'
HOLD = "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.09, 0, 0, 0]\n"


def _scenario(tmp, name, body):
    p = tmp / name
    p.write_text(body)
    return str(p)


def _emps_map(tmp, name, column, angle):
    """The EMPS map with ``angle = ...`` (wrap or unwrap) on one column entry."""
    text = (EMPS / "emps_map.toml").read_text()
    entry = {"q1": 'q1 = { variable = "qm", unit = "m"', "time": 'time = { variable = "t", unit = "s"'}[column]
    assert entry in text
    return _scenario(tmp, name, text.replace(entry, f'{entry}, angle = "{angle}"'))


def _recording_variants(tmp):
    """Copies of a valid recording with one thing wrong each: binary content, a bad
    parameter or a unit field in the sidecar, positions in mm, a sidecar naming another
    robot than the columns'."""
    src = SCEN / "calibration_6pus_campaign"
    out = {}
    for name in ("binary", "badpar", "units", "mm", "quattro", "linear_delta", "nosidecar"):
        shutil.copy(src.with_suffix(".csv"), tmp / f"{name}.csv")
        shutil.copy(src.with_suffix(".json"), tmp / f"{name}.json")
        out[name] = str(tmp / f"{name}.csv")
    (tmp / "binary.csv").write_bytes(b"\x82\x00\xff\x01\n\x02\n")
    (tmp / "nosidecar.json").unlink()
    for name, change in (("badpar", lambda m: m.setdefault("parameters", {}).update({"leg[9].L": 0.1})),
                         ("units", lambda m: m.update({"units": {"q": "mm"}})),
                         ("quattro", lambda m: m.update({"robot": "quattro", "parameters": {}})),
                         ("linear_delta", lambda m: m.update({"robot": "linear_delta", "parameters": {}}))):
        meta = json.loads((tmp / f"{name}.json").read_text())
        change(meta)
        (tmp / f"{name}.json").write_text(json.dumps(meta))
    rows = list(csv.reader(open(src.with_suffix(".csv"))))
    idx = [rows[0].index(c) for c in ("x", "y", "z")]
    with open(tmp / "mm.csv", "w", newline="") as f:
        csv.writer(f).writerows([rows[0]] + [[str(float(v) * 1000) if i in idx else v for i, v in enumerate(r)]
                                             for r in rows[1:]])
    return out


def _places(tmp):
    """Real file-system situations: a folder, a file that cannot be read, a folder that
    cannot be written, a path under a file.  As root (who reads and writes through file
    modes) the unreadable file is /proc/self/mem (reading it fails with EIO) and the
    read-only folder is under /sys (EPERM); otherwise modes 000 and 555."""
    folder = tmp / "a_folder"
    folder.mkdir()
    afile = tmp / "a_file.txt"
    afile.write_text("not a folder\n")
    if ROOT:
        unreadable, readonly = Path("/proc/self/mem"), Path("/sys/kernel/cosim_out")
    else:
        unreadable = tmp / "secret.toml"
        unreadable.write_text("x = 1\n")
        unreadable.chmod(0)
        ro = tmp / "readonly"
        ro.mkdir()
        ro.chmod(0o555)
        readonly = ro / "out"
    return {"folder": str(folder), "file": str(afile), "unreadable": str(unreadable), "readonly": str(readonly),
            "under_file": str(afile / "sub")}


# commands reading a file, with the rest of a valid command line; {} is the file
INPUTS = {"run": ["run", "{}"], "export-ssp": ["export-ssp", "{}", "--out", "{tmp}/x.ssp"],
          "view": ["view", "{}"], "diagnose": ["diagnose", "{}"], "calibrate": ["calibrate", "{}"],
          "sweep": ["sweep", "{}"], "params": ["params", "{}"], "diagnose --model":
          ["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--model", "{}"],
          "indices --robot": ["indices", "--robot", "{}", "--axis", "x=-0.01:0.01:3"],
          "blind-case --robot": ["blind-case", "--robot", "{}"],
          "blind-benchmark --robot": ["blind-benchmark", "--robot", "{}"],
          "discrepancy-demo --robot": ["discrepancy-demo", "--robot", "{}"],
          "parasitic": ["parasitic", "{}"], "map": ["map", "{}", "--out", "{tmp}/m.png"],
          "fmu": ["fmu", "{}", "--out", "{tmp}/fmus"], "urdf": ["urdf", "{}"], "identify": ["identify", "{}"],
          "import": ["import", "{}", "--map", str(EMPS / "emps_map.toml"), "--out", "{tmp}/imp"],
          "import --map": ["import", str(EMPS / "DATA_EMPS.mat"), "--map", "{}", "--out", "{tmp}/imp"],
          "import --robot": ["import", str(EMPS / "DATA_EMPS.mat"), "--map", str(EMPS / "emps_map.toml"), "--out",
                             "{tmp}/imp", "--robot", "{}"]}
# commands writing into a folder given by --out (or --keys); {} is the folder
OUT_DIRS = {"run": ["run", str(SCEN / "6pus_step_pd.toml"), "--out", "{}"],
            "diagnose": ["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--out", "{}"],
            "sweep": ["sweep", str(SCEN / "sweeps" / "pd_gains.toml"), "--out", "{}"],
            "calibrate": ["calibrate", str(SCEN / "calibration_6pus_campaign.csv"), "--out", "{}"],
            "quattro map": ["quattro", "map", "--out", "{}"], "quattro cycle": ["quattro", "cycle", "--out", "{}"],
            "indices": ["indices", "--robot", "6pus", "--axis", "x=-0.01:0.01:3", "--out", "{}"],
            "blind-case": ["blind-case", "--out", "{}"], "blind-case --keys": ["blind-case", "--keys", "{}"],
            "discrepancy-demo": ["discrepancy-demo", "--out", "{}"], "demo": ["demo", "--out", "{}"],
            "blind-benchmark": ["blind-benchmark", "--out", "{}"],
            "import": ["import", str(EMPS / "DATA_EMPS.mat"), "--map", str(EMPS / "emps_map.toml"), "--out", "{}"],
            "fmu": ["fmu", "6pus", "--out", "{}"]}
# commands writing one file given by --out
OUT_FILES = {"view": ["view", "{rec}", "--out", "{}"],
             "parasitic": ["parasitic", "tripod_3rps", "--map", "{}"],
             "map": ["map", "tripod_3rps", "--out", "{}"],
             "urdf": ["urdf", str(REPO / "robots" / "urdf" / "ur5.urdf"), "--out", "{}"],
             "identify": ["identify", "{rec}", "--out", "{}"],
             "export-ssp": ["export-ssp", str(SCEN / "6pus_step_pdg.toml"), "--out", "{}"]}


def _fill(argv, value, tmp, rec=""):
    return [a.replace("{}", value).replace("{tmp}", str(tmp)).replace("{rec}", rec) for a in argv]


def _file_system_cases(tmp):
    pl = _places(tmp)
    garbage = tmp / "garbage.bin"
    garbage.write_bytes(b"\x82\x00\xff not text\n")
    empty = tmp / "empty.toml"
    empty.write_text("")
    rec = str(SCEN / "calibration_6pus_campaign.csv")
    cases = []
    for name, argv in INPUTS.items():
        cases.append((_fill(argv, pl["folder"], tmp), f"{pl['folder']} is a folder; give a file"))
        cases.append((_fill(argv, pl["unreadable"], tmp), f"cannot read {pl['unreadable']}"))
    for name, argv in OUT_DIRS.items():
        cases.append((_fill(argv, pl["file"], tmp), f"{pl['file']} is an existing file; --out takes a folder"))
        cases.append((_fill(argv, pl["readonly"], tmp), f"cannot write in {pl['readonly']}"))
        cases.append((_fill(argv, pl["under_file"], tmp), "a part of this path is a file, not a folder"))
    for name, argv in OUT_FILES.items():
        cases.append((_fill(argv, pl["folder"], tmp, rec), f"{pl['folder']} is a folder; --out takes the file to write"))
        cases.append((_fill(argv, pl["readonly"] + "/x.out", tmp, rec), f"cannot write {pl['readonly']}/x.out"))
        cases.append((_fill(argv, pl["under_file"] + "/x.out", tmp, rec), "a part of this path is a file"))
    cases += [
        (["run", str(garbage)], "garbage.bin is not a text file (byte 0x82 at byte 0"), (["run", str(empty)], "empty.toml"),
        (["sweep", str(garbage)], "garbage.bin is not a text file"), (["sweep", str(empty)], "empty.toml"),
        (["export-ssp", str(garbage), "--out", str(tmp / "x.ssp")], "garbage.bin is not a text file"),
        (["view", str(garbage)], "garbage.bin"), (["params", str(garbage) + ".toml"], "garbage.bin.toml"),
    ]
    return cases


def _two_channel_rig(tmp):
    """A rig's MATLAB file with a test signal one sample short and a measured torque, maps
    that import them (one giving the torque no unit), and a recording whose sidecar does
    not state the measured effort's unit."""
    import numpy as np
    import scipy.io

    t = np.arange(200) * 1e-3
    scipy.io.savemat(tmp / "rig2.mat", {"t": t, "ang": np.sin(t), "u": np.cos(t), "w": np.zeros(199),
                                        "trq": np.cos(t)})
    head = 'robot = "pendulum"\n[columns]\ntime = "t"\nq1 = "ang"\nqd1 = { derive = "central_difference" }\n' \
           'tau1 = { variable = "u", unit = "N m" }\n'
    short = _scenario(tmp, "inject_map.toml", head + 'inject1 = { variable = "w", unit = "N m" }\n'
                      '[injection]\npoint = "command"\nin_effort = true\n')
    nounit = _scenario(tmp, "meas_map.toml", head + 'tau_meas1 = "trq"\n')
    rows = "\n".join(f"{k * 1e-3},{np.sin(k * 1e-3)},{np.cos(k * 1e-3)},{np.cos(k * 1e-3)},{np.cos(k * 1e-3)}"
                      for k in range(200))
    (tmp / "meas.csv").write_text("time,q1,qd1,tau1,tau_meas1\n" + rows + "\n")
    (tmp / "meas.json").write_text(json.dumps({"format": "pkm-recording/1", "robot": "pendulum",
                                               "units": {"time": "s", "q": "rad", "qd": "rad/s", "tau": "N m"}}))
    return [
        (["import", str(tmp / "rig2.mat"), "--map", short, "--out", str(tmp / "imp2")],
         "variable 'w' (column inject1): has 199 values, time (t) has 200"),
        (["import", str(tmp / "rig2.mat"), "--map", nounit, "--out", str(tmp / "imp2")],
         "columns.tau_meas1.unit: missing: a measured effort needs its unit"),
        (["diagnose", str(tmp / "meas.csv")], "has a measured effort (tau_meas columns) but the sidecar does not "
                                              "state its unit"),
    ]


def _cases(tmp):
    garbage = tmp / "garbage.csv"
    garbage.write_bytes(b"\x82\x00\xff not a recording\n")
    bad = _recording_variants(tmp)
    heavy = tmp / "heavy.json"
    heavy.write_text(json.dumps({"platform.m": "heavy"}))
    heavy2 = tmp / "heavy2.json"
    heavy2.write_text(json.dumps({"robot": "6pus", "parameters": {"platform.m": {"value": None, "unit": "kg"}}}))
    notjson = tmp / "notjson.json"
    notjson.write_text("{ platform.m = 1 }")
    one_s = _scenario(tmp, "step1s.toml", (SCEN / "6pus_step_pd.toml").read_text().replace("step = 0.001", "step = 1.0"))
    return _file_system_cases(tmp) + _two_channel_rig(tmp) + [
        # messages that each say what is wrong and where
        (["diagnose", bad["binary"]], "is not a text CSV file (byte 0x82"),
        # a campaign is several runs of one rig
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), str(SCEN / "calibration_fourbar_seed002.csv"),
          "--no-replay", "--no-figures"], "runs of two robots: calibration_fourbar_seed002 is of 'fourbar'"),
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--model", str(heavy)],
         'heavy.json: platform.m = "heavy" is not a finite number'),
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--model", str(heavy2)],
         "heavy2.json: parameters.platform.m.value = null is not a finite number"),
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--model", str(notjson)],
         "notjson.json: not a JSON parameter file (line 1, column 3)"),
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--model", str(tmp / "nope.json")],
         "nope.json: no such parameter file"),
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--model", "appendix_a"],
         "no parameter set 'appendix_a'"),
        (["diagnose", str(SCEN)], f"{SCEN} is a folder; give a file"),
        (["diagnose", bad["quattro"]], "names robot 'quattro' (4 arms, pose x y z rz) but the file has joint "
                                       "columns q1..q6 (6 joints): does the sidecar name the right robot?"),
        (["diagnose", bad["linear_delta"]], "names robot 'linear_delta' (3 sliders, pose x y z) but the file has joint "
                                            "columns q1..q6"),
        (["calibrate", bad["quattro"]], "does the sidecar name the right robot?"),
        (["view", bad["linear_delta"]], "does the sidecar name the right robot?"),
        (["diagnose", bad["nosidecar"]], "JSON sidecar nosidecar.json is missing"),
        (["run", one_s, "--out", str(tmp / "one_s")],
         "stopped in the step from t = 0 s to 1 s: leg 6 reached its stroke limit"),
        (["indices", "--robot", "6pus", "--axis", "x=-0.1:0.1:100000", "--axis", "y=-0.1:0.1:100000"],
         "a grid of 10,000,000,000 poses (100000 x 100000) needs about"),
        (["indices", "--robot", "6pus", "--axis", "x=-0.1:0.1:100000", "--axis", "y=-0.1:0.1:100000"],
         "use fewer points per axis"),
        (["indices", "--robot", "6pus", "--axis", "q=-0.1:0.1:3"], "6pus has no pose coordinate 'q'"),
        (["indices", "--robot", "6pus", "--axis", "x=-0.1:0.1"], "give NAME=START:STOP:N"),
        (["indices", "--robot", "6pus"], "give at least one --axis"),
        (["parasitic", "tripod_3rps", "--pose", "0.45", "0.1"], "--pose takes 3 values (z rx ry) for tripod_3rps"),
        (["parasitic", "tripod_3rps", "--param", "leg[9].px"], "tripod_3rps has no parameter named 'leg[9].px'"),
        (["parasitic", "tripod_3rps", "--map", str(tmp / "m.png"), "--grid", "1"], "--grid 1: give 2 to 201 points"),
        (["parasitic", "tripod_3rps", "--pose", "0.9", "0.0", "0.0"], "leg 1 joint q = "),
        (["map", "tripod_3rps", "--slices", "0"], "--slices 0: give 1 to 9 rows"),
        (["urdf", str(REPO / "robots" / "urdf" / "ur5.urdf"), "--tip", "forearm_link"],
         'tip link "forearm_link" is not fixed to the last moving link'),
        (["map", "tripod_3rps", "--span", "-1"], "span = -1.0: give the map's half-width about home as a positive"),
        (["map", "tripod_3rps", "--axes", "rx", "x"], "--axes: 'x' is not a coordinate of tripod_3rps"),
        # kept from the first corpus
        (["calibrate", bad["binary"]], "is not a text CSV file"),
        (["diagnose", bad["badpar"], "--no-replay", "--no-figures"], "badpar.json: parameters: 6pus has no parameter"),
        (["diagnose", bad["units"], "--no-replay", "--no-figures"], "units.q = 'mm'"),
        (["calibrate", bad["mm"]], "column 'x': values up to"),
        (["params", "hexapod"], "unknown robot 'hexapod' (known: fourbar, 6pus"),
        (["params", "no/such/robot.toml"], "cannot read robot description no/such/robot.toml"),
        (["params", "6pus", "--set", "nope"], "no parameter set 'nope' (known: default)"),
        (["params", "quattro", "--set", "appendix_b"], "known: default, appendix_a"),
        (["run", str(tmp / "missing.toml")], "scenario file not found"),
        (["run", _scenario(tmp, "kp.toml", STEP.replace("kp = 300", 'kp = "300"') + HOLD)],
         "controller.kp: must be a number"),
        (["run", _scenario(tmp, "mm.toml", STEP + "from = [0, 0, 85, 0, 0, 0]\nto = [0, 0, 90, 0, 0, 0]\n")],
         "was it given in mm?"),
        (["run", _scenario(tmp, "deg.toml", STEP + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.085, 0, 0, 30]\n")],
         "was it given in degrees?"),
        (["run", _scenario(tmp, "far.toml", STEP + "from = [0, 0, 0.085, 0, 0, 0]\nto = [0, 0, 0.5, 0, 0, 0]\n")],
         "leg 1 cannot reach pose (x, y, z, rx, ry, rz) = (0, 0, 0.5, 0, 0, 0)"),
        (["run", _scenario(tmp, "ctl.toml", STEP.replace('type = "pd"', 'type = "pid2"') + HOLD)],
         "controller.type: must be"),
        (["run", _scenario(tmp, "nodur.toml", STEP.replace("duration = 0.5\n", "") + HOLD)], "duration: missing"),
        (["run", _scenario(tmp, "noto.toml", STEP + "from = [0, 0, 0.085, 0, 0, 0]\n")], "reference.to: missing"),
        (["run", _scenario(tmp, "bot.toml", STEP.replace('"6pus"', '"hexapod"') + HOLD)], "unknown robot 'hexapod'"),
        (["run", _scenario(tmp, "syntax.toml", STEP + HOLD + "kd = = 3\n")], "syntax.toml: not valid TOML: Invalid value (at line 11"),
        (["run", str(SCEN / "6pus_step_pd.toml"), "--plant", "banana"], "invalid choice: 'banana'"),
        (["run", str(SCEN / "6pus_step_pd.toml"), "--duration", "-1"], "must be a positive number of seconds"),
        (["run", str(SCEN / "6pus_step_pd.toml"), "--duration", "abc"], "invalid float value: 'abc'"),
        (["run", str(SCEN / "6pus_step_pd.toml"), "--bogus"], "unrecognized arguments: --bogus"),
        (["run"], "the following arguments are required: scenario"),
        (["diagnose", str(garbage)], "garbage.csv"),
        (["diagnose", str(tmp / "missing.csv")], "file not found"),
        (["calibrate", str(tmp / "missing.csv")], "file not found"),
        (["calibrate", str(garbage)], "garbage.csv"),
        (["calibrate", str(SCEN / "calibration_6pus_campaign.csv"), "--holdout", "2"], "holdout fraction"),
        (["quattro", "map", "--index", "alpha_x", "--out", str(tmp / "q")], "invalid choice: 'alpha_x'"),
        (["quattro", "cycle", "--out", str(tmp / "q"), "--set", "nope"], "quattro has no parameter set 'nope' (known: default, appendix_a)"),
        (["quattro"], "the following arguments are required: action"),
        (["discrepancy-demo", "--effect", "friction"], "it can hide: coulomb"),
        (["blind-case", "--robot", "quattro", "--effect", "nope", "--seed", "1"], "it can hide: coulomb"),
        (["blind-case", "--robot", "hexapod"], "unknown robot 'hexapod'"),
        (["blind-benchmark", "--robot", "hexapod"], "unknown robot 'hexapod'"),
        (["sweep", str(tmp / "missing.toml")], "sweep spec not found"),
        (["sweep"], "give a sweep spec"),
        (["export-ssp", str(SCEN / "6pus_letter_m_ct.toml"), "--out", str(tmp / "x.ssp")], "set-point"),
        (["export-ssp", str(tmp / "missing.toml"), "--out", str(tmp / "x.ssp")], "scenario file not found"),
        (["export-ssp", str(SCEN / "6pus_step_pdg.toml")], "the following arguments are required: --out"),
        (["view", str(tmp / "missing.csv")], "file not found"),
        (["bench", "nope"], "invalid choice: 'nope'"),
        (["fmu", "6pus", "--fmi", "4", "--out", str(tmp / "fmus")], "invalid choice: 4"),
        (["fmu", "hexapod", "--out", str(tmp / "fmus")], "unknown robot 'hexapod'"),
        (["import", str(EMPS / "DATA_EMPS.mat"), "--out", str(tmp / "imp")], "the following arguments are required: --map"),
        (["import", str(EMPS / "DATA_EMPS.mat"), "--map", str(EMPS / "emps_map.toml"), "--out", str(tmp / "imp"),
          "--format", "xlsx"], "invalid choice: 'xlsx'"),
        (["import", str(EMPS / "DATA_EMPS.mat"), "--map", _scenario(tmp, "map_syntax.toml", "[robot\n"), "--out",
          str(tmp / "imp")], "map_syntax.toml: not valid TOML"),
        (["import", str(EMPS / "DATA_EMPS.mat"), "--map", _emps_map(tmp, "wrap_q.toml", "q1", "wrap"), "--out",
          str(tmp / "imp")], "q1 is a position in m (a prismatic joint): only an angle column"),
        (["import", str(EMPS / "DATA_EMPS.mat"), "--map", _emps_map(tmp, "wrap_t.toml", "time", "unwrap"), "--out",
          str(tmp / "imp")], "field columns.time.angle: time is a time: only an angle column"),
        *_log_mistakes(tmp),
        (["nosuchcommand"], "invalid choice: 'nosuchcommand'"),
        (["calibrate", str(SCEN / "calibration_6pus_campaign.csv"), "--solver", "bogus"], "invalid choice: 'bogus'"),
        (["diagnose", str(SCEN / "calibration_6pus_campaign.csv"), "--window", "-1"], "window = -1.0 must be"),
        (["sweep", str(SCEN / "sweeps" / "pd_gains.toml"), "--scheduler", "tcp://127.0.0.1:9", "--out",
          str(tmp / "sw")], "no Dask scheduler answers at tcp://127.0.0.1:9"),
        (["run", _scenario(tmp, "unit.toml", STEP.replace('type = "step"\n', 'type = "step"\nangle_unit = "grad"\n')
                           + HOLD)], "reference.angle_unit: must be 'rad' or 'deg'"),
    ]


def _log_mistakes(tmp):
    """Imports of a ROS 2 bag (written by rosbags) naming a topic, a field or an index it does
    not have, and of a bag with no messages: one line naming the file, topic and field."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    F = ts.types["std_msgs/msg/Float64MultiArray"]
    for name, n in (("bag", 3), ("empty_bag", 0)):
        with Writer(tmp / name, version=9) as w:
            c = w.add_connection("/state", F.__msgtype__, typestore=ts)
            for k in range(n):
                m = F(layout=ts.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0),
                      data=np.array([0.1 * k, 1.0, 2.0]))
                w.write(c, 1000 * k, ts.serialize_cdr(m, F.__msgtype__))
    body = ('robot = "pendulum"\n[columns]\ntime = {{ topic = "/state", field = "log_time" }}\n'
            'q1 = {{ topic = "{t}", field = "{f}" }}\nqd1 = {{ topic = "/state", field = "data[1]" }}\n'
            'tau1 = {{ topic = "/state", field = "data[2]" }}\n')

    def case(bag, t, f, expect):
        mp = _scenario(tmp, f"log_map_{len(t)}_{len(f)}_{bag}.toml", body.format(t=t, f=f))
        return ["import", str(tmp / bag), "--map", mp, "--out", str(tmp / "imp")], expect

    return [case("bag", "/stat", "data[0]", "bag: topic '/stat', field 'data[0]' (column q1): no such topic"),
            case("bag", "/state", "dta[0]", "topic '/state', field 'dta[0]' (column q1): std_msgs/msg/"
                                            "Float64MultiArray has no field 'dta'"),
            case("bag", "/state", "data[3]", "topic '/state', field 'data[3]' (column q1): index 3 is out of range"),
            case("empty_bag", "/state", "data[0]", "empty_bag: the bag has no messages")]


def _call(argv):
    """(exit code, stderr) of ``cosim ARGV`` run by the CLI's main in this process; an
    exception that escapes main is what a user would see as a traceback."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(argv)
        except BaseException as e:  # noqa: BLE001 - reported as the traceback it would be
            code = f"traceback: {type(e).__name__}: {e}"
    return code, err.getvalue()


def _wrong(argv, code, err, expect):
    lines = err.strip().splitlines()
    if code != 2 or "Traceback" in err or len(lines) != 1 or expect not in lines[0]:
        return f"cosim {' '.join(argv)}: exit {code}, stderr: {err[-600:]!r} (expected {expect!r})"
    return None


def test_every_mistake_is_one_line_with_exit_code_2(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # default outputs (results/...) land here
    cases = _cases(tmp_path)
    bad = [w for argv, expect in cases if (w := _wrong(argv, *_call(argv), expect))]
    assert not bad, f"{len(bad)} of {len(cases)}:\n" + "\n".join(bad)


def test_the_corpus_covers_every_command_and_every_file_system_mistake(tmp_path):
    cases = _cases(tmp_path)
    commands = {argv[0] for argv, _ in cases}
    untested = set(COMMANDS) - commands - {"robots"}  # `cosim robots` takes no file and no value
    assert not untested, f"commands with no mistake in the corpus: {sorted(untested)}"
    # every command with an input file, an output folder or an output file has each kind
    # of file-system mistake (checked against the commands' own options)
    import argparse
    import importlib

    cli = importlib.import_module("cosim.cli.common")
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()

    def actions(p):
        for a in p._actions:
            yield a
            for q in (a.choices or {}).values() if isinstance(a, argparse._SubParsersAction) else ():
                yield from actions(q)

    inputs = {v[0] for v in INPUTS.values()}
    for name, (fn, _) in COMMANDS.items():
        p = sub.add_parser(name)
        if hasattr(fn, "configure"):
            fn.configure(p)
        for a in actions(p):
            kind = {cli.output_dir: "dir", cli.output_file: "file"}.get(a.type)
            if kind:
                table = OUT_DIRS if kind == "dir" else OUT_FILES
                assert any(v[0] == name and a.option_strings[0] in v for v in table.values()), (name, a.dest)
            if a.type in (cli.input_file, cli.recording_file, cli.toml_file, cli.robot_arg):
                assert name in inputs, (name, a.dest)


@pytest.mark.parametrize("argv,expect", [
    (["run", "scenarios"], "scenarios is a folder; give a file"),
    (["indices", "--robot", "6pus", "--axis", "x=-0.1:0.1:100000", "--axis", "y=-0.1:0.1:100000"],
     "needs about 2.48 TB of memory"),
    (["run", "scenarios/6pus_step_pd.toml", "--out", "README.md"], "README.md is an existing file"),
])
def test_the_installed_command_gives_one_line_and_exit_code_2(argv, expect):
    cosim = Path(sys.executable).parent / "cosim"
    p = subprocess.run([str(cosim), *argv], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and expect in p.stderr, (p.returncode, p.stderr)
    assert p.stdout == ""


def test_a_reader_that_stops_early_gets_no_traceback():
    # `cosim params 6pus | head -1`: the pipe is closed before the table is written.
    cosim = Path(sys.executable).parent / "cosim"
    p = subprocess.Popen([str(cosim), "params", "6pus"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=60) == 0, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err
